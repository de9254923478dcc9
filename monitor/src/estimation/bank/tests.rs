use super::transition::Transition;
use super::*;
use crate::estimation::ekf::EkfError;
use crate::estimation::model::BAR;
use crate::estimation::model::{
    Eval, Inputs, Leaks, Nuisance, Plant, Step, NX, P3, P4, VP, VV, V_REF, XP, XV, X_REF,
};
use crate::hypothesis::Hypothesis;
use crate::params::Params;
use crate::physics::valve::SpoolStep;
use crate::real::Real;
use nalgebra::SMatrix;

/// A plant, a step context and the filter settings at an operating
/// point of the reference rig: moving with the valve open, or holding
/// with the spool in the dead zone.
struct Setting<T: Real> {
    plant: Plant<T>,
    ctx: StepContext<T>,
    noise: ProcessNoise<T>,
    r: [T; NZ],
    s0: [T; NX],
}

impl<T: Real> Setting<T> {
    /// Look the model's tables up where filter `f` puts the plant, as
    /// the monitor does once a sample.
    fn tables_at<const N: usize>(&mut self, f: &HypothesisFilter<T, N>) {
        let at: [T; NX] = core::array::from_fn(|i| f.ekf.x[i]);
        self.ctx.inputs.tables = self.plant.tabulated(&at);
    }
}

/// Operating points: valve command and scaled plant state
/// `[x_p, ẋ_p, x_v, ẋ_v, p3, p4]`.
const POINTS: [(f64, [f64; NX]); 5] = [
    // Extending with the valve open.
    (0.2, [0.5, 0.2, 0.2, 0.0, 0.3, 0.12]),
    // Holding, spool in the dead zone.
    (0.0, [0.9, 0.0, 0.0, 0.0, 0.214, 0.129]),
    // Retracting fast, spool still moving.
    (-0.15, [1.2, -0.3, -0.15, 0.1, 0.14, 0.22]),
    // Near the stroke end, laminar orifice region (Δp < 1 bar).
    (0.3, [0.02, 0.0, 0.3, 0.0, 0.496, 0.012]),
    // Past the stroke end (the position terms vanish).
    (0.0, [1.85, 0.0, 0.0, 0.0, 0.2, 0.1]),
];

fn setting<T: Real>(moving: bool) -> Setting<T> {
    at_point(if moving { POINTS[0] } else { POINTS[1] })
}

fn at_point<T: Real>((u, s0): (f64, [f64; NX])) -> Setting<T> {
    let params = Params::nominal();
    let plant = Plant::<T>::new(&params);
    let f = &params.filter;
    let ctx = StepContext {
        inputs: Inputs {
            p_supply_pa: T::c(50.0 * BAR),
            p_tank_pa: T::c(0.8 * BAR),
            u_valve: T::c(u),
            laminar_factor: T::ONE,
            land: plant.land_leak(T::c(u)),
            rod: plant.rod_edges(T::c(u)),
            tables: plant.tabulated(&core::array::from_fn(|i| T::c(s0[i]))),
            hold_share: T::ZERO,
        },
        step: Step {
            dt: T::c(0.001),
            substeps: 2,
            spool: plant.spool_step(0.0005),
        },
        spool_dt: plant.spool_step(0.001),
        pressure_lag_s: T::c(params.sensors.pressure_lag_s),
        learning: T::c(0.7),
        gain_learning: T::c(0.4),
        leak_floor: [T::c(-1.0), T::c(-1.0)],
        laminar_floor: T::c(-2.0),
        // The dense reference has no end stops: keep them out of reach.
        stroke: T::c(1.0e3),
    };
    let gain = f.q_gain / 0.01;
    let noise = ProcessNoise {
        base: [
            T::c(f.q_position),
            T::c(f.q_velocity),
            T::c(f.q_spool),
            T::c(f.q_spool_rate),
            T::c(f.q_pressure),
            T::c(f.q_pressure),
            T::c(gain),
            T::c(gain),
            T::c(f.q_laminar / 0.25),
        ],
        leak: T::c(f.q_leak),
    };
    let sx = params.sensors.position_noise_m / 0.1;
    let sp = params.sensors.pressure_noise_bar * BAR / 1e7;
    Setting {
        plant,
        ctx,
        noise,
        r: [T::c(sx * sx), T::c(sp * sp), T::c(sp * sp)],
        s0: s0.map(T::c),
    }
}

/// One step with readings slightly off the filter's own prediction.
fn step<T: Real, const N: usize>(
    f: &mut HypothesisFilter<T, N>,
    s: &Setting<T>,
) -> Result<(), EkfError> {
    let x = &f.ekf.x;
    let m = Measurement {
        z: [x[XP] + T::c(1e-4), x[P3] + T::c(1e-3), x[P4] - T::c(1e-3)],
        r: s.r,
    };
    let q = s.noise.variances(s.ctx.step.dt);
    f.step(&s.plant, &s.ctx, &q, &m).map(|_| ())
}

/// A filter of hypothesis `h` run for 200 steps: the covariance is
/// populated (but for the gain of the spool direction never used).
fn settled<T: Real, const N: usize>(h: Hypothesis, s: &Setting<T>) -> HypothesisFilter<T, N> {
    let p0 = [T::c(1e-3); NB];
    let mut f = HypothesisFilter::new(h, &s.s0, &p0, T::c(0.1));
    for _ in 0..200 {
        step(&mut f, s).expect("a healthy filter step");
    }
    f
}

/// A NaN or infinity anywhere in P or x fails the very next step with
/// `NonFinite`, although only x and the diagonal are checked.
fn non_finite_anywhere_fails_the_next_step<T: Real, const N: usize>(h: Hypothesis) {
    for moving in [true, false] {
        let s = setting::<T>(moving);
        let good = settled::<T, N>(h, &s);
        for bad in [T::c(f64::NAN), T::c(f64::INFINITY), T::c(f64::NEG_INFINITY)] {
            for a in 0..N {
                for b in a..N {
                    let mut f = good.clone();
                    f.ekf.p[(a, b)] = bad;
                    f.ekf.p[(b, a)] = bad;
                    let got = step(&mut f, &s);
                    let at = (h, moving, bad, a, b);
                    assert_eq!(got, Err(EkfError::NonFinite), "P at {at:?}");
                }
                let mut f = good.clone();
                f.ekf.x[a] = bad;
                let got = step(&mut f, &s);
                assert_eq!(got, Err(EkfError::NonFinite), "x at {:?}", (h, a));
            }
        }
    }
}

/// Φ as the dense code built it before the sparse form (reference).
fn dense_transition<T: Real, const N: usize>(
    h: Hypothesis,
    e: &Eval<T>,
    dt: T,
    spool: &SpoolStep<T>,
) -> SMatrix<T, N, N> {
    let j = &e.jac;
    let mut phi = SMatrix::<T, N, N>::identity();
    let stiff = crate::estimation::model::stiff::<T>;
    let g = dt / (T::ONE - dt * stiff(j.v_v));
    phi[(VP, XP)] = g * j.v_x;
    phi[(VP, VP)] = T::ONE + g * j.v_v;
    phi[(VP, P3)] = g * j.v_p3;
    phi[(VP, P4)] = g * j.v_p4;
    let ratio = dt * T::c(V_REF / X_REF);
    for c in [XP, VP, P3, P4] {
        let v = phi[(VP, c)];
        phi[(XP, c)] += ratio * v;
    }
    phi[(XV, XV)] = spool.phi[0][0];
    phi[(XV, VV)] = spool.phi[0][1];
    phi[(VV, XV)] = spool.phi[1][0];
    phi[(VV, VV)] = spool.phi[1][1];
    let g3 = dt / (T::ONE - dt * stiff(j.p3_p3));
    phi[(P3, XP)] = g3 * j.p3_x;
    phi[(P3, VP)] = g3 * j.p3_v;
    phi[(P3, XV)] = g3 * j.p3_xv;
    phi[(P3, P3)] = T::ONE + g3 * j.p3_p3;
    phi[(P3, P4)] = g3 * j.p3_p4;
    let g4 = dt / (T::ONE - dt * stiff(j.p4_p4));
    phi[(P4, XP)] = g4 * j.p4_x;
    phi[(P4, VP)] = g4 * j.p4_v;
    phi[(P4, XV)] = g4 * j.p4_xv;
    phi[(P4, P3)] = g4 * j.p4_p3;
    phi[(P4, P4)] = T::ONE + g4 * j.p4_p4;
    phi[(P3, GAIN_EXT)] = g3 * j.p3_ge;
    phi[(P4, GAIN_EXT)] = g4 * j.p4_ge;
    phi[(P3, GAIN_RET)] = g3 * j.p3_gr;
    phi[(P4, GAIN_RET)] = g4 * j.p4_gr;
    phi[(P3, LAMINAR)] = g3 * j.p3_lam;
    phi[(P4, LAMINAR)] = g4 * j.p4_lam;
    if let Some(i) = internal_index(h) {
        phi[(P3, i)] = g3 * j.p3_li;
        phi[(P4, i)] = g4 * j.p4_li;
    }
    if let Some(i) = external_index(h) {
        phi[(P4, i)] = g4 * j.p4_le;
    }
    phi
}

/// The model at an operating point, with non-zero nuisance and leaks
/// so that every Jacobian entry is exercised.
fn eval_at<T: Real>(s: &Setting<T>) -> Eval<T> {
    let nuis = Nuisance {
        gain_extend: T::c(0.3),
        gain_retract: T::c(-0.2),
        laminar: T::c(0.4),
    };
    let leaks = Leaks {
        internal: T::c(0.4),
        external: T::c(0.3),
    };
    s.plant.eval(&s.s0, &s.ctx.inputs, nuis, leaks)
}

/// Sparse Φ and prediction against the dense references, at every
/// operating point, on random SPD covariances: Φ exactly, the
/// prediction within `tol` of √(P_aa·P_bb) of the result.
fn prediction_matches_dense<T: Real, const N: usize>(h: Hypothesis, tol: f64) {
    let mut rng = crate::estimation::ekf::TestRng(0x9e37_79b9_7f4a_7c15 ^ h as u64);
    for point in POINTS {
        let s = at_point::<T>(point);
        let e = eval_at(&s);
        let leaks = leak_indices::<N>(h);
        let phi = Transition::<T, N>::new(&e, s.ctx.step.dt, &s.ctx.spool_dt, leaks);
        let dense = dense_transition::<T, N>(h, &e, s.ctx.step.dt, &s.ctx.spool_dt);
        assert_eq!(phi.dense(), dense, "{h:?} at {point:?}");
        let q = s.noise.variances(s.ctx.step.dt);
        let q_n: [T; N] = core::array::from_fn(|i| q[i]);
        for _ in 0..40 {
            let p0 = rng.spd::<T, N>();
            let mut fast = p0;
            phi.predict_covariance(&mut fast, &q);
            let mut slow = p0;
            crate::estimation::ekf::predict_covariance_dense(&mut slow, &dense, &q_n);
            // The prediction writes the upper triangle only.
            for a in 0..N {
                for b in a..N {
                    let scale = (slow[(a, a)] * slow[(b, b)]).sqrt().to_f64();
                    let d = (fast[(a, b)] - slow[(a, b)]).abs().to_f64() / scale;
                    assert!(d <= tol, "{h:?} at {point:?}: P[{a}, {b}] differs by {d:e}");
                }
                for b in 0..a {
                    assert_eq!(fast[(a, b)], p0[(a, b)], "lower triangle untouched");
                }
            }
        }
    }
}

#[test]
fn sparse_prediction_equals_the_dense_product() {
    // The same products, summed in another order (one triangle of the
    // plant block; row x_p from row ẋ_p): rounding differences only,
    // a few units in the last place (seen: f64 5e-16, f32 5e-7).
    prediction_matches_dense::<f64, { NB }>(Hypothesis::Healthy, 2e-15);
    prediction_matches_dense::<f64, { NB + 1 }>(Hypothesis::Internal, 2e-15);
    prediction_matches_dense::<f64, { NB + 1 }>(Hypothesis::External, 2e-15);
    prediction_matches_dense::<f64, { NB + 2 }>(Hypothesis::Both, 2e-15);
    prediction_matches_dense::<f32, { NB }>(Hypothesis::Healthy, 2e-6);
    prediction_matches_dense::<f32, { NB + 1 }>(Hypothesis::Internal, 2e-6);
    prediction_matches_dense::<f32, { NB + 1 }>(Hypothesis::External, 2e-6);
    prediction_matches_dense::<f32, { NB + 2 }>(Hypothesis::Both, 2e-6);
}

/// The whole filter step as the dense code did it: nonlinear mean,
/// dense Φ·P·Φᵀ, Joseph updates as matrix products.
fn dense_step<T: Real, const N: usize>(f: &mut HypothesisFilter<T, N>, s: &Setting<T>) {
    // The readings of `step`: off the state before the step.
    let x = f.ekf.x;
    let z = [x[XP] + T::c(1e-4), x[P3] + T::c(1e-3), x[P4] - T::c(1e-3)];
    let e = f.predict_mean(&s.plant, &s.ctx);
    let phi = dense_transition::<T, N>(f.hypothesis, &e, s.ctx.step.dt, &s.ctx.spool_dt);
    let q = s.noise.variances(s.ctx.step.dt);
    let q: [T; N] = core::array::from_fn(|i| q[i]);
    crate::estimation::ekf::predict_covariance_dense(&mut f.ekf.p, &phi, &q);
    let w = f.learning_weights(&s.ctx);
    for (k, &j) in MEASURED.iter().enumerate() {
        let lag = if j == XP {
            T::ZERO
        } else {
            s.ctx.pressure_lag_s * e.f[j]
        };
        crate::estimation::ekf::joseph_update_dense(&mut f.ekf, j, z[k], s.r[k] + lag * lag, &w);
    }
}

/// 500 steps of the optimised filter and of the dense one from the
/// same start, at every operating point: x within `tol_x` (relative to
/// 1 + |x|), P within `tol_p` of √(P_aa·P_bb).
fn filter_matches_dense<T: Real, const N: usize>(h: Hypothesis, tol_x: f64, tol_p: f64) {
    for point in POINTS {
        let mut s = at_point::<T>(point);
        let p0 = [T::c(1e-3); NB];
        let mut fast = HypothesisFilter::<T, N>::new(h, &s.s0, &p0, T::c(0.1));
        let mut slow = fast.clone();
        for _ in 0..500 {
            s.tables_at(&slow);
            step(&mut fast, &s).expect("a healthy filter step");
            dense_step(&mut slow, &s);
        }
        let rel = |a: T, b: T, scale: f64| (a - b).abs().to_f64() / scale;
        for a in 0..N {
            let d = rel(
                fast.ekf.x[a],
                slow.ekf.x[a],
                1.0 + slow.ekf.x[a].abs().to_f64(),
            );
            assert!(d <= tol_x, "{h:?} at {point:?}: x[{a}] differs by {d:e}");
            for b in 0..N {
                let scale = (slow.ekf.p[(a, a)] * slow.ekf.p[(b, b)]).sqrt().to_f64();
                let d = rel(fast.ekf.p[(a, b)], slow.ekf.p[(a, b)], scale);
                assert!(
                    d <= tol_p,
                    "{h:?} at {point:?}: P[{a}, {b}] differs by {d:e}"
                );
            }
        }
    }
}

#[test]
fn filter_steps_equal_the_dense_filter() {
    // The dense Joseph update (matrix products) rounds differently
    // from the elementwise one: f64 agrees to ~1e-13, f32 to ~1e-5.
    filter_matches_dense::<f64, { NB }>(Hypothesis::Healthy, 1e-13, 1e-11);
    filter_matches_dense::<f64, { NB + 1 }>(Hypothesis::Internal, 1e-13, 1e-11);
    filter_matches_dense::<f64, { NB + 1 }>(Hypothesis::External, 1e-13, 1e-11);
    filter_matches_dense::<f64, { NB + 2 }>(Hypothesis::Both, 1e-13, 1e-11);
    filter_matches_dense::<f32, { NB }>(Hypothesis::Healthy, 1e-5, 3e-4);
    filter_matches_dense::<f32, { NB + 1 }>(Hypothesis::Internal, 1e-5, 3e-4);
    filter_matches_dense::<f32, { NB + 1 }>(Hypothesis::External, 1e-5, 3e-4);
    filter_matches_dense::<f32, { NB + 2 }>(Hypothesis::Both, 1e-5, 3e-4);
}

#[test]
fn non_finite_values_anywhere_are_caught_within_one_step() {
    non_finite_anywhere_fails_the_next_step::<f32, { NB }>(Hypothesis::Healthy);
    non_finite_anywhere_fails_the_next_step::<f32, { NB + 1 }>(Hypothesis::Internal);
    non_finite_anywhere_fails_the_next_step::<f32, { NB + 1 }>(Hypothesis::External);
    non_finite_anywhere_fails_the_next_step::<f32, { NB + 2 }>(Hypothesis::Both);
    non_finite_anywhere_fails_the_next_step::<f64, { NB + 2 }>(Hypothesis::Both);
}

#[test]
fn healthy_laminar_leakage_never_estimated_below_its_floor() {
    // Readings that ask for ever less leakage across the edges and the
    // seal (the chamber pressures drift apart, as a plant whose edges
    // differ from the model's makes them): the estimate stops at the
    // floor instead of running backwards.
    let mut s = setting::<f64>(false);
    s.ctx.laminar_floor = -0.5;
    let p0 = [1e-3; NB];
    let mut f: HypothesisFilter<f64, { NB + 2 }> =
        HypothesisFilter::new(Hypothesis::Both, &s.s0, &p0, 0.1);
    f.ekf.x[LAMINAR] = -0.45;
    let mut lowest = f64::INFINITY;
    for _ in 0..2000 {
        s.tables_at(&f);
        let x = &f.ekf.x;
        let m = Measurement {
            z: [x[XP], x[P3] + 2e-3, x[P4] - 2e-3],
            r: s.r,
        };
        let q = s.noise.variances(s.ctx.step.dt);
        f.step(&s.plant, &s.ctx, &q, &m).expect("a filter step");
        lowest = lowest.min(f.ekf.x[LAMINAR]);
    }
    assert!(lowest >= -0.5, "{lowest}");
    assert_eq!(f.ekf.x[LAMINAR], -0.5, "the readings do push it down");
}

/// One step of `hypothesis`' filter (`N` states) at a hold with the rod
/// chamber `p4_bar_below_p3` bar below the piston chamber and its internal
/// leak coefficient at 3 l/min per 10 bar (uncertain).
fn internal_leak_at_hold<const N: usize>(
    hypothesis: Hypothesis,
    p4_bar_below_p3: f64,
) -> FilterOutput<f64> {
    let mut s = setting::<f64>(false);
    s.s0[P4] = s.s0[P3] - p4_bar_below_p3 * BAR / 1e7;
    let p0 = [1e-3; NB];
    let mut f = HypothesisFilter::<f64, N>::new(hypothesis, &s.s0, &p0, 1.0);
    let (Some(i), _) = leak_indices::<N>(hypothesis) else {
        panic!("{hypothesis:?} has no internal leak state")
    };
    f.ekf.x[i] = 3.0;
    let m = Measurement {
        z: [f.ekf.x[XP], f.ekf.x[P3], f.ekf.x[P4]],
        r: s.r,
    };
    let q = s.noise.variances(s.ctx.step.dt);
    f.step(&s.plant, &s.ctx, &q, &m).expect("a filter step")
}

#[test]
fn no_internal_leak_flow_is_claimed_while_the_chamber_pressures_are_equal() {
    // The `both` filter (the one whose flows the decision reads): what it
    // reports, and what the decision alarms on, is the flow
    // θ·|p3 − p4| / 10 bar with its 1σ.
    let run = internal_leak_at_hold::<{ NB + 2 }>;
    // Equal pressures: the leak path carries nothing, whatever θ reads,
    // and neither does its uncertainty: no internal-leak claim.
    let equal = run(Hypothesis::Both, 0.0);
    assert!(
        equal.flow_internal_lpm.abs() < 0.02,
        "{}",
        equal.flow_internal_lpm
    );
    assert!(
        equal.flow_internal_sd_lpm < 0.02,
        "{}",
        equal.flow_internal_sd_lpm
    );
    // 8 bar across the piston: the same coefficient is a 2.4 l/min leak.
    let apart = run(Hypothesis::Both, 8.0);
    assert!(apart.flow_internal_lpm > 2.0, "{}", apart.flow_internal_lpm);
}

#[test]
fn the_internal_leak_learns_nothing_while_the_chamber_pressures_are_equal() {
    // Its flow θ·Δp does not depend on θ there: whatever the coefficient
    // would learn is the model's error, read as a leak at the next move.
    let s = setting::<f64>(false);
    let weights = |p4_bar_below_p3: f64| {
        let mut s0 = s.s0;
        s0[P4] = s0[P3] - p4_bar_below_p3 * BAR / 1e7;
        let f = HypothesisFilter::<f64, { NB + 2 }>::new(Hypothesis::Both, &s0, &[1e-3; NB], 1.0);
        let (Some(internal), Some(external)) = leak_indices::<{ NB + 2 }>(Hypothesis::Both) else {
            panic!("`both` has both leak states")
        };
        let w = f.learning_weights(&s.ctx);
        (w[internal], w[external])
    };
    let learning = s.ctx.learning;
    let (internal, external) = weights(0.0);
    assert!(internal < 1e-9, "{internal}");
    assert_eq!(external, learning);
    // Half weight at 1 bar; 8 bar apart it learns almost fully.
    assert!((weights(1.0).0 - 0.5 * learning).abs() < 1e-9);
    let (internal, external) = weights(8.0);
    assert!(internal > 0.98 * learning, "{internal}");
    assert_eq!(external, learning);
}

#[test]
fn each_leak_filter_reports_its_own_leak_flow_and_only_both_the_valve_gains() {
    // The internal-leak filter in the same place: its flow (which tells
    // the decision whether its likelihood speaks for a leak at all) is
    // its own coefficient times the pressure difference, like the `both`
    // filter's; the valve gains the decision reads are the `both`
    // filter's only.
    let out = internal_leak_at_hold::<{ NB + 1 }>(Hypothesis::Internal, 8.0);
    assert!(out.log_likelihood.is_finite() && out.nis > 0.0);
    assert!(out.flow_internal_lpm > 2.0, "{}", out.flow_internal_lpm);
    assert!(out.flow_internal_sd_lpm > 0.0);
    // About 8 bar across the piston (less the step's own change).
    assert!(out.dp_10bar[0] > 0.6, "{:?}", out.dp_10bar);
    assert_eq!(
        (
            out.flow_external_lpm,
            out.flow_external_sd_lpm,
            out.valve_gain
        ),
        (0.0, 0.0, [0.0; 2])
    );
}

#[test]
fn valve_gains_are_learned_only_once_their_sigma_is_below_the_threshold() {
    // At the start each gain has the prior's σ (here 8 %): not learned to
    // 1 %, learned to 10 %.
    let p0: [f64; NB] = core::array::from_fn(|i| match i {
        GAIN_EXT | GAIN_RET => (0.08 / crate::estimation::model::GAIN_REF).powi(2),
        _ => 1e-3,
    });
    let s0 = [0.0; NX];
    let bank = Bank::new(&s0, &p0, 0.1);
    assert_eq!(bank.valve_gains_learned(0.01), [false, false]);
    assert_eq!(bank.valve_gains_learned(0.1), [true, true]);
}
