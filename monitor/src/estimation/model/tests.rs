use super::*;
use crate::params::Params;
use crate::real::Real;

// The dense form, for the finite-difference test (the filter uses the sparse one).
impl<T: Real> Plant<T> {
    /// The full Jacobian ∂f/∂[s, gain_ext, gain_ret, laminar, θ_i, θ_e] as a dense 11×11
    /// array (the finite-difference test's; the filter uses the sparse form).
    pub fn dense_jacobian(&self, e: &Eval<T>) -> [[T; NX + 5]; NX + 5] {
        let j = &e.jac;
        let mut a = [[T::ZERO; NX + 5]; NX + 5];
        a[XP][VP] = T::c(V_REF / X_REF);
        a[VP][XP] = j.v_x;
        a[VP][VP] = j.v_v;
        a[VP][P3] = j.v_p3;
        a[VP][P4] = j.v_p4;
        a[XV][VV] = self.omega;
        a[VV][XV] = -self.omega;
        a[VV][VV] = -(self.omega * self.two_zeta);
        a[P3][XP] = j.p3_x;
        a[P3][VP] = j.p3_v;
        a[P3][XV] = j.p3_xv;
        a[P3][P3] = j.p3_p3;
        a[P3][P4] = j.p3_p4;
        a[P3][NX] = j.p3_ge;
        a[P3][NX + 1] = j.p3_gr;
        a[P3][NX + 2] = j.p3_lam;
        a[P3][NX + 3] = j.p3_li;
        a[P4][XP] = j.p4_x;
        a[P4][VP] = j.p4_v;
        a[P4][XV] = j.p4_xv;
        a[P4][P3] = j.p4_p3;
        a[P4][P4] = j.p4_p4;
        a[P4][NX] = j.p4_ge;
        a[P4][NX + 1] = j.p4_gr;
        a[P4][NX + 2] = j.p4_lam;
        a[P4][NX + 3] = j.p4_li;
        a[P4][NX + 4] = j.p4_le;
        a
    }
}

fn plant() -> Plant<f64> {
    Plant::new(&Params::nominal())
}

/// A plant with every optional term active (for the Jacobian check).
fn plant_all_terms() -> Plant<f64> {
    let mut p = Params::nominal();
    p.valve.rod_edge_gain_extend = 1.03;
    p.valve.rod_edge_gain_retract = 0.97;
    p.leakage.external_lpm_per_bar = 2e-3;
    p.valve.edge_leak_skew_a = 0.3;
    p.valve.edge_leak_skew_b = -0.2;
    p.valve.edge_leak_spool_gain = 20.0;
    Plant::new(&p)
}

fn inputs(p: &Plant<f64>, u: f64) -> Inputs<f64> {
    Inputs {
        p_supply_pa: 50.0 * BAR,
        p_tank_pa: 0.8 * BAR,
        u_valve: u,
        laminar_factor: 1.0,
        land: p.land_leak(u),
        rod: p.rod_edges(u),
        // Mid-stroke at 20 bar; `at` looks them up where the model is
        // evaluated.
        tables: p.tabulated(&state(0.09, 0.0, 0.0, 20.0, 20.0)),
        hold_share: p.hold_share(u),
    }
}

/// `u` with the tables looked up at state `s`: the state-dependent model.
fn at(p: &Plant<f64>, s: &[f64; NX], u: &Inputs<f64>) -> Inputs<f64> {
    Inputs {
        tables: p.tabulated(s),
        ..*u
    }
}

fn state(xp: f64, v: f64, xv: f64, p3_bar: f64, p4_bar: f64) -> [f64; NX] {
    [
        xp / X_REF,
        v / V_REF,
        xv,
        0.3,
        p3_bar * BAR / P_REF,
        p4_bar * BAR / P_REF,
    ]
}

/// Central finite differences of f w.r.t. the scaled state and leaks.
fn fd_jacobian(
    p: &Plant<f64>,
    s: &[f64; NX],
    u: &Inputs<f64>,
    n: Nuisance<f64>,
    l: Leaks<f64>,
) -> [[f64; NX + 5]; NX + 5] {
    let mut a = [[0.0; NX + 5]; NX + 5];
    for j in 0..NX + 5 {
        let h = 1e-6;
        let (mut sp, mut sm) = (*s, *s);
        let (mut lp, mut lm) = (l, l);
        let (mut np, mut nm) = (n, n);
        match j {
            6 => {
                np.gain_extend += h;
                nm.gain_extend -= h;
            }
            7 => {
                np.gain_retract += h;
                nm.gain_retract -= h;
            }
            8 => {
                np.laminar += h;
                nm.laminar -= h;
            }
            9 => {
                lp.internal += h;
                lm.internal -= h;
            }
            10 => {
                lp.external += h;
                lm.external -= h;
            }
            _ => {
                sp[j] += h;
                sm[j] -= h;
            }
        }
        let fp = p.eval(&sp, &at(p, &sp, u), np, lp).f;
        let fm = p.eval(&sm, &at(p, &sm, u), nm, lm).f;
        for i in 0..NX {
            a[i][j] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    a
}

#[test]
fn analytic_jacobian_matches_finite_differences() {
    let p = plant_all_terms();
    let leaks = Leaks {
        internal: 0.4,
        external: 0.3,
    };
    let nuis = Nuisance {
        gain_extend: 0.3,
        gain_retract: -0.2,
        laminar: 0.4,
    };
    let cases = [
        (state(0.05, 0.02, 0.2, 30.0, 12.0), inputs(&p, 0.2)),
        (state(0.12, -0.03, -0.15, 14.0, 22.0), inputs(&p, -0.15)),
        (state(0.09, 0.0, 0.005, 21.0, 13.0), inputs(&p, 0.0)), // dead zone, at rest
        (state(0.03, 1e-4, 0.0162, 25.0, 10.0), inputs(&p, 0.0162)), // rounded edge
        (state(0.10, 0.01, 0.3, 49.6, 1.2), inputs(&p, 0.3)),   // laminar orifice region
        (state(0.07, -0.2, -0.6, 3.0, 45.0), inputs(&p, -0.6)), // low pressure, soft oil
    ];
    for (n, (s, u)) in cases.iter().enumerate() {
        let e = p.eval(s, &at(&p, s, u), nuis, leaks);
        let a = p.dense_jacobian(&e);
        let fd = fd_jacobian(&p, s, u, nuis, leaks);
        for i in 0..NX {
            for j in 0..NX + 5 {
                let scale = fd[i].iter().map(|v| v.abs()).fold(1e-9, f64::max);
                let err = (a[i][j] - fd[i][j]).abs();
                assert!(
                    err < 2e-4 * scale,
                    "case {n}: d f{i}/d s{j}: analytic {} vs fd {}",
                    a[i][j],
                    fd[i][j]
                );
            }
        }
    }
}

#[test]
fn tables_looked_up_nearby_and_followed_along_their_slope_are_the_model_at_the_state() {
    // The monitor looks the tables up once a sample at the `both` filter's
    // estimate; every filter and substep evaluates at its own state. Within
    // the tables' intervals that is the model at the own state to rounding
    // but for the moving mass, taken as looked up (0.05–0.25 % per
    // millimetre on this rig); across a node of the bulk-modulus table
    // (1.8 bar apart at 12 bar) within the table's own accuracy (1 %,
    // `fluid::tests::table_is_within_one_percent`).
    let p = plant_all_terms();
    let nuis = Nuisance::default();
    let leaks = Leaks {
        internal: 0.2,
        external: 0.1,
    };
    for (s, u) in [
        (state(0.09, 0.02, 0.1, 30.0, 12.0), inputs(&p, 0.1)),
        (state(0.03, -0.05, -0.2, 4.0, 40.0), inputs(&p, -0.2)), // soft oil
        (state(0.15, 0.0, 0.0, 21.0, 13.0), inputs(&p, 0.0)),
    ] {
        let own = p.eval(&s, &at(&p, &s, &u), nuis, leaks).f;
        for (dx_m, dp_bar) in [(0.0, 0.3), (0.0, -0.3), (2e-4, 0.1), (-2e-4, -0.1)] {
            let mut near = s;
            near[XP] += dx_m / X_REF;
            near[P3] += dp_bar * BAR / P_REF;
            near[P4] -= dp_bar * BAR / P_REF;
            let followed = p.eval(&s, &at(&p, &near, &u), nuis, leaks).f;
            for i in 0..NX {
                let tol = match i {
                    VP if dx_m != 0.0 => 1e-3,
                    P3 | P4 => 1e-2,
                    _ => 1e-9,
                };
                let scale = own[i].abs().max(1e-6);
                assert!(
                    (followed[i] - own[i]).abs() <= tol * scale,
                    "state {i}, looked up {dx_m} m / {dp_bar} bar away: {} vs {}",
                    followed[i],
                    own[i]
                );
            }
        }
    }
}

#[test]
fn with_a_hold_model_the_laminar_state_moves_no_land_leakage_at_a_hold() {
    let mut params = Params::nominal();
    params.valve.hold_edge_leak_scale = 3.0;
    let held = Plant::<f64>::new(&params);
    let free = plant();
    // Chamber pressure rates at command (= spool) `u` with laminar state `l`.
    let rates = |p: &Plant<f64>, u: f64, l: f64| {
        let s = state(0.09, 0.0, u, 30.0, 12.0);
        let n = Nuisance {
            laminar: l,
            ..Nuisance::default()
        };
        let f = p.eval(&s, &at(p, &s, &inputs(p, u)), n, Leaks::default()).f;
        [f[P3], f[P4]]
    };
    // At a hold the held land leakage does not follow the state; without
    // a hold model it does, and while the valve meters it does again.
    assert_eq!(rates(&held, 0.0, 0.0), rates(&held, 0.0, 1.0));
    assert_ne!(rates(&free, 0.0, 0.0), rates(&free, 0.0, 1.0));
    assert_ne!(rates(&held, 0.2, 0.0), rates(&held, 0.2, 1.0));
    // The hold model is the nominal land leakage × 3 there (seal leakage
    // at the temperature's factor): the same rates as a plant whose edges
    // leak three times as much.
    let mut triple = Params::nominal();
    triple.valve.edge_leak_lpm_per_bar *= 3.0;
    let triple = Plant::<f64>::new(&triple);
    let (h, t) = (rates(&held, 0.0, 0.0), rates(&triple, 0.0, 0.0));
    for k in 0..2 {
        assert!(
            (h[k] - t[k]).abs() <= 1e-9 * t[k].abs().max(1.0),
            "{h:?} {t:?}"
        );
    }
}

#[test]
fn analytic_jacobian_matches_finite_differences_with_a_hold_model() {
    let mut params = Params::nominal();
    params.valve.hold_edge_leak_scale = 3.0;
    params.valve.edge_leak_skew_a = 0.3;
    params.valve.edge_leak_spool_gain = 20.0;
    let p = Plant::<f64>::new(&params);
    let nuis = Nuisance {
        gain_extend: 0.1,
        gain_retract: -0.1,
        laminar: 0.4,
    };
    let leaks = Leaks {
        internal: 0.2,
        external: 0.1,
    };
    // Inside the dead zone, where the hold model gives way, and metering.
    for (n, u) in [0.0, 0.018, -0.02, 0.2].into_iter().enumerate() {
        let s = state(0.08, 0.0, u, 27.0, 14.0);
        let e = p.eval(&s, &at(&p, &s, &inputs(&p, u)), nuis, leaks);
        let a = p.dense_jacobian(&e);
        let fd = fd_jacobian(&p, &s, &inputs(&p, u), nuis, leaks);
        for i in 0..NX {
            for j in 0..NX + 5 {
                let scale = fd[i].iter().map(|v| v.abs()).fold(1e-9, f64::max);
                assert!(
                    (a[i][j] - fd[i][j]).abs() < 2e-4 * scale,
                    "case {n}: d f{i}/d s{j}: analytic {} vs fd {}",
                    a[i][j],
                    fd[i][j]
                );
            }
        }
    }
}

#[test]
fn balanced_at_rest_in_the_dead_zone() {
    // With the spool centred and the piston held, each chamber relaxes to
    // the pressure where the covered-edge leakages balance.
    let p = plant();
    let u = inputs(&p, 0.0);
    let mut s = state(0.09, 0.0, 0.0, 25.4, 25.4);
    s[VV] = 0.0;
    let e = p.eval(&s, &u, Nuisance::default(), Leaks::default());
    // Seal leakage is zero at equal pressures and edges are symmetric.
    assert!(e.f[P3].abs() < 1e-9 && e.f[P4].abs() < 1e-9, "{:?}", e.f);
}

#[test]
fn land_leakage_grows_exponentially_as_the_spool_uncovers_an_edge() {
    let mut params = Params::nominal();
    params.valve.edge_leak_skew_a = 0.2;
    params.valve.edge_leak_spool_gain = 100.0;
    let p = Plant::<f64>::new(&params);
    let dz = params.valve.dead_zone;
    let null = params.valve.null_offset;
    // Centred spool: the skew alone.
    let c = p.land_leak(-null);
    assert!((c.pa - 1.2).abs() < 1e-12 && (c.at - 0.8).abs() < 1e-12);
    assert!((c.pb - 1.0).abs() < 1e-12 && (c.bt - 1.0).abs() < 1e-12);
    // Half the dead zone towards extending: P→A and B→T grow e^(g·x),
    // the others shrink as much.
    let x = 0.5 * dz;
    let l = p.land_leak(x - null);
    let e = (100.0 * x).exp();
    assert!((l.pa / (1.2 * e) - 1.0).abs() < 4e-4, "{l:?}");
    assert!((l.bt / e - 1.0).abs() < 4e-4 && (l.pb * e - 1.0).abs() < 4e-4);
    assert!((l.at * e / 0.8 - 1.0).abs() < 4e-4);
    // Held at the dead zone once the edge opens.
    assert_eq!(p.land_leak(0.5), p.land_leak(dz - null));
    // At rest chamber A settles where its edges balance: higher the
    // further P→A is uncovered.
    let settle = |u: f64| {
        let inputs = inputs(&p, u);
        let (mut lo, mut hi) = (1.0, 49.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            let f = p
                .eval(
                    &state(0.09, 0.0, u + null, mid, 20.0),
                    &inputs,
                    Nuisance::default(),
                    Leaks::default(),
                )
                .f[P3];
            if f > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    };
    let (below, centred, above) = (settle(-x - null), settle(-null), settle(x - null));
    assert!(
        below < centred && centred < above,
        "{below} {centred} {above}"
    );
}

#[test]
fn leaks_drain_the_right_chambers() {
    let p = plant();
    let u = inputs(&p, 0.0);
    let s = state(0.09, 0.0, 0.0, 21.0, 13.0);
    let base = p.eval(&s, &u, Nuisance::default(), Leaks::default());
    let int = p.eval(
        &s,
        &u,
        Nuisance::default(),
        Leaks {
            internal: 1.0,
            external: 0.0,
        },
    );
    let ext = p.eval(
        &s,
        &u,
        Nuisance::default(),
        Leaks {
            internal: 0.0,
            external: 1.0,
        },
    );
    // Internal: piston chamber loses, rod chamber gains.
    assert!(int.f[P3] < base.f[P3] && int.f[P4] > base.f[P4]);
    // External: only the rod chamber loses.
    assert_eq!(ext.f[P3], base.f[P3]);
    assert!(ext.f[P4] < base.f[P4]);
    // 1 l/min per 10 bar at 8 bar difference: 0.8 l/min.
    assert!((int.q_internal * LPM_PER_M3S - 0.8).abs() < 1e-9);
    assert!((ext.q_external * LPM_PER_M3S - 1.22).abs() < 1e-9);
}

/// Reference solution: classical RK4 on the continuous model with the
/// spool driven by the same (exact) linear ODE, at a 1 µs step.
fn rk4_reference(
    p: &Plant<f64>,
    s0: [f64; NX],
    u: &Inputs<f64>,
    l: Leaks<f64>,
    t: f64,
) -> [f64; NX] {
    let h = 1e-6;
    let n = (t / h).round() as usize;
    let mut s = s0;
    let add = |a: &[f64; NX], b: &[f64; NX], k: f64| {
        let mut r = *a;
        for i in 0..NX {
            r[i] += k * b[i];
        }
        r
    };
    for _ in 0..n {
        let n = Nuisance::default();
        let f = |s: &[f64; NX]| p.eval(s, &at(p, s, u), n, l).f;
        let k1 = f(&s);
        let k2 = f(&add(&s, &k1, h / 2.0));
        let k3 = f(&add(&s, &k2, h / 2.0));
        let k4 = f(&add(&s, &k3, h));
        for i in 0..NX {
            s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    s
}

#[test]
fn one_ms_prediction_is_stable_and_accurate_for_the_stiff_model() {
    // Stiff cases: small chamber volume near the stroke end, laminar
    // orifice region (Δp < 1 bar, the steepest flow slope), soft oil.
    // Explicit Euler at 1 ms diverges on these (checked below); the
    // scheme must stay within a small fraction of the RK4 reference.
    let p = plant();
    let leaks = Leaks {
        internal: 0.3,
        external: 0.2,
    };
    let cases = [
        (state(0.002, 0.0, 0.8, 49.7, 0.9), inputs(&p, 0.8)),
        (state(0.178, 0.0, -0.8, 1.0, 49.5), inputs(&p, -0.8)),
        (state(0.09, 0.03, 0.25, 35.0, 9.0), inputs(&p, 0.25)),
        (state(0.09, 0.0, 0.0, 21.0, 13.0), inputs(&p, 0.0)),
    ];
    let dt = 0.001;
    for (n, (s0, u)) in cases.iter().enumerate() {
        let step = Step {
            dt,
            substeps: 2,
            spool: p.spool_step(dt / 2.0),
        };
        // Run 20 ms with the filter's scheme and the reference.
        let mut s = *s0;
        // The tables looked up once a step, as the monitor does.
        for _ in 0..20 {
            let u = at(&p, &s, u);
            p.advance(&mut s, &u, Nuisance::default(), leaks, &step);
        }
        let r = rk4_reference(&p, *s0, u, leaks, 0.020);
        for i in [XP, VP, P3, P4] {
            // Velocity and position within 2 %: breaking away from rest,
            // the first substep still sees the stiction slope at v = 0
            // (stiff by design, see `Friction::smoothing_m_s`) and
            // lags the reference by a fraction of a substep.
            let tol = if i >= P3 {
                0.5 * BAR / P_REF
            } else {
                (0.02 * r[i].abs()).max(2e-3)
            };
            assert!(
                (s[i] - r[i]).abs() < tol,
                "case {n}, state {i}: {} vs {}",
                s[i],
                r[i]
            );
            assert!(s[i].is_finite());
        }
        // One substep of 1 ms must be stable too (variable sample steps).
        let mut s1 = *s0;
        let step1 = Step {
            dt,
            substeps: 1,
            spool: p.spool_step(dt),
        };
        for _ in 0..20 {
            let u = at(&p, &s1, u);
            p.advance(&mut s1, &u, Nuisance::default(), leaks, &step1);
        }
        assert!(s1.iter().all(|v| v.is_finite()));
        assert!(
            (s1[P3] - r[P3]).abs() < 2.0 * BAR / P_REF,
            "case {n}: 1 substep p3 {} vs {}",
            s1[P3],
            r[P3]
        );
    }
    // Why the care: on the laminar orifice region of a blocked, wide-open
    // chamber (slope × β/V ≈ 3600 /s) explicit Euler at 1 ms overshoots
    // and rings far from the settled pressure (p3 → p2 = 50 bar).
    let mut blocked = state(0.09, 0.0, 0.8, 49.8, 1.0);
    blocked[VV] = 0.0;
    let u = inputs(&p, 0.8);
    let mut e = blocked;
    for _ in 0..10 {
        let f = p.eval(&e, &u, Nuisance::default(), Leaks::default()).f;
        for i in [P3, P4] {
            e[i] += dt * f[i];
        }
    }
    assert!(
        (e[P3] - 0.5).abs() > 1.0 * BAR / P_REF,
        "explicit Euler was accurate: {e:?}"
    );
    let mut ours = blocked;
    for _ in 0..10 {
        let e0 = p.eval(&ours, &u, Nuisance::default(), Leaks::default());
        // Same blocked piston: pressures only.
        ours[P3] += dt * e0.f[P3] / (1.0 - dt * stiff(e0.jac.p3_p3));
        ours[P4] += dt * e0.f[P4] / (1.0 - dt * stiff(e0.jac.p4_p4));
    }
    assert!((ours[P3] - 0.5).abs() < 0.1 * BAR / P_REF, "{ours:?}");
}

#[test]
fn friction_opposes_motion_and_has_breakaway_peak() {
    let p = plant();
    let (f0, _) = p.friction(0.0);
    assert_eq!(f0, 0.0);
    let (f_slow, _) = p.friction(0.005);
    let (f_fast, _) = p.friction(0.3);
    let (f_neg, _) = p.friction(-0.005);
    assert!(f_slow > 900.0 && f_slow < 1000.0, "{f_slow}");
    assert_eq!(f_neg, -f_slow);
    // Viscous term dominates at speed: 480 + 5000·0.3 plus a decayed Stribeck part.
    assert!(f_fast > 1980.0 && f_fast < 2100.0, "{f_fast}");
}

#[test]
fn a_rod_side_edge_that_opens_later_passes_less_at_small_openings() {
    let mut params = Params::nominal();
    params.valve.rod_edge_gain_extend = 1.05;
    params.valve.rod_edge_gain_retract = 0.95;
    let even = Plant::<f64>::new(&params);
    let dz = params.valve.dead_zone;
    let null = params.valve.null_offset;
    // Edges opening together: the gain ratio, bit for bit, in both
    // directions and at rest.
    for u in [-0.3, -0.05, 0.0, 0.05, 0.3] {
        let r = even.rod_edges(u);
        assert_eq!((r.extend, r.retract), (1.05, 0.95), "u = {u}");
    }
    params.valve.rod_edge_offset_extend = 0.01;
    params.valve.rod_edge_offset_retract = -0.01;
    let later = Plant::<f64>::new(&params);
    // Extending at an opening a past the piston-side edge: (a − 0.01)/a.
    for a in [0.02, 0.05, 0.2] {
        let r = later.rod_edges(dz + a - null);
        assert!(
            (r.extend - 1.05 * (a - 0.01) / a).abs() < 1e-12,
            "{a}: {r:?}"
        );
        assert_eq!(r.retract, 0.95, "the closed direction keeps its ratio");
    }
    // Not yet open on the rod side: nothing through it.
    assert_eq!(later.rod_edges(dz + 0.005 - null).extend, 0.0);
    // Retracting, the rod side opens first: more, up to the bound.
    let a = 0.04;
    let r = later.rod_edges(-(dz + a) - null);
    assert!((r.retract - 0.95 * (a + 0.01) / a).abs() < 1e-12, "{r:?}");
    let r = later.rod_edges(-(dz + 0.0025) - null);
    assert!(
        (r.retract - 0.95 * MAX_ROD_OPENING_RATIO).abs() < 1e-12,
        "{r:?}"
    );
    // The model meters the rod side by it: B's flow while extending
    // scales with the ratio, A's does not.
    let u = dz + 0.02 - null;
    let s = state(0.09, 0.01, u + null, 40.0, 20.0);
    let flows = |p: &Plant<f64>| {
        let e = p.eval(&s, &inputs(p, u), Nuisance::default(), Leaks::default());
        (e.f[P3], e.f[P4])
    };
    let ((a_even, b_even), (a_later, b_later)) = (flows(&even), flows(&later));
    assert_eq!(a_even, a_later);
    assert!(
        b_later > b_even,
        "less flows out of B: {b_even} → {b_later}"
    );
}
