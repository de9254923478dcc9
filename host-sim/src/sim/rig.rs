//! The test rig's physics, integrated at a fine step (RK4, 50 µs) in f64.
//!
//! This is deliberately *not* the monitor's model stepped at 1 ms: it is an
//! independent implementation of the physics of thesis ch. 5–6 with the
//! effects the monitor's model simplifies or leaves out:
//!
//! - stick–slip (Karnopp) friction with the exact exponential Stribeck
//!   curve, where the monitor uses a smooth sign;
//! - a sharp-cornered spool opening and a different laminar/turbulent
//!   orifice blend (Q ∝ Δp/(Δp² + δ²)^¼);
//! - separate flow coefficients per metering edge and per leakage edge;
//! - the exact pressure-dependent bulk modulus, its temperature drift, and
//!   temperature-dependent viscous friction;
//! - end stops;
//! - leak flows following a laminar or an orifice law, from an onset time;
//! - supply pressure droop and ripple, return-line back pressure.
//!
//! Sensors (lag, noise, offsets, quantisation) are in `sensors.rs`.
//!
//! Both the model and the data are the simulator's own: the rig's values
//! are a [`Rig`] (`rig_data.rs`, the reference rig's numbers written there
//! as literals), not the monitor's `Params`, and the crane's load and the
//! oil (bulk modulus with air, viscosity) are computed by the independent
//! `plant` crate's models. Nothing of the monitor — neither model code nor
//! model data types — computes this rig.

use super::rig_data::Rig;
use super::{BAR, LPM};

/// Points of the tabulated load over the stroke.
const LOAD_POINTS: usize = 721;

/// The crane's load over the stroke, from `plant`'s virtual-work
/// derivation, tabulated (its trigonometry per RK4 stage would dominate).
#[derive(Clone, Debug)]
struct LoadCurve {
    stroke_m: f64,
    /// Gravity load G(x), N (positive opposes extension), with the offset.
    gravity_n: Vec<f64>,
    /// Effective moving mass M(x), kg.
    mass_kg: Vec<f64>,
    /// ½·M'(x), kg/m.
    c2_kg_m: Vec<f64>,
}

impl LoadCurve {
    fn new(rig: &Rig) -> Self {
        let l = &rig.load;
        let (weight, inertia) = (l.scaled(l.gravity_scale), l.scaled(l.inertia_scale));
        let stroke_m = rig.cylinder.stroke_m;
        let x = |k: usize| stroke_m * k as f64 / (LOAD_POINTS - 1) as f64;
        let h = 1e-5;
        Self {
            stroke_m,
            gravity_n: (0..LOAD_POINTS)
                .map(|k| weight.gravity_force_n(x(k)))
                .collect(),
            mass_kg: (0..LOAD_POINTS)
                .map(|k| inertia.effective_mass_kg(x(k)))
                .collect(),
            c2_kg_m: (0..LOAD_POINTS)
                .map(|k| {
                    let m = |x: f64| inertia.effective_mass_kg(x);
                    0.25 * (m(x(k) + h) - m(x(k) - h)) / h
                })
                .collect(),
        }
    }

    /// (G, M, ½M') at `x`, linearly interpolated, clamped to the stroke.
    fn at(&self, x: f64) -> (f64, f64, f64) {
        let f = (x / self.stroke_m).clamp(0.0, 1.0) * (LOAD_POINTS - 1) as f64;
        let k = (f as usize).min(LOAD_POINTS - 2);
        let w = f - k as f64;
        let lerp = |v: &[f64]| v[k] + w * (v[k + 1] - v[k]);
        (
            lerp(&self.gravity_n),
            lerp(&self.mass_kg),
            lerp(&self.c2_kg_m),
        )
    }
}

/// How a leak's flow depends on its pressure difference.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum LeakLaw {
    /// Q = K·Δp (a long narrow gap; viscosity-dependent).
    Laminar,
    /// Q = K·√Δp (a sharp needle-valve orifice; viscosity-independent).
    Orifice,
}

/// A rig running: its data, the operating point and the leaks of the
/// scenario, and the load tabulated from the data.
#[derive(Clone, Debug)]
pub struct RigPhysics {
    /// The rig's hardware (reference or perturbed).
    rig: Rig,
    /// Oil temperature, °C.
    pub temp_c: f64,
    /// Supply set pressure, bar.
    pub supply_bar: f64,
    /// Internal leak coefficient (units per `internal_law`: m³/(s·Pa) or
    /// m³/(s·√Pa)).
    pub internal_k: f64,
    /// Internal leak law.
    pub internal_law: LeakLaw,
    /// External leak coefficient.
    pub external_k: f64,
    /// External leak law.
    pub external_law: LeakLaw,
    /// Leaks start at this time, s (0: present from the start).
    pub leak_onset_s: f64,
    /// The load over the stroke (from `plant`).
    load: LoadCurve,
}

/// Physical state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigState {
    /// Piston position, m.
    pub x: f64,
    /// Piston velocity, m/s.
    pub v: f64,
    /// Spool position, fraction of travel.
    pub xv: f64,
    /// Spool velocity, 1/s.
    pub vv: f64,
    /// Piston-chamber pressure, Pa.
    pub p3: f64,
    /// Rod-chamber pressure, Pa.
    pub p4: f64,
}

/// Flows and pressures beside the state, for sensors and truth.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigOutputs {
    /// Supply pressure at the valve, Pa.
    pub p2: f64,
    /// Tank pressure at the valve, Pa.
    pub p5: f64,
    /// Internal (artificial) leak flow, m³/s, piston → rod chamber.
    pub q_internal: f64,
    /// External (artificial) leak flow, m³/s, rod chamber → tank.
    pub q_external: f64,
}

impl RigPhysics {
    /// Rig `rig` at supply set pressure `supply_bar` (bar) and oil
    /// temperature `temp_c` (°C), with no leaks.
    pub fn new(rig: Rig, supply_bar: f64, temp_c: f64) -> Self {
        Self {
            load: LoadCurve::new(&rig),
            rig,
            temp_c,
            supply_bar,
            internal_k: 0.0,
            internal_law: LeakLaw::Laminar,
            external_k: 0.0,
            external_law: LeakLaw::Laminar,
            leak_onset_s: 0.0,
        }
    }

    /// The rig's hardware.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// ν(T_ref)/ν(T): laminar flows scale with it.
    fn laminar_factor(&self) -> f64 {
        let f = &self.rig.fluid;
        f.oil.viscosity_cst(f.reference_temperature_c) / f.oil.viscosity_cst(self.temp_c)
    }

    /// Leak flow through a leak of coefficient `k`, law `law`, at `dp` Pa.
    pub fn leak_flow(&self, k: f64, law: LeakLaw, dp: f64) -> f64 {
        match law {
            LeakLaw::Laminar => k * self.laminar_factor() * dp,
            // A sharp orifice with a short laminar region below 0.2 bar.
            LeakLaw::Orifice => k * dp / (dp * dp + (0.2 * BAR) * (0.2 * BAR)).powf(0.25),
        }
    }

    /// Supply and tank pressures given the flows drawn from P and returned
    /// to T (m³/s) at time `t`.
    fn port_pressures(&self, q_p: f64, q_t: f64, t: f64) -> (f64, f64) {
        let s = &self.rig.supply;
        let ref_q = 20.0 * LPM;
        let draw = (q_p.max(0.0) / ref_q).powi(2);
        let (amp, freq) = (s.ripple_bar, s.ripple_hz);
        let p2 = (self.supply_bar - s.droop_bar * draw) * BAR
            + amp * BAR * (2.0 * std::f64::consts::PI * freq * t).sin();
        let p5 = (s.tank_bar + s.tank_rise_bar * (q_t.max(0.0) / ref_q).powi(2)) * BAR;
        (p2, p5)
    }

    /// Time derivative of the state under spool command `u` at time `t`,
    /// with the port pressures used.
    pub fn derivative(&self, s: &RigState, u: f64, t: f64) -> (RigState, RigOutputs) {
        let rig = &self.rig;
        let c = &rig.cylinder;
        let vlv = &rig.valve;
        let lam = self.laminar_factor();
        let kv = |g: f64| g * LPM / BAR.sqrt();
        let k_edge = vlv.edge_leak_lpm_per_bar * LPM / BAR * lam;
        let open_pos = (s.xv - vlv.dead_zone).max(0.0);
        let open_neg = (-s.xv - vlv.dead_zone).max(0.0);
        let delta = vlv.laminar_dp_bar * BAR;
        let orifice = |dp: f64| dp / (dp * dp + delta * delta).powf(0.25);
        let kv_ext = kv(vlv.flow_gain_extend_lpm_sqrt_bar);
        let kv_ret = kv(vlv.flow_gain_retract_lpm_sqrt_bar);

        // Port pressures depend on the flows, which depend weakly on them:
        // one fixed-point pass from the set values is plenty.
        let (mut p2, mut p5) = (self.supply_bar * BAR, rig.supply.tank_bar * BAR);
        let mut flows = [0.0; 4];
        for _ in 0..2 {
            let g = vlv.edge_gain;
            let q_pa = kv_ext * g[0] * open_pos * orifice(p2 - s.p3);
            let q_bt = kv_ext * g[1] * open_pos * orifice(s.p4 - p5);
            let q_pb = kv_ret * g[2] * open_neg * orifice(p2 - s.p4);
            let q_at = kv_ret * g[3] * open_neg * orifice(s.p3 - p5);
            flows = [q_pa, q_bt, q_pb, q_at];
            let (a, b) = self.port_pressures(q_pa + q_pb, q_bt + q_at, t);
            p2 = a;
            p5 = b;
        }
        let [q_pa, q_bt, q_pb, q_at] = flows;
        let l = vlv.edge_leak;
        let leak_a = k_edge * (l[0] * (p2 - s.p3) - l[1] * (s.p3 - p5));
        let leak_b = k_edge * (l[2] * (p2 - s.p4) - l[3] * (s.p4 - p5));
        let seal = rig.leakage.seal_lpm_per_bar * LPM / BAR * lam * (s.p3 - s.p4);
        let leaking = t >= self.leak_onset_s;
        let q_int = if leaking {
            self.leak_flow(self.internal_k, self.internal_law, s.p3 - s.p4)
        } else {
            0.0
        };
        let q_ext = if leaking {
            self.leak_flow(self.external_k, self.external_law, s.p4 - p5)
        } else {
            0.0
        };
        let ext_base = rig.leakage.external_lpm_per_bar * LPM / BAR * lam * (s.p4 - p5);

        let xc = s.x.clamp(0.0, c.stroke_m);
        let vol_a = c.dead_volume_piston_m3 + c.piston_area_m2 * xc;
        let vol_b = c.dead_volume_rod_m3 + c.rod_side_area_m2 * (c.stroke_m - xc);
        // Warm oil is a little softer (≈ 0.4 %/°C).
        let soft = (1.0 - 0.004 * (self.temp_c - 25.0)).clamp(0.6, 1.2);
        let oil = &rig.fluid.oil;
        let beta3 = oil.bulk_modulus_bar(s.p3 / BAR) * BAR * soft;
        let beta4 = oil.bulk_modulus_bar(s.p4 / BAR) * BAR * soft;
        let dp3 = beta3 / vol_a * (q_pa - q_at + leak_a - seal - q_int - c.piston_area_m2 * s.v);
        let dp4 = beta4 / vol_b
            * (q_pb - q_bt + leak_b + seal + q_int - q_ext - ext_base + c.rod_side_area_m2 * s.v);

        // Mechanics with Karnopp stick–slip friction and end stops.
        let (gravity_n, mass_kg, c2_kg_m) = self.load.at(xc);
        let f_hyd = s.p3 * c.piston_area_m2 - s.p4 * c.rod_side_area_m2;
        let mut f_stop = 0.0;
        if s.x < 0.0 {
            f_stop = -2e8 * s.x - 2e5 * s.v.min(0.0);
        } else if s.x > c.stroke_m {
            f_stop = -2e8 * (s.x - c.stroke_m) - 2e5 * s.v.max(0.0);
        }
        let f_drive = f_hyd - gravity_n - c2_kg_m * s.v * s.v + f_stop;
        let fr = &rig.friction;
        // Viscous friction follows viscosity weakly.
        let b_visc = fr.viscous_ns_per_m / lam.powf(0.3);
        let v_stick = 1e-4;
        let acc = if s.v.abs() < v_stick && f_drive.abs() <= fr.breakaway_n {
            // Stuck: friction cancels the drive and the residual velocity
            // decays within a few steps.
            -s.v / 2e-4
        } else {
            let dir = if s.v.abs() < v_stick {
                f_drive.signum()
            } else {
                s.v.signum()
            };
            let f_fric = (fr.coulomb_n
                + (fr.breakaway_n - fr.coulomb_n) * (-fr.stribeck_s_per_m * s.v.abs()).exp())
                * dir
                + b_visc * s.v;
            (f_drive - f_fric) / mass_kg
        };

        // Spool: second-order servo loop with travel limits.
        let w = vlv.natural_frequency_rad_s;
        let cmd = (u + vlv.null_offset).clamp(-1.0, 1.0);
        let mut avv = w * w * (cmd - s.xv) - 2.0 * vlv.damping_ratio * w * s.vv;
        if (s.xv >= 1.0 && s.vv > 0.0) || (s.xv <= -1.0 && s.vv < 0.0) {
            avv = -s.vv / 1e-4;
        }
        let d = RigState {
            x: s.v,
            v: acc,
            xv: s.vv,
            vv: avv,
            p3: dp3,
            p4: dp4,
        };
        (
            d,
            RigOutputs {
                p2,
                p5,
                q_internal: q_int,
                q_external: q_ext,
            },
        )
    }

    /// Advance by `h` seconds with classical RK4 under command `u`.
    pub fn rk4(&self, s: &RigState, u: f64, t: f64, h: f64) -> (RigState, RigOutputs) {
        let add = |a: &RigState, d: &RigState, k: f64| RigState {
            x: a.x + k * d.x,
            v: a.v + k * d.v,
            xv: a.xv + k * d.xv,
            vv: a.vv + k * d.vv,
            p3: a.p3 + k * d.p3,
            p4: a.p4 + k * d.p4,
        };
        let (k1, out) = self.derivative(s, u, t);
        let (k2, _) = self.derivative(&add(s, &k1, h / 2.0), u, t + h / 2.0);
        let (k3, _) = self.derivative(&add(s, &k2, h / 2.0), u, t + h / 2.0);
        let (k4, _) = self.derivative(&add(s, &k3, h), u, t + h);
        let mut n = *s;
        n.x += h / 6.0 * (k1.x + 2.0 * k2.x + 2.0 * k3.x + k4.x);
        n.v += h / 6.0 * (k1.v + 2.0 * k2.v + 2.0 * k3.v + k4.v);
        n.xv += h / 6.0 * (k1.xv + 2.0 * k2.xv + 2.0 * k3.xv + k4.xv);
        n.vv += h / 6.0 * (k1.vv + 2.0 * k2.vv + 2.0 * k3.vv + k4.vv);
        n.p3 += h / 6.0 * (k1.p3 + 2.0 * k2.p3 + 2.0 * k3.p3 + k4.p3);
        n.p4 += h / 6.0 * (k1.p4 + 2.0 * k2.p4 + 2.0 * k3.p4 + k4.p4);
        n.xv = n.xv.clamp(-1.0, 1.0);
        // Cavitation: pressures cannot fall below vacuum.
        n.p3 = n.p3.max(-0.95 * BAR);
        n.p4 = n.p4.max(-0.95 * BAR);
        // Karnopp: a velocity that crossed zero while stuck is zero.
        (n, out)
    }

    /// A static starting point at position `x`: spool centred, pressures at
    /// the force balance the valve leakage would settle to.
    pub fn rest_state(&self, x: f64) -> RigState {
        let c = &self.rig.cylinder;
        let (gravity_n, _, _) = self.load.at(x);
        // Rod side near the leakage balance, piston side carries the load.
        let p4 = (0.5 * self.supply_bar * BAR).min(0.45 * self.supply_bar * BAR);
        let p3 = (gravity_n + p4 * c.rod_side_area_m2) / c.piston_area_m2;
        RigState {
            x,
            v: 0.0,
            xv: 0.0,
            vv: 0.0,
            p3,
            p4,
        }
    }
}
