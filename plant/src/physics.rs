//! The plant's equations of motion and their integration (classic RK4 at a
//! fixed step of at most 50 µs, in f64; inputs held over a sample).
//!
//! State: piston position x (m) and velocity v (m/s), spool position s and
//! rate (1, 1/s), chamber pressures pA, pB, supply pS, tank pT (bar, gauge),
//! friction bristle deflection z (m).
//!
//! - Load: `M(x)·ẍ = pA·A_A − pB·A_B − G(x) − ½M'(x)·ẋ² − F_f + F_stop`.
//! - Chambers: `C(p)·ṗ = Q_in − A·ẋ − leaks`, `C = V(x)/β(p) + V_hose/K_hose`.
//! - Supply: `C_S·ṗS = Q_pump(pS) − Q_P→A − Q_P→B`.
//! - Tank: `τ·ṗT = pT_static(Q_return) − pT`.

use crate::controller::Controller;
use crate::leak::LeakLaw;
use crate::load::LoadTable;
use crate::scenario::Profile;
use crate::valve::LPM;
use crate::RigSpec;

/// Largest integration step, s.
pub const MAX_STEP_S: f64 = 50e-6;
/// Largest integration step while the valve is nearly closed and the
/// piston slow and clear of the stops, s.
pub const QUIET_STEP_S: f64 = 100e-6;
/// Largest spool travel (and command) of a quiet sample, fraction.
const QUIET_OPENING: f64 = 0.08;
/// Largest piston speed of a quiet sample, m/s.
const QUIET_SPEED_M_S: f64 = 0.03;
/// Fraction of the supply line volume that is hose.
const SUPPLY_HOSE_FRACTION: f64 = 0.5;
/// Time the machine runs (holding the first setpoint) before the recording
/// starts, s.
pub const PRE_ROLL_S: f64 = 3.0;
/// Distance from a stroke end within which a piston counts as at the
/// stop, m (the bumper plus its compression).
pub const AT_STOP_M: f64 = 2e-4;

const N: usize = 9;
type State = [f64; N];

/// True values at one sample.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Sample {
    pub x: f64,
    pub v: f64,
    pub spool: f64,
    pub pa: f64,
    pub pb: f64,
    /// Supply pressure at the valve, including ripple, bar.
    pub ps: f64,
    pub pt: f64,
    /// Ripple at this instant, bar.
    pub ripple: f64,
    /// Internal / external leak, l/min (signed, nominal direction).
    pub q_int: f64,
    pub q_ext: f64,
    pub u: f64,
    pub temp_c: f64,
    pub x_ref: f64,
}

/// Everything a run's physics needs besides the rig.
#[derive(Clone, Debug)]
pub(crate) struct RunPhysics {
    pub law: LeakLaw,
    /// Leak coefficients (l/min at the reference), internal and external.
    pub c_int: f64,
    pub c_ext: f64,
    pub onset_s: f64,
    /// Oil temperature drift, °C/s.
    pub temp_rate_c_s: f64,
    pub sample_rate_hz: f64,
    /// Use [`QUIET_STEP_S`] in quiet samples (off only to test it).
    pub quiet_step: bool,
}

/// Inputs held over one sample.
struct Held {
    u: f64,
    fluidity: f64,
    viscous: f64,
    c_int: f64,
    c_ext: f64,
}

struct Model<'a> {
    rig: &'a RigSpec,
    load: LoadTable,
    law: LeakLaw,
    hose_a: f64,
    hose_b: f64,
    hose_s: f64,
}

impl Model<'_> {
    /// Leak flows (m³/s), internal and external, at pressures.
    #[inline]
    fn leaks(&self, h: &Held, pa: f64, pb: f64, pt: f64) -> (f64, f64) {
        (
            self.law.flow(h.c_int, pa - pb, h.fluidity),
            self.law.flow(h.c_ext, pb - pt, h.fluidity),
        )
    }

    #[inline]
    fn deriv(&self, ripple: f64, y: &State, h: &Held) -> State {
        let r = self.rig;
        let c = &r.cylinder;
        let [x, v, s, sv, pa, pb, ps, pt, z] = *y;
        // Valve and leaks.
        let ps_valve = ps + ripple;
        let q = r.valve.edge_flows(s, ps_valve, pa, pb, pt, h.fluidity);
        let (qi, qe) = self.leaks(h, pa, pb, pt);
        // Chambers.
        let va = (c.dead_volume_piston_m3 + c.piston_area_m2 * x).max(1e-6);
        let vb = (c.dead_volume_rod_m3 + c.rod_area_m2 * (c.stroke_m - x)).max(1e-6);
        let ca = va / r.fluid.bulk_modulus_bar(pa) + self.hose_a;
        let cb = vb / r.fluid.bulk_modulus_bar(pb) + self.hose_b;
        let dpa = (q[0] - q[1] - c.piston_area_m2 * v - qi) / ca;
        let dpb = (q[2] - q[3] + c.rod_area_m2 * v + qi - qe) / cb;
        // Supply and tank.
        let cs = r.supply.line_volume_m3 / r.fluid.bulk_modulus_bar(ps) + self.hose_s;
        let dps = (r.supply.pump_flow(ps, r.supply_bar) - q[0] - q[2]) / cs;
        let dpt = (r.supply.tank_static(q[1] + q[3] + qe) - pt) / r.supply.tank_tau_s;
        // Mechanics.
        let (m, dm, g) = self.load.at(x);
        let f_app = (pa * c.piston_area_m2 - pb * c.rod_area_m2) * 1e5 - g - 0.5 * dm * v * v
            + c.stop_force(x, v);
        let (ff, dz) = r.friction.force(v, z, f_app, m, h.viscous);
        let acc = (f_app - ff) / m;
        let ds = r.valve.spool_accel(h.u, s, sv);
        [v, acc, sv, ds, dpa, dpb, dps, dpt, dz]
    }
}

#[inline]
fn axpy(y: &State, k: &State, a: f64) -> State {
    let mut o = *y;
    for i in 0..N {
        o[i] += a * k[i];
    }
    o
}

/// Where a run's physics stands at the leak's onset: everything before it
/// is the same whatever the leak coefficients, so the leak calibration's
/// later passes start here instead of from the pre-roll (bit-identical:
/// the whole integration state is kept).
#[derive(Clone, Debug)]
pub(crate) struct Onset {
    /// Index of the first leaking step (pre-roll included).
    k: usize,
    y: State,
    ctrl: Controller,
    profile: Profile,
    /// The samples recorded before it.
    out: Vec<Sample>,
}

/// Run the physics of `rig` through `profile`: one [`Sample`] per
/// recorded sample (after a pre-roll of [`PRE_ROLL_S`]); from `resume`
/// on if given (taken by an earlier run of the same rig, profile and
/// run physics but for the leak coefficients). Second: the state at the
/// onset of a leak that starts after the first step (kept by the caller
/// for the next pass).
pub(crate) fn run(
    rig: &RigSpec,
    mut profile: Profile,
    p: &RunPhysics,
    resume: Option<&Onset>,
) -> (Vec<Sample>, Option<Onset>) {
    let c = &rig.cylinder;
    let model = Model {
        rig,
        load: LoadTable::new(&rig.load, c.stroke_m),
        law: p.law,
        hose_a: c.dead_volume_piston_m3 * c.hose_fraction / c.hose_stiffness_bar,
        hose_b: c.dead_volume_rod_m3 * c.hose_fraction / c.hose_stiffness_bar,
        hose_s: rig.supply.line_volume_m3 * SUPPLY_HOSE_FRACTION / c.hose_stiffness_bar,
    };
    let dt = 1.0 / p.sample_rate_hz;
    let n_fine = (dt / MAX_STEP_S).ceil().max(1.0) as usize;
    // Quiet samples (valve at most QUIET_OPENING open, piston slow, clear
    // of the stops) have no stiff orifice, friction or contact dynamics:
    // twice the step.
    let n_quiet = (dt / QUIET_STEP_S).ceil().max(1.0) as usize;
    let n_rows = (profile.duration_s * p.sample_rate_hz).round() as usize;
    let n_pre = (PRE_ROLL_S * p.sample_rate_hz).round() as usize;

    // Start at rest at the first setpoint, pressures near a static balance.
    let x0 = profile.start();
    let pb0 = 0.3 * rig.supply_bar;
    let (_, _, g0) = model.load.at(x0);
    let pa0 = (g0 / 1e5 + pb0 * c.rod_area_m2) / c.piston_area_m2;
    let mut y: State = [
        x0,
        0.0,
        0.0,
        0.0,
        pa0,
        pb0,
        rig.supply_bar,
        rig.supply.tank_bar,
        0.0,
    ];

    let nu_ref = rig.fluid.viscosity_cst(crate::REFERENCE_TEMP_C);
    let mut ctrl = Controller::default();
    let mut ripple = Vec::with_capacity(2 * n_fine + 1);
    let ripple_now = |rig: &RigSpec, t: f64| rig.supply.ripple(t);
    let mut out = Vec::with_capacity(n_rows);
    let mut first = 0;
    if let Some(r) = resume {
        (first, y, ctrl, profile) = (r.k, r.y, r.ctrl.clone(), r.profile.clone());
        out.extend_from_slice(&r.out);
    }
    let mut onset = None;
    for k in first..(n_pre + n_rows) {
        let t = (k as f64 - n_pre as f64) * dt;
        let temp_c = rig.temp_c + p.temp_rate_c_s * t.max(0.0);
        let nu = rig.fluid.viscosity_cst(temp_c);
        let leaking = p.onset_s <= 0.0 || t >= p.onset_s;
        // (A leak from the start leaks from the pre-roll on: no onset.)
        if leaking && p.onset_s > 0.0 && resume.is_none() && onset.is_none() {
            onset = Some(Onset {
                k,
                y,
                ctrl: ctrl.clone(),
                profile: profile.clone(),
                out: out.clone(),
            });
        }
        let (x_ref, v_ref) = profile.at(t.max(0.0));
        let u = match profile.step {
            Some((ts, a)) if t >= ts => a.clamp(-1.0, 1.0),
            _ => ctrl.step(&rig.controller, x_ref, v_ref, y[0], dt),
        };
        let held = Held {
            u,
            fluidity: nu_ref / nu,
            viscous: rig.friction.viscous_ns_per_m
                * (nu / nu_ref).powf(rig.friction.viscous_viscosity_exponent),
            c_int: if leaking { p.c_int } else { 0.0 },
            c_ext: if leaking { p.c_ext } else { 0.0 },
        };
        if k >= n_pre {
            let (qi, qe) = model.leaks(&held, y[4], y[5], y[7]);
            let ripple = ripple_now(rig, t);
            out.push(Sample {
                x: y[0],
                v: y[1],
                spool: y[2],
                pa: y[4],
                pb: y[5],
                ps: y[6] + ripple,
                pt: y[7],
                ripple,
                q_int: qi / LPM,
                q_ext: qe / LPM,
                u,
                temp_c,
                x_ref,
            });
        }
        let quiet = y[1].abs() < QUIET_SPEED_M_S
            && y[2].abs() < QUIET_OPENING
            && (u.clamp(-1.0, 1.0) + rig.valve.null_bias).abs() < QUIET_OPENING
            && y[0] > 0.001
            && y[0] < c.stroke_m - 0.001;
        let n_sub = if quiet && p.quiet_step {
            n_quiet
        } else {
            n_fine
        };
        let h = dt / n_sub as f64;
        rig.supply
            .ripple_series(t, 0.5 * h, &mut ripple, 2 * n_sub + 1);
        for j in 0..n_sub {
            let (r0, r1, r2) = (ripple[2 * j], ripple[2 * j + 1], ripple[2 * j + 2]);
            let k1 = model.deriv(r0, &y, &held);
            let k2 = model.deriv(r1, &axpy(&y, &k1, 0.5 * h), &held);
            let k3 = model.deriv(r1, &axpy(&y, &k2, 0.5 * h), &held);
            let k4 = model.deriv(r2, &axpy(&y, &k3, h), &held);
            for i in 0..N {
                y[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
            }
            // Rigid cylinder heads.
            let [x, v, ..] = &mut y;
            c.clamp_to_heads(x, v);
            // Spool travel limits.
            if y[2].abs() > 1.0 {
                y[2] = y[2].clamp(-1.0, 1.0);
                y[3] = 0.0;
            }
        }
    }
    (out, onset)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{RigSpec, Scenario};

    /// A pass resumed at the leak's onset is the pass run from the start,
    /// bit for bit, whatever coefficients the onset was taken under.
    #[test]
    fn a_pass_resumed_at_the_onset_is_the_pass_from_the_start() {
        let rig = RigSpec::random(3, 100.0, 40.0);
        let profile = Profile::new(&Scenario::ClosedLoop {
            duration_s: 2.0,
            seed: 4,
        });
        let mut p = RunPhysics {
            law: LeakLaw::Laminar,
            c_int: 0.4,
            c_ext: 0.2,
            onset_s: 1.2,
            temp_rate_c_s: 0.005,
            sample_rate_hz: 1000.0,
            quiet_step: true,
        };
        let (first, onset) = run(&rig, profile.clone(), &p, None);
        let onset = onset.expect("a leak after the start has an onset");
        assert_eq!(onset.k, 3000 + 1200);
        p.c_int = 0.9;
        p.c_ext = 0.05;
        let (whole, _) = run(&rig, profile.clone(), &p, None);
        let (resumed, again) = run(&rig, profile, &p, Some(&onset));
        assert!(again.is_none());
        assert_eq!(resumed.len(), whole.len());
        let bits = |s: &Sample| {
            [s.x, s.v, s.pa, s.pb, s.ps, s.pt, s.q_int, s.q_ext, s.u].map(f64::to_bits)
        };
        assert!(resumed.iter().zip(&whole).all(|(a, b)| bits(a) == bits(b)));
        // The coefficients matter after the onset only.
        assert!(first[..1200]
            .iter()
            .zip(&whole)
            .all(|(a, b)| bits(a) == bits(b)));
        assert!(first[1200..]
            .iter()
            .zip(&whole[1200..])
            .any(|(a, b)| a.q_int != b.q_int));
        // A leak from the start has no onset to resume at.
        p.onset_s = 0.0;
        assert!(run(
            &rig,
            Profile::new(&Scenario::ClosedLoop {
                duration_s: 0.5,
                seed: 4
            }),
            &p,
            None
        )
        .1
        .is_none());
    }

    /// The doubled step of quiet samples changes nothing that matters.
    #[test]
    fn the_quiet_step_is_accurate() {
        for seed in [1, 2] {
            let rig = RigSpec::random(seed, 100.0, 30.0);
            let profile = Profile::new(&Scenario::ClosedLoop {
                duration_s: 3.0,
                seed,
            });
            let mut p = RunPhysics {
                law: LeakLaw::Laminar,
                c_int: 0.3,
                c_ext: 0.1,
                onset_s: 0.0,
                temp_rate_c_s: 0.0,
                sample_rate_hz: 1000.0,
                quiet_step: true,
            };
            let (a, _) = run(&rig, profile.clone(), &p, None);
            p.quiet_step = false;
            let (b, _) = run(&rig, profile, &p, None);
            for (a, b) in a.iter().zip(&b) {
                assert!((a.x - b.x).abs() < 2e-5, "x {} vs {}", a.x, b.x);
                assert!((a.pa - b.pa).abs() < 0.05, "pa {} vs {}", a.pa, b.pa);
                assert!((a.pb - b.pb).abs() < 0.05, "pb {} vs {}", a.pb, b.pb);
                assert!(
                    (a.q_int - b.q_int).abs() < 2e-3,
                    "q {} vs {}",
                    a.q_int,
                    b.q_int
                );
            }
        }
    }
}
