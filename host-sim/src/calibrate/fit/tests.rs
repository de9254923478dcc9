//! The valve regression on exact synthetic samples.

use super::*;
use monitor::Sample;

/// Steady samples of a valve with flow gains `gain` × the nominal ones
/// and its piston-side edges at the nominal dead zone and null, the
/// rod-side edges `rod_offset` of travel later, both chambers' pressures
/// rising at `rate_bar_s` ≠ 0 (the piston speed is what continuity leaves
/// of the metering flow after the oil's compression).
fn samples(p: &Params, gain: f64, rate_bar_s: f64, rod_offset: f64) -> Prepared {
    let c = &p.cylinder;
    let to_si = 1.0 / LPM_PER_M3S / BAR.sqrt();
    let kv = [
        gain * p.valve.flow_gain_extend_lpm_sqrt_bar * to_si,
        gain * p.valve.flow_gain_retract_lpm_sqrt_bar * to_si,
    ];
    let edges = [
        p.valve.dead_zone - p.valve.null_offset,
        p.valve.dead_zone + p.valve.null_offset,
    ];
    let k_edge = p.valve.edge_leak_lpm_per_bar / LPM_PER_M3S / BAR;
    let k_seal = p.leakage.seal_lpm_per_bar / LPM_PER_M3S / BAR;
    let k_ext = p.leakage.external_lpm_per_bar / LPM_PER_M3S / BAR;
    let delta = p.valve.laminar_dp_bar * BAR;
    let g = |dp: f64| orifice(dp, delta, delta.sqrt()).0;
    let stored = |vol: f64, pa: f64| vol / bulk_modulus_exact(&p.fluid, pa) * rate_bar_s * BAR;
    let mut d = prepare(&[]);
    for i in 0..400 {
        let extend = i % 2 == 0;
        let opening = 0.05 + 0.25 * (i / 2) as f64 / 200.0;
        let x = 0.02 + 0.14 * (i / 2) as f64 / 200.0;
        let (p2, p5) = (100.0 * BAR, 1.0 * BAR);
        let (p3, p4) = if extend {
            (55.0 * BAR, 30.0 * BAR)
        } else {
            (40.0 * BAR, 70.0 * BAR)
        };
        let seal = k_seal * (p3 - p4);
        let store_a = stored(c.dead_volume_piston_m3 + c.piston_area_m2 * x, p3);
        let store_b = stored(
            c.dead_volume_rod_m3 + c.rod_side_area_m2 * (c.stroke_m - x),
            p4,
        );
        // Metering flows into A and B (the rod-side edge at gain ratio 1).
        let (u, q_a, q_b) = if extend {
            let m = kv[0] * (opening - edges[0]);
            let m_b = kv[0] * (opening - edges[0] - rod_offset);
            (opening, m * g(p2 - p3), -m_b * g(p4 - p5))
        } else {
            let m = kv[1] * (opening - edges[1]);
            let m_b = kv[1] * (opening - edges[1] - rod_offset);
            (-opening, -m * g(p3 - p5), m_b * g(p2 - p4))
        };
        // Chamber A's continuity gives the speed; B's pressure rate is
        // what B's continuity then needs (the same rate, up to the edges'
        // small leakage: the test asserts on A's edge).
        let v = (q_a - store_a - seal + k_edge * (p2 + p5 - 2.0 * p3)) / c.piston_area_m2;
        let need_b =
            q_b + c.rod_side_area_m2 * v + seal + k_edge * (p2 + p5 - 2.0 * p4) - k_ext * (p4 - p5);
        let dp4 = rate_bar_s * need_b / store_b;
        d.p2.push(p2 / BAR);
        d.p3.push(p3 / BAR);
        d.p4.push(p4 / BAR);
        d.p5.push(p5 / BAR);
        d.x.push(x);
        d.u.push(u);
        d.v.push(v);
        d.dp3.push(rate_bar_s);
        d.dp4.push(dp4);
        d.steady.push(i);
    }
    d.stride_s = 0.005;
    d
}

fn fitted_gain(d: &Prepared, start: &Params) -> f64 {
    let (mut p, mut fits, mut warnings, mut q) =
        (start.clone(), Vec::new(), Vec::new(), Quality::default());
    fit_valve(d, &mut p, &mut fits, &mut warnings, &mut q);
    assert!(q.problems.is_empty(), "{:?}", q.problems);
    p.valve.flow_gain_extend_lpm_sqrt_bar / start.valve.flow_gain_extend_lpm_sqrt_bar
}

#[test]
fn the_valve_fit_counts_the_oil_compressed_while_the_pressures_move() {
    let p = Params::nominal();
    // Pressures rising at 10 bar/s (FLOWING allows 2 bar in 180 ms).
    let rising = samples(&p, 1.05, 10.0, 0.0);
    let corrected = fitted_gain(&rising, &p);
    assert!((corrected - 1.05).abs() < 1e-4, "{corrected}");
    // Read as steady flow, the same samples give another gain.
    let mut as_steady = rising;
    as_steady.dp3.iter_mut().for_each(|r| *r = 0.0);
    as_steady.dp4.iter_mut().for_each(|r| *r = 0.0);
    let uncorrected = fitted_gain(&as_steady, &p);
    assert!((uncorrected - 1.05).abs() > 1e-3, "{uncorrected}");
}

#[test]
fn a_rod_side_edge_that_opens_later_is_fitted_as_an_offset_not_a_gain() {
    let p = Params::nominal();
    for offset in [0.012, -0.008] {
        let d = samples(&p, 1.0, 10.0, offset);
        let (mut fitted, mut fits, mut warnings, mut q) =
            (p.clone(), Vec::new(), Vec::new(), Quality::default());
        fit_valve(&d, &mut fitted, &mut fits, &mut warnings, &mut q);
        assert!(q.problems.is_empty(), "{:?}", q.problems);
        let v = &fitted.valve;
        for (ratio, off) in [
            (v.rod_edge_gain_extend, v.rod_edge_offset_extend),
            (v.rod_edge_gain_retract, v.rod_edge_offset_retract),
        ] {
            assert!((ratio - 1.0).abs() < 1e-3, "{offset}: ratio {ratio}");
            assert!((off - offset).abs() < 2e-4, "{offset}: offset {off}");
        }
    }
    // Beyond the plausible offset: no offset, the gain ratio through the
    // piston side's edge (which takes up part of the late edge).
    let d = samples(&p, 1.0, 10.0, 1.5 * MAX_ROD_EDGE_OFFSET);
    let (mut fitted, mut fits, mut warnings, mut q) =
        (p.clone(), Vec::new(), Vec::new(), Quality::default());
    fit_valve(&d, &mut fitted, &mut fits, &mut warnings, &mut q);
    let v = &fitted.valve;
    assert_eq!(v.rod_edge_offset_extend, 0.0);
    assert!(v.rod_edge_gain_extend < 0.95, "{}", v.rod_edge_gain_extend);
}

#[test]
fn a_rod_side_line_beyond_the_plausible_offset_is_not_used() {
    let line = |k: f64, edge: f64| -> Vec<(f64, f64)> {
        (0..100)
            .map(|i| {
                let u = 0.05 + 0.003 * i as f64;
                (u, k * (u - edge))
            })
            .collect()
    };
    let (ratio, offset) = rod_side_line(&line(0.95, 0.03), 1.0, 0.02).unwrap();
    assert!((ratio - 0.95).abs() < 1e-9 && (offset - 0.01).abs() < 1e-9);
    assert!(rod_side_line(&line(1.0, 0.02 + MAX_ROD_EDGE_OFFSET + 0.01), 1.0, 0.02).is_none());
    assert!(rod_side_line(&line(1.4, 0.02), 1.0, 0.02).is_none());
}

/// A 1 kHz recording of `ms` samples at 100 bar supply and 1 bar tank,
/// chamber pressures `p_piston` / `p_rod` (bar), the position and
/// command given per sample index.
fn recording(
    ms: usize,
    [p_piston, p_rod]: [f32; 2],
    x_m: impl Fn(usize) -> f32,
    u: impl Fn(usize) -> f32,
) -> Vec<Sample> {
    (0..ms)
        .map(|i| Sample {
            t_s: i as f64 * 1e-3,
            p_supply_bar: Some(100.0),
            p_piston_bar: Some(p_piston),
            p_rod_bar: Some(p_rod),
            p_tank_bar: Some(1.0),
            x_piston_m: Some(x_m(i)),
            u_valve: Some(u(i)),
            temp_oil_c: None,
        })
        .collect()
}

#[test]
fn a_stick_slipping_piston_moves_without_moving_steadily() {
    // 2 s out, then 2 s in, 1 mm every 80 ms (stuck 70 ms, slipping 10):
    // 12.5 mm/s on average, never at one speed for 0.2 s.
    let x_at = |t_ms: usize| {
        let slips = |ms: usize| (ms / 80) as f32 * 0.001;
        if t_ms < 2000 {
            0.05 + slips(t_ms)
        } else {
            0.05 + slips(2000) - slips(t_ms - 2000)
        }
    };
    let recording = recording(4000, [50.0, 45.0], x_at, |ms| {
        if ms < 2000 {
            0.05
        } else {
            -0.05
        }
    });
    let m = Motion::of(&prepare(&recording));
    // A few samples at the top of each slip look steady, far from the
    // 1.5 s per direction a valve fit needs.
    assert!(m.extend_s.max(m.retract_s) < 0.2, "{m:?}");
    assert!(m.moving_s.iter().all(|&s| s > 1.0), "{m:?}");
}

#[test]
fn holds_count_for_the_edge_fit_up_to_where_the_model_starts_to_meter() {
    // A 2 s hold with the spool `xv` from null, the pressures steady.
    let p = Params::nominal();
    let hold = |xv: f64| -> EdgeHolds {
        let u = (xv - p.valve.null_offset) as f32;
        let recording = recording(2000, [55.0, 40.0], |_| 0.08, |_| u);
        EdgeHolds::of(&prepare(&recording), &p)
    };
    let dz = p.valve.dead_zone;
    // Inside the dead zone short of the rounded corner: a hold for the fit,
    // even within the corner's second width (which an earlier margin of
    // 2 × `OPENING_ROUNDING` threw away).
    let inside = hold(dz - 1.5 * OPENING_ROUNDING);
    assert!(inside.hold_s > 1.0, "{}", inside.hold_s);
    // Where the model's edge already meters: not a covered hold.
    let corner = hold(dz - 0.5 * OPENING_ROUNDING);
    assert_eq!(corner.hold_s, 0.0);
}

#[test]
fn the_hold_command_is_the_median_command_at_rest() {
    // 3 s at rest with the command hunting around +0.012, then 1 s moving.
    let t = |ms: usize| ms as f32 * 1e-3;
    let recording = recording(
        4000,
        [55.0, 40.0],
        |ms| 0.08 + 0.05 * (t(ms) - 3.0).max(0.0),
        |ms| {
            if t(ms) >= 3.0 {
                0.2
            } else {
                0.012 + 0.001 * (40.0 * t(ms)).sin()
            }
        },
    );
    let u = hold_command(&prepare(&recording)).expect("2 s or more at rest");
    assert!((u - 0.012).abs() < 5e-4, "{u}");
    // Less than 2 s at rest places nothing.
    assert_eq!(hold_command(&prepare(&recording[1500..])), None);
}

#[test]
fn a_kept_valve_has_its_null_moved_to_where_the_piston_holds() {
    // 3 s at rest at u = +0.024, outside the kept dead zone around null 0.
    let rec = recording(3000, [55.0, 40.0], |_| 0.08, |_| 0.024);
    let d = prepare(&rec);
    let mut p = Params::nominal();
    p.valve.null_offset = 0.0;
    p.valve.dead_zone = 0.01;
    let (mut fits, mut warnings) = (Vec::new(), Vec::new());
    assert!(centre_null_on_holds(&d, &mut p, &mut fits, &mut warnings));
    assert!(
        (p.valve.null_offset + 0.024).abs() < 1e-6,
        "{}",
        p.valve.null_offset
    );
    // The rest of the valve is kept, and the move is said.
    assert_eq!(p.valve.dead_zone, 0.01);
    assert_eq!(fits.len(), 1);
    assert!(warnings[0].contains("valve null moved"), "{warnings:?}");
    // Holds already inside the dead zone leave it where it is.
    let mut q = Params::nominal();
    q.valve.null_offset = -0.02;
    q.valve.dead_zone = 0.01;
    assert!(!centre_null_on_holds(&d, &mut q, &mut fits, &mut warnings));
    assert_eq!(q.valve.null_offset, -0.02);
    // An implausible null is not taken.
    let far = recording(3000, [55.0, 40.0], |_| 0.08, |_| 0.05);
    let mut r = Params::nominal();
    r.valve.null_offset = 0.0;
    assert!(!centre_null_on_holds(
        &prepare(&far),
        &mut r,
        &mut fits,
        &mut warnings
    ));
    assert_eq!(r.valve.null_offset, 0.0);
}

/// Hold rows of a valve whose covered edges follow the model's law with
/// skews `a`, `b` and growth `g`: at each spool position the chambers sit
/// at pressures where the land leakage of their two edges balances
/// (supply 50 bar, tank 0).
fn balanced_holds(a: f64, b: f64, g: f64) -> EdgeHolds {
    let rows = (0..200)
        .map(|k| {
            let xv = 0.004 * ((k as f64 * 0.37).sin());
            let e = (g * xv).exp();
            // (1 + a)·e·(1 − f) = (1 − a)/e·f for A's fraction f of supply.
            let fa = (1.0 + a) * e / ((1.0 + a) * e + (1.0 - a) / e);
            let fb = (1.0 + b) / e / ((1.0 + b) / e + (1.0 - b) * e);
            HoldRow {
                xv,
                drop: [1.0 - fa, fa, 1.0 - fb, fb],
                need: [0.0, 0.0],
            }
        })
        .collect();
    EdgeHolds { rows, hold_s: 20.0 }
}

#[test]
fn the_edge_fit_finds_the_skews_and_how_fast_the_leakage_grows_with_the_spool() {
    let holds = balanced_holds(0.3, -0.2, 120.0);
    let mut p = Params::nominal();
    p.valve.dead_zone = 0.01;
    let mut warnings = Vec::new();
    let f = fit_edge_leak(&holds, &mut p, Growth::Search, &mut warnings);
    assert!(f.is_some() && warnings.is_empty(), "{warnings:?}");
    let v = &p.valve;
    // The search's grid is 64 log-spaced rates: within one step of it.
    assert!(
        (v.edge_leak_spool_gain / 120.0 - 1.0).abs() < 0.06,
        "{}",
        v.edge_leak_spool_gain
    );
    assert!((v.edge_leak_skew_a - 0.3).abs() < 0.03, "{v:?}");
    assert!((v.edge_leak_skew_b + 0.2).abs() < 0.03, "{v:?}");
    // Fixed at the true rate the skews come out exact.
    let mut q = Params::nominal();
    q.valve.dead_zone = 0.01;
    fit_edge_leak(&holds, &mut q, Growth::Fixed(120.0), &mut warnings).unwrap();
    assert!((q.valve.edge_leak_skew_a - 0.3).abs() < 1e-9);
    assert!((q.valve.edge_leak_skew_b + 0.2).abs() < 1e-9);
    assert_eq!(q.valve.edge_leak_spool_gain, 120.0);
}

#[test]
fn an_edge_fit_at_its_bound_is_not_used_and_says_so() {
    // Edges far more lopsided than the fit may give: the skew saturates.
    let holds = balanced_holds(0.97, 0.0, 0.0);
    let mut p = Params::nominal();
    let before = p.clone();
    let mut warnings = Vec::new();
    assert!(fit_edge_leak(&holds, &mut p, Growth::Fixed(0.0), &mut warnings).is_none());
    assert_eq!(p, before);
    assert!(warnings[0].contains("sits at a bound"), "{warnings:?}");
    // A still spool cannot say how fast the leakage grows.
    let mut still = balanced_holds(0.3, -0.2, 0.0);
    for r in &mut still.rows {
        r.xv = 0.001;
    }
    assert!(fit_edge_leak(&still, &mut p, Growth::Search, &mut warnings).is_none());
}
