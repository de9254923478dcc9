//! Behaviour of the plant as a whole. Runs are short: tests run in debug.

use plant::*;

fn run(rig: RigSpec, scenario: Scenario, leak: Leak, noise_seed: u64) -> Run {
    Run {
        rig,
        scenario,
        leak,
        faults: vec![],
        temp_column: false,
        sample_rate_hz: 1000.0,
        noise_seed,
    }
}

const NO_LEAK: Leak = Leak {
    internal_lpm: 0.0,
    external_lpm: 0.0,
    onset_s: 0.0,
};

fn closed_loop(duration_s: f64, seed: u64) -> Scenario {
    Scenario::ClosedLoop { duration_s, seed }
}

fn rest(duration_s: f64) -> Scenario {
    Scenario::StepTest {
        duration_s,
        step_at_s: 0.0,
        amplitude: 0.0,
    }
}

#[test]
fn runs_are_deterministic_and_seeds_matter() {
    let r = run(
        RigSpec::random(11, 50.0, 25.0),
        closed_loop(3.0, 5),
        NO_LEAK,
        9,
    );
    let a = simulate(&r);
    let b = simulate(&r);
    assert_eq!(a.len(), 3000);
    assert!(a == b, "the same run twice differs");
    assert_eq!(
        RigSpec::random(11, 50.0, 25.0),
        RigSpec::random(11, 50.0, 25.0)
    );
    assert_ne!(
        RigSpec::random(11, 50.0, 25.0),
        RigSpec::random(12, 50.0, 25.0)
    );
    let mut r2 = r.clone();
    r2.noise_seed = 10;
    let c = simulate(&r2);
    assert!(
        a.iter().zip(&c).any(|(a, c)| a.p_piston != c.p_piston),
        "noise seed ignored"
    );
    // The noise seed also draws the run's temperature drift and leak law,
    // so the physics may differ slightly; the setpoints may not.
    assert!(a
        .iter()
        .zip(&c)
        .all(|(a, c)| a.truth.x_ref_m == c.truth.x_ref_m));
}

#[test]
fn at_rest_without_land_leakage_the_piston_stays_put() {
    let mut rig = RigSpec::random(3, 50.0, 25.0);
    rig.valve.land_leak_lpm_per_bar = [0.0; 4];
    let rows = simulate(&run(rig, rest(4.0), Leak::default(), 1));
    let x0 = rows[0].truth.x_m;
    for r in &rows {
        assert!(
            (r.truth.x_m - x0).abs() < 5e-5,
            "moved {} m",
            r.truth.x_m - x0
        );
    }
}

#[test]
fn at_rest_creep_is_bounded_by_the_land_leakage() {
    for seed in [4, 5] {
        let rig = RigSpec::random(seed, 100.0, 40.0);
        let t = 4.0;
        let rows = simulate(&run(rig.clone(), rest(t), Leak::default(), 1));
        let x0 = rows[0].truth.x_m;
        let x1 = rows.last().unwrap().truth.x_m;
        // Worst case: every edge into / out of one chamber at full supply
        // pressure, fluidity ≤ 3, leak factor ≤ e (spool within the bias).
        let k = &rig.valve.land_leak_lpm_per_bar;
        let q = (k[0] + k[1]).max(k[2] + k[3]) * 1e-3 / 60.0
            * rig.supply_bar
            * 3.0
            * std::f64::consts::E;
        let compress = 2.5e-4 * 2.0 * rig.supply_bar / 1000.0; // chamber C·Δp, m³ (β ≥ 1000 bar)
        let bound = (q * t + compress) / rig.cylinder.rod_area_m2;
        assert!(
            (x1 - x0).abs() < bound,
            "creep {} m > bound {bound} m",
            x1 - x0
        );
        assert!((x1 - x0).abs() < 0.01, "creep {} m", x1 - x0);
    }
}

#[test]
fn a_fault_run_reuses_its_twins_motion_and_reads_the_same() {
    let twin = run(
        RigSpec::random(13, 100.0, 25.0),
        closed_loop(2.0, 7),
        NO_LEAK,
        3,
    );
    let mut faulty = twin.clone();
    faulty.faults = vec![Fault::OpenWire {
        channel: Channel::PPiston,
        at_s: 1.0,
    }];
    faulty.temp_column = true;
    let mut last = None;
    assert!(simulate_reusing(&twin, &mut last) == simulate(&twin));
    assert!(last.as_ref().is_some_and(|m| m.fits(&faulty)));
    assert!(simulate_reusing(&faulty, &mut last) == simulate(&faulty));
    // Another noise seed draws another leak law and drift: not reused.
    let mut other = twin.clone();
    other.noise_seed = 4;
    assert!(!last.as_ref().unwrap().fits(&other));
    assert!(simulate_reusing(&other, &mut last) == simulate(&other));
    assert!(last
        .as_ref()
        .is_some_and(|m| m.fits(&other) && !m.fits(&twin)));
}

#[test]
fn an_internal_leak_realises_its_requested_mean_flow() {
    for (rig_seed, noise_seed) in [(21, 1), (22, 2)] {
        let leak = Leak {
            internal_lpm: 0.3,
            external_lpm: 0.0,
            onset_s: 1.0,
        };
        let r = run(
            RigSpec::random(rig_seed, 50.0, 25.0),
            Scenario::ClosedLoop {
                duration_s: 6.0,
                seed: 3,
            },
            leak,
            noise_seed,
        );
        let (rows, rep) = simulate_with_report(&r);
        let after: Vec<f64> = rows
            .iter()
            .filter(|r| r.t >= 1.0)
            .map(|r| r.truth.internal_lpm)
            .collect();
        let before = rows
            .iter()
            .filter(|r| r.t < 0.999)
            .map(|r| r.truth.internal_lpm.abs())
            .sum::<f64>();
        assert_eq!(before, 0.0, "leak before onset");
        let mean = after.iter().sum::<f64>() / after.len() as f64;
        assert!(!rep.internal_by_magnitude);
        assert!(
            (mean / 0.3 - 1.0).abs() < 0.05,
            "mean {mean} l/min ({rep:?})"
        );
        assert!(rows.iter().all(|r| r.truth.external_lpm == 0.0));
    }
}

#[test]
fn an_external_leak_realises_its_requested_mean_flow() {
    let leak = Leak {
        internal_lpm: 0.0,
        external_lpm: 0.5,
        onset_s: 0.0,
    };
    let r = run(
        RigSpec::random(23, 100.0, 30.0),
        Scenario::ClosedLoop {
            duration_s: 5.0,
            seed: 4,
        },
        leak,
        3,
    );
    let (rows, rep) = simulate_with_report(&r);
    let mean = rows.iter().map(|r| r.truth.external_lpm).sum::<f64>() / rows.len() as f64;
    let target = if rep.external_by_magnitude {
        rows.iter().map(|r| r.truth.external_lpm.abs()).sum::<f64>() / rows.len() as f64
    } else {
        mean
    };
    assert!(
        (target / 0.5 - 1.0).abs() < 0.05,
        "mean {target} l/min ({rep:?})"
    );
}

#[test]
fn closed_loop_tracks_its_setpoints() {
    for seed in [31, 32] {
        let rows = simulate(&run(
            RigSpec::random(seed, 50.0, 25.0),
            Scenario::ClosedLoop {
                duration_s: 12.0,
                seed,
            },
            Leak::default(),
            1,
        ));
        let rms = (rows
            .iter()
            .map(|r| (r.truth.x_m - r.truth.x_ref_m).powi(2))
            .sum::<f64>()
            / rows.len() as f64)
            .sqrt();
        assert!(rms < 0.005, "rms tracking error {rms} m");
        // The setpoint moves, and the piston follows it over the stroke.
        let span = |f: &dyn Fn(&Row) -> f64| {
            let v: Vec<f64> = rows.iter().map(f).collect();
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        };
        let sx = span(&|r| r.truth.x_m);
        let sr = span(&|r| r.truth.x_ref_m);
        assert!(sr > 0.01 && (sx - sr).abs() < 0.005, "span {sx} vs {sr}");
    }
}

#[test]
fn a_step_test_runs_into_the_end_stop_and_stays_in_the_stroke() {
    for (seed, amp) in [(41, 0.8), (42, -0.6)] {
        let rig = RigSpec::random(seed, 100.0, 25.0);
        let stroke = rig.cylinder.stroke_m;
        let ps = rig.supply_bar;
        let rows = simulate(&run(
            rig,
            Scenario::StepTest {
                duration_s: 4.0,
                step_at_s: 0.5,
                amplitude: amp,
            },
            Leak::default(),
            1,
        ));
        for r in &rows {
            assert!(
                r.truth.x_m > -1e-4 && r.truth.x_m < stroke + 1e-4,
                "x = {}",
                r.truth.x_m
            );
        }
        let last = rows.last().unwrap();
        assert!(last.truth.at_end_stop);
        assert!(last.truth.v_m_s.abs() < 1e-3);
        assert_eq!(last.u_valve.map(|u| (u - amp).abs() < 0.01), Some(true));
        // Against the stop the driven chamber goes to supply, the other to tank.
        let [pa, pb] = last.truth.p_chambers_bar;
        let (hi, lo) = if amp > 0.0 { (pa, pb) } else { (pb, pa) };
        assert!(hi > 0.9 * ps && lo < 5.0, "pa {pa} pb {pb}");
        assert!(rows.iter().take(400).all(|r| !r.truth.at_end_stop));
    }
}

#[test]
fn pressure_and_position_noise_match_the_drawn_sigma() {
    let mut rig = RigSpec::random(51, 50.0, 25.0);
    for ch in rig
        .sensors
        .pressure
        .iter_mut()
        .chain([&mut rig.sensors.position])
    {
        ch.coloured_sigma = 0.0;
        ch.lag_s = 0.0;
        ch.quantum = 0.0;
        ch.ripple_pickup = 0.0;
        ch.range = [-1e9, 1e9];
    }
    let sp = rig.sensors.pressure[1].clone();
    let sx = rig.sensors.position.clone();
    let rows = simulate(&run(rig, rest(4.0), Leak::default(), 7));
    let stats = |e: Vec<f64>| {
        let n = e.len() as f64;
        let m = e.iter().sum::<f64>() / n;
        (
            m,
            (e.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
        )
    };
    let (mp, s_p) = stats(
        rows.iter()
            .map(|r| r.p_piston.unwrap() - r.truth.p_chambers_bar[0])
            .collect(),
    );
    let (mx, s_x) = stats(
        rows.iter()
            .map(|r| r.x_piston.unwrap() - r.truth.x_m)
            .collect(),
    );
    assert!(
        (s_p / sp.white_sigma - 1.0).abs() < 0.05,
        "{s_p} vs {}",
        sp.white_sigma
    );
    assert!(
        (s_x / sx.white_sigma - 1.0).abs() < 0.05,
        "{s_x} vs {}",
        sx.white_sigma
    );
    assert!((mp - sp.offset).abs() < 0.05 * sp.white_sigma + 1e-9);
    assert!((mx - sx.offset).abs() < 0.05 * sx.white_sigma + 1e-12);
}

#[test]
fn the_temperature_column_is_written_only_when_asked() {
    let mut r = run(
        RigSpec::random(61, 50.0, 35.0),
        rest(0.5),
        Leak::default(),
        1,
    );
    assert!(simulate(&r).iter().all(|r| r.temp_oil.is_none()));
    r.temp_column = true;
    let rows = simulate(&r);
    assert!(rows
        .iter()
        .all(|r| (r.temp_oil.unwrap() - 35.0).abs() < 3.0));
}

#[test]
fn the_crate_does_not_depend_on_the_monitor() {
    let manifest = include_str!("../Cargo.toml");
    for line in manifest.lines() {
        let l = line.trim_start();
        assert!(
            !l.starts_with("monitor"),
            "Cargo.toml names monitor: {line}"
        );
        assert!(!l.contains("path = \"../monitor\""), "{line}");
    }
    for src in [
        include_str!("../src/lib.rs"),
        include_str!("../src/physics.rs"),
    ] {
        assert!(!src.contains("monitor::"));
    }
}

#[test]
fn the_supply_collapses_when_the_valve_asks_more_than_the_pump_gives() {
    let mut rig = RigSpec::random(81, 150.0, 25.0);
    rig.supply.pump_max_lpm = 25.0;
    rig.supply.ripple_bar = [0.0; 3];
    let droop = rig.supply.droop_bar;
    let rows = simulate(&run(
        rig,
        Scenario::StepTest {
            duration_s: 2.0,
            step_at_s: 0.5,
            amplitude: -1.0,
        },
        Leak::default(),
        1,
    ));
    let before = rows[400].truth.p_supply_bar;
    let during = rows
        .iter()
        .filter(|r| !r.truth.at_end_stop && r.t > 0.6)
        .map(|r| r.truth.p_supply_bar)
        .fold(f64::MAX, f64::min);
    assert!(before > 150.0 - droop, "{before}");
    assert!(
        during < 150.0 - droop - 20.0,
        "supply only fell to {during} bar"
    );
    // Back to the set pressure against the stop.
    assert!(rows.last().unwrap().truth.p_supply_bar > 150.0 - droop);
}

#[test]
fn time_stamps_are_the_sample_instants() {
    let r = run(
        RigSpec::random(82, 50.0, 25.0),
        rest(0.25),
        Leak::default(),
        1,
    );
    let mut r500 = r.clone();
    r500.sample_rate_hz = 500.0;
    for (run, dt) in [(r, 1e-3f64), (r500, 2e-3)] {
        let rows = simulate(&run);
        assert_eq!(rows.len(), (0.25 / dt).round() as usize);
        for (k, row) in rows.iter().enumerate() {
            assert!((row.t - k as f64 * dt).abs() < 1e-12);
        }
    }
}

#[test]
fn degenerate_runs_do_not_panic() {
    let rig = RigSpec::random(83, 50.0, 25.0);
    assert!(simulate(&run(rig.clone(), rest(0.0), Leak::default(), 1)).is_empty());
    // A leak whose onset is after the end: no leak in the rows.
    let leak = Leak {
        internal_lpm: 0.5,
        external_lpm: 0.5,
        onset_s: 10.0,
    };
    let rows = simulate(&run(rig.clone(), rest(0.3), leak, 1));
    assert!(rows
        .iter()
        .all(|r| r.truth.internal_lpm == 0.0 && r.truth.external_lpm == 0.0));
    let s = Scenario::LongHold {
        hold_s: 1.0,
        seed: 2,
    };
    let d = planned_duration_s(&s);
    assert!(d > 18.0 && d < 40.0, "{d}");
}
