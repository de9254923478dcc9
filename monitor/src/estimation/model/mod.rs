//! The six-state plant model of thesis §8.1.2 and its analytic Jacobian.
//!
//! State (scaled to O(1) so the f32 covariance is well conditioned):
//!
//! | index | state | unit of 1.0 |
//! |---|---|---|
//! | 0 | piston position x_p | 0.1 m |
//! | 1 | piston velocity ẋ_p | 0.1 m/s |
//! | 2 | spool position x_v | full travel |
//! | 3 | spool velocity ẋ_v/ω_v | full travel |
//! | 4 | piston-chamber pressure p3 | 100 bar |
//! | 5 | rod-chamber pressure p4 | 100 bar |
//!
//! Inputs: supply pressure p2, tank pressure p5, valve command u_v.
//! Measured: x_p, p3, p4. Two leak coefficients enter as parameters (or as
//! augmented states of the bank's leak hypotheses), in litres per minute
//! per 10 bar of pressure difference:
//!
//! - internal leak θ_i: across the piston seal, piston → rod chamber
//!   (thesis Leak 2), Q_i = θ_i·(p3 − p4)/10 bar;
//! - external leak θ_e: rod-side line → tank (thesis Leak 1, across the
//!   valve), Q_e = θ_e·(p4 − p5)/10 bar.
//!
//! Physics: force balance (eq. 6.16) with the pantograph load of ch. 5
//! (`load.rs`) and friction (eq. 6.17, corrected); continuity in each
//! chamber (eqs. 6.1–6.2) with the pressure-dependent bulk modulus
//! (eqs. 6.9–6.10, `fluid.rs`); valve spool dynamics (eq. 6.3); orifice
//! flows through the four metering edges (eqs. 6.11–6.14, `valve.rs`);
//! laminar leakage across the covered edges (eqs. 6.4–6.5) and the piston
//! seal (eq. 6.8). Beyond the thesis, each covered edge's land leakage
//! grows exponentially as the spool uncovers it and a chamber's two edges
//! may leak unequally ([`LandLeak`], calibrated): a real valve's pressure
//! gain at null, which the thesis' constant leakage lacks.

use crate::params::Params;
use crate::physics::fluid::BulkModulusTable;
pub use crate::physics::friction::stribeck_decay;
use crate::physics::load::{LoadTable, LoadTerms};
pub use crate::physics::units::{BAR, LEAK_UNIT, LPM_PER_M3S};
use crate::physics::valve::{
    hold_share, land_growth, opening, orifice, spool_at, SpoolStep, OPENING_ROUNDING,
};
use crate::real::Real;

mod jacobian;
#[cfg(test)]
mod tests;

pub use jacobian::{Eval, Jacobian};

/// Number of physical states.
pub const NX: usize = 6;
/// Index of piston position.
pub const XP: usize = 0;
/// Index of piston velocity.
pub const VP: usize = 1;
/// Index of spool position.
pub const XV: usize = 2;
/// Index of spool velocity.
pub const VV: usize = 3;
/// Index of piston-chamber pressure.
pub const P3: usize = 4;
/// Index of rod-chamber pressure.
pub const P4: usize = 5;

/// Unit of the scaled position and velocity states, m and m/s.
pub const X_REF: f64 = 0.1;
/// Unit of the scaled velocity state, m/s.
pub const V_REF: f64 = 0.1;
/// Unit of the scaled pressure states, Pa (100 bar).
pub const P_REF: f64 = 1.0e7;
/// Inputs held over one sample, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs<T> {
    /// Supply pressure p2, Pa (gauge).
    pub p_supply_pa: T,
    /// Tank pressure p5, Pa (gauge).
    pub p_tank_pa: T,
    /// Valve command u_v, normalised to [-1, 1].
    pub u_valve: T,
    /// Temperature factor on laminar leakage, ν(T_ref)/ν(T) (1 at the
    /// reference temperature).
    pub laminar_factor: T,
    /// The covered edges' land leakage at this command
    /// ([`Plant::land_leak`]).
    pub land: LandLeak<T>,
    /// The rod-side edges' metering at this command
    /// ([`Plant::rod_edges`]).
    pub rod: RodEdges<T>,
    /// The load and the chambers' bulk moduli, looked up once a sample
    /// ([`Plant::tabulated`]).
    pub tables: Tabulated<T>,
    /// Share of the hold's land-leakage model at this command
    /// ([`Plant::hold_share`]): 0 where the laminar state scales the land
    /// leakage everywhere.
    pub hold_share: T,
}

/// The model's state-dependent tables, looked up once a sample at one
/// state (the `both` filter's estimate before the step) for every filter
/// and substep: the pantograph's load at the piston position and each
/// chamber's bulk modulus at its pressure. Both tables interpolate
/// linearly, so each evaluation moves along the looked-up interval's slope
/// to its own state ([`Plant::eval`]): exact while the state stays in that
/// interval, as it does within a 1 ms step and between filters (their
/// states differ by a fraction of the pressure noise), and within the
/// bulk-modulus table's own 1 % where a state crosses one of its nodes;
/// the moving mass is taken as looked up (0.05–0.25 % per millimetre of
/// stroke, a fifth of a millimetre per step at the fastest moves). Looked up
/// per filter and substep the tables cost 1 200 instructions a sample
/// (sixteen interval searches and eight load interpolations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tabulated<T> {
    /// Piston position (m) and chamber pressures (Pa) they were looked up at.
    pub at: [T; 3],
    /// Load terms at that position.
    pub load: LoadTerms<T>,
    /// 1 / M(x), 1/kg.
    pub inv_mass: T,
    /// Bulk modulus of each chamber at its pressure, Pa (piston, rod side).
    pub beta: [T; 2],
    /// Its slope dβ/dp there.
    pub dbeta: [T; 2],
}

/// Flow of each direction's rod-side metering edge (B→T extending, P→B
/// retracting) per unit of its piston-side edge's (P→A, A→T) at one
/// command: the calibrated gain ratio times the ratio of the two edges'
/// openings, which differ when one edge opens later
/// (`valve.rod_edge_offset_*`). Taken at the commanded spool, like the land
/// leakage, once a sample for every filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodEdges<T> {
    /// B→T per P→A.
    pub extend: T,
    /// P→B per A→T.
    pub retract: T,
}

/// Largest ratio of a rod-side edge's opening to its piston-side edge's
/// ([`Plant::rod_edges`]): where the rod side opens first, the ratio grows
/// without bound as the piston side closes, while both flows vanish.
pub const MAX_ROD_OPENING_RATIO: f64 = 4.0;

/// Each covered metering edge's land leakage relative to
/// `valve.edge_leak_lpm_per_bar`, at one spool position: a laminar
/// conductance that grows e-fold per 1/`edge_leak_spool_gain` of travel
/// uncovering the edge, and is split unevenly between a chamber's two
/// edges by its skew. Positive travel uncovers P→A and B→T.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandLeak<T> {
    /// P→A.
    pub pa: T,
    /// A→T.
    pub at: T,
    /// P→B.
    pub pb: T,
    /// B→T.
    pub bt: T,
}

/// Valve uncertainty estimated online by every filter: the metering flow
/// gains of the two spool directions relative to the parameters (valve
/// coefficients vary ±5 % between valves, between directions, and with
/// wear). A 5 % gain error alone would look like a 0.3 l/min leak during
/// moves. (A spool-bias state was tried and rejected: at holds it is
/// confounded with the internal leak.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Nuisance<T> {
    /// Flow gain deviation for positive spool travel (P→A, B→T), in units
    /// of [`GAIN_REF`] (0 = as parameterised).
    pub gain_extend: T,
    /// Flow gain deviation for negative spool travel (P→B, A→T).
    pub gain_retract: T,
    /// Deviation of the healthy laminar leakage (valve edges, piston seal)
    /// from its modelled value, in units of
    /// [`LAMINAR_REF`]: oil viscosity halves from 25 °C to 40 °C and with
    /// it the leakage doubles. With a `temp_oil` reading this corrects the
    /// residual; without one it is the temperature compensation. Its
    /// signature differs from a leak's: edge leakage pulls each chamber
    /// towards half the supply pressure, so its effect changes sign with
    /// the chamber pressure, a leak's does not.
    pub laminar: T,
}

/// Unit of the scaled flow-gain deviations (10 %).
pub const GAIN_REF: f64 = 0.1;
/// Unit of the scaled laminar-leakage deviation (50 %).
pub const LAMINAR_REF: f64 = 0.5;

/// Leak coefficients, l/min per 10 bar.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Leaks<T> {
    /// Internal leak θ_i (piston seal, piston → rod chamber).
    pub internal: T,
    /// External leak θ_e (rod-side line → tank).
    pub external: T,
}

/// The plant, compiled from [`Params`] into SI constants and tables.
#[derive(Clone, Debug)]
pub struct Plant<T> {
    a_p: T,
    a_r: T,
    stroke: T,
    v_p0: T,
    v_r0: T,
    load: LoadTable<T>,
    beta: BulkModulusTable<T>,
    /// ω_v, rad/s.
    pub omega: T,
    two_zeta: T,
    kv_ext: T,
    kv_ret: T,
    rod_edge_ext: T,
    rod_edge_ret: T,
    rod_offset_ext: T,
    rod_offset_ret: T,
    k_ext_base: T,
    dead_zone: T,
    null_offset: T,
    open_eps: T,
    k_edge: T,
    /// Each edge's share of the land leakage with the spool centred:
    /// P→A 1 + s_a, A→T 1 − s_a, P→B 1 + s_b, B→T 1 − s_b.
    land_centred: LandLeak<T>,
    /// Exponent of the land leakage's growth per unit spool travel, 1/λ.
    land_gain: T,
    k_seal: T,
    /// `valve.hold_edge_leak_scale` (0: no hold model).
    hold_edge_scale: T,
    lam_dp: T,
    sqrt_lam_dp: T,
    f_coulomb: T,
    f_stribeck: T,
    c_stribeck: T,
    b_viscous: T,
    v_smooth2: T,
    omega_f64: f64,
    zeta_f64: f64,
}

impl<T: Real> Plant<T> {
    /// Compile `params` (assumed validated).
    pub fn new(params: &Params) -> Self {
        let c = &params.cylinder;
        let v = &params.valve;
        let fr = &params.friction;
        let kv = |lpm_sqrt_bar: f64| lpm_sqrt_bar / LPM_PER_M3S / BAR.sqrt();
        let lam = |lpm_per_bar: f64| lpm_per_bar / LPM_PER_M3S / BAR;
        Self {
            a_p: T::c(c.piston_area_m2),
            a_r: T::c(c.rod_side_area_m2),
            stroke: T::c(c.stroke_m),
            v_p0: T::c(c.dead_volume_piston_m3),
            v_r0: T::c(c.dead_volume_rod_m3),
            load: LoadTable::new(&params.load, c.stroke_m),
            beta: BulkModulusTable::new(&params.fluid),
            omega: T::c(v.natural_frequency_rad_s),
            two_zeta: T::c(2.0 * v.damping_ratio),
            kv_ext: T::c(kv(v.flow_gain_extend_lpm_sqrt_bar)),
            kv_ret: T::c(kv(v.flow_gain_retract_lpm_sqrt_bar)),
            rod_edge_ext: T::c(v.rod_edge_gain_extend),
            rod_edge_ret: T::c(v.rod_edge_gain_retract),
            rod_offset_ext: T::c(v.rod_edge_offset_extend),
            rod_offset_ret: T::c(v.rod_edge_offset_retract),
            k_ext_base: T::c(lam(params.leakage.external_lpm_per_bar)),
            dead_zone: T::c(v.dead_zone),
            null_offset: T::c(v.null_offset),
            open_eps: T::c(OPENING_ROUNDING),
            k_edge: T::c(lam(v.edge_leak_lpm_per_bar)),
            land_centred: LandLeak {
                pa: T::c(1.0 + v.edge_leak_skew_a),
                at: T::c(1.0 - v.edge_leak_skew_a),
                pb: T::c(1.0 + v.edge_leak_skew_b),
                bt: T::c(1.0 - v.edge_leak_skew_b),
            },
            land_gain: T::c(v.edge_leak_spool_gain),
            k_seal: T::c(lam(params.leakage.seal_lpm_per_bar)),
            hold_edge_scale: T::c(v.hold_edge_leak_scale),
            lam_dp: T::c(v.laminar_dp_bar * BAR),
            sqrt_lam_dp: T::c((v.laminar_dp_bar * BAR).sqrt()),
            f_coulomb: T::c(fr.coulomb_n),
            f_stribeck: T::c((fr.breakaway_n - fr.coulomb_n).max(0.0)),
            c_stribeck: T::c(fr.stribeck_s_per_m),
            b_viscous: T::c(fr.viscous_ns_per_m),
            v_smooth2: T::c(fr.smoothing_m_s * fr.smoothing_m_s),
            omega_f64: v.natural_frequency_rad_s,
            zeta_f64: v.damping_ratio,
        }
    }

    /// The discrete spool map for a step of `h` seconds.
    pub fn spool_step(&self, h: f64) -> SpoolStep<T> {
        SpoolStep::new(self.omega_f64, self.zeta_f64, h)
    }

    /// Share of the hold's land-leakage model at valve command `u_valve`
    /// (`valve.hold_edge_leak_scale`; [`hold_share`]): 1 with the spool
    /// the command puts inside the dead zone, falling as it opens an edge;
    /// 0 without a hold model.
    #[inline]
    pub fn hold_share(&self, u_valve: T) -> T {
        if self.hold_edge_scale <= T::ZERO {
            return T::ZERO;
        }
        hold_share(self.spool_command(u_valve).abs() - self.dead_zone)
    }

    /// Spool command including the valve's null bias.
    #[inline]
    pub fn spool_command(&self, u_valve: T) -> T {
        spool_at(u_valve, self.null_offset)
    }

    /// The covered edges' land leakage at valve command `u_valve`: the
    /// spool taken where the command puts it (it follows within a few
    /// milliseconds), held to the dead zone. Evaluated once per sample for
    /// every filter of the bank.
    #[inline]
    pub fn land_leak(&self, u_valve: T) -> LandLeak<T> {
        let x = self
            .spool_command(u_valve)
            .clamp_to(-self.dead_zone, self.dead_zone);
        let grow = land_growth(self.land_gain * x);
        let shrink = T::ONE / grow;
        let c = &self.land_centred;
        LandLeak {
            pa: c.pa * grow,
            at: c.at * shrink,
            pb: c.pb * shrink,
            bt: c.bt * grow,
        }
    }

    /// The rod-side edges' metering relative to the piston-side edges' at
    /// valve command `u_valve` ([`RodEdges`]). Only the direction the
    /// command opens has a ratio of openings; the closed direction keeps
    /// its gain ratio (its flows are zero, or nearly, whatever the ratio).
    #[inline]
    pub fn rod_edges(&self, u_valve: T) -> RodEdges<T> {
        let x = self.spool_command(u_valve);
        if x >= T::ZERO {
            RodEdges {
                extend: self.rod_edge_ext * self.opening_ratio(x, self.rod_offset_ext),
                retract: self.rod_edge_ret,
            }
        } else {
            RodEdges {
                extend: self.rod_edge_ext,
                retract: self.rod_edge_ret * self.opening_ratio(-x, self.rod_offset_ret),
            }
        }
    }

    /// The rod-side edge's opening per the piston-side edge's at spool
    /// `travel` toward them, the rod side opening `offset` later: a − offset
    /// over a (exactly 1 when the edges open together), at most
    /// [`MAX_ROD_OPENING_RATIO`]; 1 while the piston side is closed.
    #[inline(always)]
    fn opening_ratio(&self, travel: T, offset: T) -> T {
        let (piston, _) = opening(travel - self.dead_zone, self.open_eps);
        if piston > T::ZERO {
            ((piston - offset).max(T::ZERO) / piston).min(T::c(MAX_ROD_OPENING_RATIO))
        } else {
            T::ONE
        }
    }

    /// The load and bulk-modulus tables at scaled plant state `s`
    /// ([`Tabulated`]).
    #[inline]
    pub fn tabulated(&self, s: &[T; NX]) -> Tabulated<T> {
        let p_ref = T::c(P_REF);
        let at = [s[XP] * T::c(X_REF), s[P3] * p_ref, s[P4] * p_ref];
        let load = self.load.at(at[0]);
        let (beta3, dbeta3) = self.beta.at(at[1]);
        let (beta4, dbeta4) = self.beta.at(at[2]);
        Tabulated {
            at,
            inv_mass: T::ONE / load.mass_kg,
            load,
            beta: [beta3, beta4],
            dbeta: [dbeta3, dbeta4],
        }
    }

    /// Friction force (N) and its slope dF/dv (N·s/m) at velocity `v` (m/s).
    /// The sign function is smoothed as v/√(v² + v_s²) and the Stribeck
    /// decay e^(−y) is replaced by 1/(1 + y + y²/2 + y³/6) (within 2 % for
    /// y < 1, where the term matters), which keeps `exp` off the 1 ms path.
    #[inline]
    pub fn friction(&self, v: T) -> (T, T) {
        let root = (v * v + self.v_smooth2).sqrt();
        let sign = v / root;
        let dsign = self.v_smooth2 / (root * root * root);
        let y = self.c_stribeck * v.abs();
        let decay = stribeck_decay(y);
        // decay = 1/poly: d(decay)/d|v| = −poly'·c·decay².
        let dpoly = T::ONE + y * (T::ONE + y * T::c(0.5));
        let ddecay_dabsv = -(dpoly * self.c_stribeck) * decay * decay;
        let magnitude = self.f_coulomb + self.f_stribeck * decay;
        let force = magnitude * sign + self.b_viscous * v;
        // d|v|/dv · sign = |sign| ≥ 0 for the smoothed sign.
        let slope =
            magnitude * dsign + self.f_stribeck * ddecay_dabsv * sign.abs() + self.b_viscous;
        (force, slope)
    }

    /// Evaluate the model at scaled state `s`.
    #[inline(always)]
    pub fn eval(&self, s: &[T; NX], u: &Inputs<T>, nuis: Nuisance<T>, leaks: Leaks<T>) -> Eval<T> {
        let x_ref = T::c(X_REF);
        let v_ref = T::c(V_REF);
        let p_ref = T::c(P_REF);
        let xp = s[XP] * x_ref;
        let v = s[VP] * v_ref;
        let xv = s[XV];
        let p3 = s[P3] * p_ref;
        let p4 = s[P4] * p_ref;
        let p2 = u.p_supply_pa;
        let p5 = u.p_tank_pa;

        // --- Mechanics: M·a = p3·A_p − p4·A_r − F_f(v) − G(x) − c2(x)·v².
        // The tables along their slopes from where they were looked up.
        let tab = &u.tables;
        let load = &tab.load;
        let dx = xp - tab.at[0];
        let gravity = load.gravity_n + load.dgravity * dx;
        let c2 = load.c2_kg_m + load.dc2 * dx;
        let (f_fric, df_fric) = self.friction(v);
        let f_net = p3 * self.a_p - p4 * self.a_r - f_fric - gravity - c2 * v * v;
        let inv_m = tab.inv_mass;
        let acc = f_net * inv_m;
        let dacc_dx =
            (-load.dgravity - load.dc2 * v * v) * inv_m - f_net * load.dmass * inv_m * inv_m;
        let dacc_dv = (-df_fric - T::c(2.0) * c2 * v) * inv_m;

        // --- Valve: metering edges open past the dead zone.
        let (a_pos, da_pos) = opening(xv - self.dead_zone, self.open_eps);
        let (a_neg, da_neg) = opening(-xv - self.dead_zone, self.open_eps);
        let (lam, slam) = (self.lam_dp, self.sqrt_lam_dp);
        let zero = (T::ZERO, T::ZERO);
        let (g_pa, dg_pa) = if a_pos > T::ZERO {
            orifice(p2 - p3, lam, slam)
        } else {
            zero
        };
        let (g_bt, dg_bt) = if a_pos > T::ZERO {
            orifice(p4 - p5, lam, slam)
        } else {
            zero
        };
        let (g_pb, dg_pb) = if a_neg > T::ZERO {
            orifice(p2 - p4, lam, slam)
        } else {
            zero
        };
        let (g_at, dg_at) = if a_neg > T::ZERO {
            orifice(p3 - p5, lam, slam)
        } else {
            zero
        };
        // Healthy laminar leakage scales with the viscosity factor, from the
        // temperature reading and the filter's own estimate; at a hold with
        // a hold model, the edges' part is held (`valve.hold_edge_leak_scale`)
        // and the seal's follows the temperature alone.
        let laminar = u.laminar_factor * (T::ONE + nuis.laminar * T::c(LAMINAR_REF));
        let hold = u.hold_share;
        let (lam_edge, lam_seal) = if hold > T::ZERO {
            let meter = T::ONE - hold;
            (
                hold * u.laminar_factor * self.hold_edge_scale + meter * laminar,
                hold * u.laminar_factor + meter * laminar,
            )
        } else {
            (laminar, laminar)
        };
        let k_edge = self.k_edge * lam_edge;
        let gref = T::c(GAIN_REF);
        let kv_ext = self.kv_ext * (T::ONE + nuis.gain_extend * gref);
        let kv_ret = self.kv_ret * (T::ONE + nuis.gain_retract * gref);
        // Metering flows of each direction (into A, into B).
        // The rod-side edges (B→T, P→B) may pass more or less than the
        // piston-side edges of the same direction: the calibrated gain
        // ratios times the openings' ratio at this command (`Inputs::rod`).
        let kv_ext_b = kv_ext * u.rod.extend;
        let kv_ret_b = kv_ret * u.rod.retract;
        let ext_a = kv_ext * a_pos * g_pa;
        let ext_b = -(kv_ext_b * a_pos * g_bt);
        let ret_a = -(kv_ret * a_neg * g_at);
        let ret_b = kv_ret_b * a_neg * g_pb;
        // Land leakage of the covered edges, per edge at this command.
        let land = &u.land;
        let land_a = k_edge * (land.pa * (p2 - p3) - land.at * (p3 - p5));
        let land_b = k_edge * (land.pb * (p2 - p4) - land.bt * (p4 - p5));
        let q_a = ext_a + ret_a + land_a;
        let q_b = ext_b + ret_b + land_b;

        // --- Leaks: healthy seal leakage plus the hypothesised leaks.
        let leak_unit = T::c(LEAK_UNIT);
        let k_int_extra = leaks.internal * leak_unit;
        let k_seal = self.k_seal * lam_seal;
        let k_int = k_seal + k_int_extra;
        let k_ext_extra = leaks.external * leak_unit;
        // The rod-side baseline is a calibration correction, not a viscous
        // gap: it keeps the temperature factor but not the filter's
        // laminar estimate (which would make that collinear with a leak).
        let k_ext_base = self.k_ext_base * u.laminar_factor;
        let k_ext = k_ext_base + k_ext_extra;
        let dp_int = p3 - p4;
        let dp_ext = p4 - p5;
        let q_i = k_int * dp_int;
        let q_e = k_ext * dp_ext;

        // --- Continuity in each chamber.
        let xc = xp.clamp_to(T::ZERO, self.stroke);
        let in_stroke = if xp > T::ZERO && xp < self.stroke {
            T::ONE
        } else {
            T::ZERO
        };
        let vol_a = self.v_p0 + self.a_p * xc;
        let vol_b = self.v_r0 + self.a_r * (self.stroke - xc);
        let [dbeta3, dbeta4] = tab.dbeta;
        let beta3 = tab.beta[0] + dbeta3 * (p3 - tab.at[1]);
        let beta4 = tab.beta[1] + dbeta4 * (p4 - tab.at[2]);
        let ca = beta3 / vol_a;
        let cb = beta4 / vol_b;
        let flow_a = q_a - q_i - self.a_p * v;
        let flow_b = q_b + q_i - q_e + self.a_r * v;
        let dp3 = ca * flow_a;
        let dp4 = cb * flow_b;

        // (The land leakage follows the command, an input: no x_v term.)
        let dqa_dxv = kv_ext * da_pos * g_pa + kv_ret * da_neg * g_at;
        let dqb_dxv = -(kv_ret_b * da_neg * g_pb) - kv_ext_b * da_pos * g_bt;
        let dqa_dp3 =
            -(kv_ext * a_pos * dg_pa) - kv_ret * a_neg * dg_at - k_edge * (land.pa + land.at);
        let dqb_dp4 =
            -(kv_ret_b * a_neg * dg_pb) - kv_ext_b * a_pos * dg_bt - k_edge * (land.pb + land.bt);
        // Laminar factor: d(healthy leakage)/d(state), the edges' and the
        // seal's parts each by their own factor (the same without a hold
        // model, and as before).
        let dlam_state = u.laminar_factor * T::c(LAMINAR_REF);
        let (lam_a, lam_b, dlam) = if hold > T::ZERO {
            let d = (T::ONE - hold) * dlam_state;
            let (de, ds) = (d / lam_edge, d / lam_seal);
            (
                land_a * de - k_seal * dp_int * ds,
                land_b * de + k_seal * dp_int * ds,
                T::ONE,
            )
        } else {
            (
                land_a - k_seal * dp_int,
                land_b + k_seal * dp_int,
                dlam_state / laminar,
            )
        };
        // Gains: each direction's metering flows scale with its gain.
        let dge = self.kv_ext * gref / kv_ext;
        let dgr = self.kv_ret * gref / kv_ret;

        // Physical Jacobian entries, then scaled: ∂f_i/∂s_j = A_ij·S_j/S_i.
        let inv_va = T::ONE / vol_a;
        let inv_vb = T::ONE / vol_b;
        let x_over_v = x_ref / v_ref;
        let p_over_v = p_ref / v_ref;
        let inv_p = T::ONE / p_ref;
        let jac = Jacobian {
            v_x: dacc_dx * x_over_v,
            v_v: dacc_dv,
            v_p3: self.a_p * inv_m * p_over_v,
            v_p4: -(self.a_r * inv_m * p_over_v),
            p3_x: -(ca * self.a_p * inv_va * flow_a * in_stroke) * x_ref * inv_p,
            p3_v: -(ca * self.a_p) * v_ref * inv_p,
            p3_xv: ca * dqa_dxv * inv_p,
            p3_p3: dbeta3 * inv_va * flow_a + ca * (dqa_dp3 - k_int),
            p3_p4: ca * k_int,
            p3_li: -(ca * leak_unit * dp_int) * inv_p,
            p4_x: cb * self.a_r * inv_vb * flow_b * in_stroke * x_ref * inv_p,
            p4_v: cb * self.a_r * v_ref * inv_p,
            p4_xv: cb * dqb_dxv * inv_p,
            p4_p3: cb * k_int,
            p4_p4: dbeta4 * inv_vb * flow_b + cb * (dqb_dp4 - k_int - k_ext),
            p4_li: cb * leak_unit * dp_int * inv_p,
            p4_le: -(cb * leak_unit * dp_ext) * inv_p,
            p3_ge: ca * ext_a * dge * inv_p,
            p4_ge: cb * ext_b * dge * inv_p,
            p3_gr: ca * ret_a * dgr * inv_p,
            p4_gr: cb * ret_b * dgr * inv_p,
            p3_lam: ca * lam_a * dlam * inv_p,
            p4_lam: cb * lam_b * dlam * inv_p,
        };
        let omega = self.omega;
        let f = [
            s[VP] * (v_ref / x_ref),
            acc / v_ref,
            omega * s[VV],
            omega * (self.spool_command(u.u_valve) - xv) - omega * self.two_zeta * s[VV],
            dp3 * inv_p,
            dp4 * inv_p,
        ];
        Eval {
            f,
            jac,
            q_internal: k_int_extra * dp_int,
            q_external: k_ext_extra * dp_ext,
            q_valve_a: ext_a + ret_a,
        }
    }

    /// Advance the scaled state `s` by `dt` seconds in `n` ≥ 1 substeps with
    /// inputs held: the spool by its exact-in-steady-state trapezoidal map,
    /// velocity and pressures by linearly implicit Euler on their own
    /// (stiff) diagonal, velocity before position (symplectic), pressures
    /// with the velocity and spool updates of the same substep. Returns the
    /// model evaluated at the initial state, whose Jacobian the covariance
    /// prediction uses.
    pub fn advance(
        &self,
        s: &mut [T; NX],
        u: &Inputs<T>,
        nuis: Nuisance<T>,
        leaks: Leaks<T>,
        step: &Step<T>,
    ) -> Eval<T> {
        // (A small integer: exact in f32, and no software f64 on the MCU.)
        let h = step.dt / T::from_f32(step.substeps as f32);
        let cmd = self.spool_command(u.u_valve);
        // The first substep is peeled off: only its evaluation is returned,
        // so in the later ones the compiler drops the Jacobian entries the
        // substep itself does not use (`eval` is inlined into both).
        let first = self.eval(s, u, nuis, leaks);
        self.substep(s, &first, h, cmd, &step.spool);
        for _ in 1..step.substeps {
            let e = self.eval(s, u, nuis, leaks);
            self.substep(s, &e, h, cmd, &step.spool);
        }
        first
    }

    /// One substep of `h` seconds from the model `e` evaluated at `s`.
    #[inline(always)]
    fn substep(&self, s: &mut [T; NX], e: &Eval<T>, h: T, cmd: T, spool: &SpoolStep<T>) {
        let j = &e.jac;
        let [xv, vv] = spool.apply([s[XV], s[VV]], cmd);
        let dxv = xv - s[XV];
        s[XV] = xv;
        s[VV] = vv;
        let dv = h * e.f[VP] / (T::ONE - h * stiff(j.v_v));
        s[VP] += dv;
        s[XP] += h * s[VP] * T::c(V_REF / X_REF);
        let f3 = e.f[P3] + j.p3_v * dv + j.p3_xv * dxv;
        let f4 = e.f[P4] + j.p4_v * dv + j.p4_xv * dxv;
        s[P3] += h * f3 / (T::ONE - h * stiff(j.p3_p3));
        s[P4] += h * f4 / (T::ONE - h * stiff(j.p4_p4));
    }
}

/// One prediction step: its length and how it is integrated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step<T> {
    /// Length, s.
    pub dt: T,
    /// Integration substeps.
    pub substeps: u32,
    /// The spool map for one substep (`Plant::spool_step(dt / substeps)`).
    pub spool: SpoolStep<T>,
}

/// The part of a diagonal Jacobian entry treated implicitly: only its
/// damping (negative) part, so 1 − h·d ≥ 1 never divides by zero.
#[inline(always)]
pub fn stiff<T: Real>(d: T) -> T {
    d.min(T::ZERO)
}
