//! `host-sim eval`: scoring on hand-made results, the rig sets, the cache,
//! and one tiny evaluation end to end on the plant.

use host_sim::eval::exec::{self, Alarm, TruthSummary};
use host_sim::eval::report::{self, Target};
use host_sim::eval::{
    self, plan, Category, Cell, ExecConfig, FaultKind, PlanConfig, RigSet, RunResult, RunSpec,
    SetChoice, DEV_RIGS, HOLDOUT_RIGS, WIDE_RIGS,
};
use monitor::Params;
use std::time::Instant;

fn cell() -> Cell {
    Cell {
        set: RigSet::Dev,
        rig: 1,
        supply_bar: 50.0,
        temp_c: 25.0,
        temp_column: false,
    }
}

fn spec(category: Category, internal: f64, external: f64, onset_s: f64) -> RunSpec {
    RunSpec {
        id: format!("test/{}/{internal}/{external}/{onset_s}", category.name()),
        cell: cell(),
        category,
        fault: None,
        scenario: plant::Scenario::ClosedLoop {
            duration_s: 60.0,
            seed: 1,
        },
        leak: plant::Leak {
            internal_lpm: internal,
            external_lpm: external,
            onset_s,
        },
        faults: Vec::new(),
        noise_seed: 1,
        sample_rate_hz: 1000.0,
        placed: None,
    }
}

fn fault_spec(kind: FaultKind) -> RunSpec {
    let mut s = spec(Category::Fault, 0.0, 0.0, 0.0);
    s.fault = Some(kind);
    s.faults = eval::plan::faults_of(kind);
    s
}

fn result(spec: RunSpec, verdict: &str, alarms: &[(f64, &str)]) -> RunResult {
    let mut r = RunResult::empty(spec, 0.08);
    r.verdict = verdict.to_string();
    r.alarms = alarms
        .iter()
        .map(|&(t_s, what)| Alarm {
            t_s,
            what: what.to_string(),
        })
        .collect();
    r.first_alarm = r.alarms.first().cloned();
    r
}

#[test]
fn any_alarm_on_a_healthy_run_is_a_false_alarm() {
    for cat in [
        Category::HealthyClosedLoop,
        Category::HealthyLongHold,
        Category::HealthyStep,
    ] {
        let quiet = result(spec(cat, 0.0, 0.0, 0.0), "healthy", &[]);
        assert!(!quiet.false_alarm() && quiet.passes());
        let alarmed = result(spec(cat, 0.0, 0.0, 0.0), "internal", &[(40.0, "internal")]);
        assert!(alarmed.false_alarm() && !alarmed.passes());
        assert!(!alarmed.detected(), "no leak to detect");
        // Inconclusive: not a false alarm, not healthy either.
        let unsure = result(spec(cat, 0.0, 0.0, 0.0), "inconclusive", &[]);
        assert!(!unsure.false_alarm() && unsure.inconclusive() && !unsure.passes());
    }
}

#[test]
fn an_alarm_before_the_onset_is_a_false_alarm_not_a_detection() {
    let r = result(
        spec(Category::Leak, 0.3, 0.0, 30.0),
        "internal",
        &[(12.0, "internal")],
    );
    assert!(r.false_alarm());
    assert!(!r.detected() && !r.isolated() && !r.passes());
    assert_eq!(r.latency_s(), None);
    // Escalated after the onset: detected, but the false alarm stays.
    let r = result(
        spec(Category::Leak, 0.3, 0.0, 30.0),
        "internal",
        &[(12.0, "external"), (31.0, "internal")],
    );
    assert!(r.false_alarm() && r.detected() && !r.passes());
}

#[test]
fn isolation_needs_the_final_verdict_to_name_exactly_the_true_leaks() {
    let both = spec(Category::Leak, 0.2, 0.2, 30.0);
    let r = result(both.clone(), "internal", &[(32.0, "internal")]);
    assert!(r.detected() && !r.isolated());
    let r = result(both.clone(), "both", &[(32.0, "internal"), (33.0, "both")]);
    assert!(r.detected() && r.isolated() && r.passes());
    // A leak alarm later cleared to healthy is detected, not isolated.
    let r = result(both, "healthy", &[(32.0, "both")]);
    assert!(r.detected() && !r.isolated());
    // A single leak reported as both is not isolated.
    let r = result(
        spec(Category::Leak, 0.0, 0.5, 30.0),
        "both",
        &[(31.0, "both")],
    );
    assert!(r.detected() && !r.isolated());
    // A sensor-fault "alarm" is no detection.
    let r = result(
        spec(Category::Leak, 0.0, 0.5, 30.0),
        "sensor_fault",
        &[(31.0, "sensor_fault")],
    );
    assert!(!r.detected());
}

/// Per-sample truth at 1 kHz over `secs` s: (true time, [internal, external,
/// velocity]) from a function of time.
fn truth_series(secs: f64, f: impl Fn(f64) -> [f32; 3]) -> (Vec<f64>, Vec<[f32; 3]>) {
    let n = (secs * 1000.0).round() as usize;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
    let q = t.iter().map(|&t| f(t)).collect();
    (t, q)
}

#[test]
fn latency_counts_from_the_onset_and_from_the_first_flow_above_the_alarm_level() {
    let s = spec(Category::Leak, 0.3, 0.0, 30.0);
    // The leak trickles at 0.05 l/min (below the 0.08 alarm level) until 32 s,
    // then flows 0.3 l/min.
    let (t, q) = truth_series(60.0, |t| {
        let qi = if t < 30.0 {
            0.0
        } else if t < 32.0 {
            0.05
        } else {
            0.3
        };
        [qi, 0.0, 0.0]
    });
    let params = Params::nominal();
    let truth = exec::truth_summary(&s, &t, &q, &params);
    // Averaged over the 0.25 s detection window: 0.3 − 0.25·e^(−Δt/0.25)
    // reaches 0.08 at Δt = 0.25·ln(0.25/0.22) ≈ 0.032 s.
    let f = truth.flowing_s.expect("flows above the alarm level");
    assert!((f - 32.032).abs() < 0.003, "{f}");
    let mut r = result(s, "internal", &[(33.5, "internal")]);
    r.truth = truth;
    assert!((r.latency_s().unwrap() - 3.5).abs() < 1e-9);
    assert!((r.latency_flowing_s().unwrap() - (33.5 - f)).abs() < 1e-9);
    // A leak present from the start has no latency (the warm-up limits it).
    let mut r0 = result(
        spec(Category::Leak, 0.3, 0.0, 0.0),
        "internal",
        &[(11.0, "internal")],
    );
    r0.truth.flowing_s = Some(0.1);
    assert!(r0.detected() && r0.latency_s().is_none() && r0.latency_flowing_s().is_none());
}

#[test]
fn size_error_is_against_the_true_flow_averaged_as_the_monitor_averages_its_size() {
    let s = spec(Category::Leak, 0.0, 0.3, 30.0);
    let (t, q) = truth_series(60.0, |t| {
        let qe = if t < 30.0 {
            0.0
        } else if t < 56.0 {
            0.2
        } else {
            0.4
        };
        [0.0, qe, 0.0]
    });
    let params = Params::nominal();
    let truth = exec::truth_summary(&s, &t, &q, &params);
    assert!(
        (truth.last_lpm[1] - 0.4).abs() < 1e-3,
        "{:?}",
        truth.last_lpm
    );
    let after = (26.0 * 0.2 + 4.0 * 0.4) / 30.0;
    assert!((truth.after_onset_lpm[1] - after).abs() < 1e-3);
    // The monitor's size is an exponential average over the evidence
    // window (4 s): 4 s after the step from 0.2 to 0.4 it is 0.4 − 0.2/e.
    let tau = params.filter.evidence_window_s;
    let size = 0.4 - 0.2 * (-4.0 / tau).exp();
    assert!(
        (truth.size_lpm[1] - size).abs() < 1e-3,
        "{:?} vs {size}",
        truth.size_lpm
    );
    let mut r = result(s, "external", &[(31.0, "external")]);
    r.truth = truth;
    r.est_lpm = [Some(0.01), Some(1.05 * size)];
    let e = r.size_errors();
    assert_eq!(e.len(), 1, "only the present leak");
    assert!((e[0] - 0.05).abs() < 1e-3, "{e:?}");
    // No estimate at the end counts as 0 (a 100 % error).
    r.est_lpm = [None, None];
    assert!((r.size_errors()[0] - 1.0).abs() < 1e-9);
}

#[test]
fn truth_finds_the_hold_and_a_mid_move_instant() {
    let s = spec(Category::HealthyLongHold, 0.0, 0.0, 0.0);
    // Move 0–10 s, hold 10–40 s, move 40–50 s, hold 50–55 s.
    let (t, q) = truth_series(55.0, |t| {
        let v = if t < 10.0 || (40.0..50.0).contains(&t) {
            0.02
        } else {
            0.0
        };
        [0.0, 0.0, v]
    });
    let truth = exec::truth_summary(&s, &t, &q, &Params::nominal());
    let [a, b] = truth.hold_s.expect("a hold");
    assert!((a - 10.0).abs() < 0.5 && (b - 40.0).abs() < 0.01, "{a} {b}");
    let m = truth.mid_move_s.expect("moving after 20 s");
    assert!((40.3..40.6).contains(&m), "{m}");
}

#[test]
fn fault_expectations() {
    for kind in FaultKind::ALL {
        let s = fault_spec(kind);
        if kind.expects_sensor_fault() {
            assert!(result(s.clone(), "sensor_fault", &[]).passes(), "{kind:?}");
            assert!(!result(s.clone(), "healthy", &[]).passes());
            let leak = result(s.clone(), "sensor_fault", &[(25.0, "external")]);
            assert!(leak.false_alarm() && !leak.passes());
            // A false alarm of the healthy plant before the fault is a false
            // alarm, not a failure to handle the fault.
            let before = result(s, "sensor_fault", &[(12.0, "external")]);
            assert!(before.false_alarm() && before.passes(), "{kind:?}");
        } else {
            let mut ok = result(s.clone(), "healthy", &[]);
            ok.fault_verdicts.insert("inconclusive".into(), 1800);
            ok.fault_verdicts.insert("sensor_fault".into(), 100);
            assert!(ok.passes(), "{kind:?}: judged while active, not at the end");
            let mut bad = ok.clone();
            bad.fault_verdicts.insert("healthy".into(), 1);
            assert!(!bad.passes(), "{kind:?}: healthy while active");
            let mut leak = ok.clone();
            leak.alarms.push(Alarm {
                t_s: 21.0,
                what: "internal".into(),
            });
            assert!(!leak.passes() && leak.false_alarm());
            let never = result(s, "inconclusive", &[]);
            assert!(!never.passes(), "{kind:?}: the fault window was never seen");
        }
    }
}

fn target<'a>(ts: &'a [Target], starts: &str) -> &'a Target {
    ts.iter()
        .find(|t| t.name.starts_with(starts))
        .unwrap_or_else(|| panic!("no target `{starts}`: {ts:?}"))
}

#[test]
fn targets_count_inconclusive_separately_and_flag_false_alarms() {
    let mut rs: Vec<RunResult> = (0..20)
        .map(|_| {
            result(
                spec(Category::HealthyClosedLoop, 0.0, 0.0, 0.0),
                "healthy",
                &[],
            )
        })
        .collect();
    rs[0].verdict = "inconclusive".into();
    let refs: Vec<&RunResult> = rs.iter().collect();
    let ts = report::target_list(&refs);
    assert_eq!(target(&ts, "healthy runs (").pass, Some(true));
    assert_eq!(target(&ts, "healthy runs end").pass, Some(true));
    assert_eq!(
        target(&ts, "healthy closed-loop runs ending").pass,
        Some(true),
        "1/20 = 5 %"
    );
    assert_eq!(target(&ts, "leak runs detected").pass, None, "no leak runs");
    rs[1].verdict = "inconclusive".into();
    rs[2].alarms.push(Alarm {
        t_s: 30.0,
        what: "external".into(),
    });
    rs[2].verdict = "external".into();
    let refs: Vec<&RunResult> = rs.iter().collect();
    let ts = report::target_list(&refs);
    assert_eq!(
        target(&ts, "healthy closed-loop runs ending").pass,
        Some(false),
        "2/20"
    );
    let fa = target(&ts, "healthy runs (");
    assert_eq!(fa.pass, Some(false));
    assert!(fa.detail.starts_with("19/20"), "{}", fa.detail);
    assert_eq!(target(&ts, "healthy runs end").pass, Some(false));
    // A sensor fault on a run without an injected fault is flagged too.
    assert_eq!(
        target(&ts, "runs without an injected fault").pass,
        Some(true)
    );
    rs[3].sensor_faults.push(Alarm {
        t_s: 9.9,
        what: "u_valve".into(),
    });
    let refs: Vec<&RunResult> = rs.iter().collect();
    let ts = report::target_list(&refs);
    let sf = target(&ts, "runs without an injected fault");
    assert_eq!(sf.pass, Some(false));
    assert!(sf.detail.starts_with("19/20"), "{}", sf.detail);
}

#[test]
fn leak_targets_use_medians_per_kind_and_size() {
    let mk = |alarm: f64, est: f64| {
        let mut r = result(
            spec(Category::Leak, 0.5, 0.0, 30.0),
            "internal",
            &[(alarm, "internal")],
        );
        r.truth = TruthSummary {
            last_lpm: [0.5, 0.0],
            size_lpm: [0.5, 0.0],
            flowing_s: Some(30.2),
            ..Default::default()
        };
        r.est_lpm = [Some(est), Some(0.0)];
        r
    };
    // Latencies 1, 1.5, 9 s: median 1.5 ≤ 2 s. Size errors 2, 4, 40 %: 4 %.
    let rs = [mk(31.0, 0.51), mk(31.5, 0.52), mk(39.0, 0.7)];
    let refs: Vec<&RunResult> = rs.iter().collect();
    let ts = report::target_list(&refs);
    assert_eq!(target(&ts, "median latency after onset").pass, Some(true));
    assert_eq!(target(&ts, "median size error").pass, Some(true));
    assert_eq!(target(&ts, "leak runs detected").pass, Some(true));
    assert_eq!(target(&ts, "leak runs isolated").pass, Some(true));
    let rs = [mk(33.0, 0.6), mk(31.5, 0.52), mk(39.0, 0.7)];
    let refs: Vec<&RunResult> = rs.iter().collect();
    let ts = report::target_list(&refs);
    assert_eq!(target(&ts, "median latency after onset").pass, Some(false));
    assert_eq!(target(&ts, "median size error").pass, Some(false));
    let md = {
        let mut s = String::new();
        report::leak_table(&mut s, &refs);
        s
    };
    assert!(md.contains("| internal | 0.50 | 3 | 100 % (3/3) |"), "{md}");
}

#[test]
fn holdout_rigs_never_appear_in_a_dev_run() {
    // Every rig set is disjoint from every other (held-out seeds above all).
    let sets = RigSet::ALL;
    for (i, a) in sets.iter().enumerate() {
        for b in &sets[i + 1..] {
            for s in a.seeds() {
                assert!(
                    !b.seeds().contains(s),
                    "{} rig {s} also in {}",
                    a.name(),
                    b.name()
                );
            }
        }
    }
    // The further development rigs: their own set, one cell each with
    // `--quick`, never a held-out seed.
    let wide = plan(&PlanConfig {
        sets: vec![RigSet::Wide],
        quick: true,
        ..Default::default()
    });
    assert_eq!(wide.cells.len(), WIDE_RIGS.len());
    for s in wide
        .specs()
        .chain(wide.cells.iter().map(|c| &c.calibration))
    {
        assert_eq!(s.cell.set, RigSet::Wide, "{}", s.id);
        assert!(WIDE_RIGS.contains(&s.cell.rig), "{}", s.id);
        assert!(s.id.starts_with("wide/"), "{}", s.id);
    }
    let dev = plan(&PlanConfig::default());
    assert_eq!(dev.cells.len(), DEV_RIGS.len() * 4);
    // Per rig: 4 cells × 19 runs, 2 long holds, 9 faults.
    assert_eq!(dev.runs(), DEV_RIGS.len() * (4 * 19 + 2 + 9));
    for s in dev.specs().chain(dev.cells.iter().map(|c| &c.calibration)) {
        assert_eq!(s.cell.set, RigSet::Dev, "{}", s.id);
        assert!(DEV_RIGS.contains(&s.cell.rig), "{}", s.id);
        assert!(!HOLDOUT_RIGS.contains(&s.cell.rig), "{}", s.id);
        assert!(s.id.starts_with("dev/"), "{}", s.id);
    }
    // The run's plant rig is the cell's.
    let first = dev.specs().next().unwrap();
    assert_eq!(first.run().rig.seed, first.cell.rig);
    // Both sets: each run in its own set, the dev part unchanged.
    let both = plan(&PlanConfig {
        sets: vec![RigSet::Dev, RigSet::Holdout],
        ..Default::default()
    });
    for s in both.specs() {
        let seeds = s.cell.set.seeds();
        assert!(seeds.contains(&s.cell.rig), "{}", s.id);
    }
    let dev_part: Vec<&RunSpec> = both.specs().filter(|s| s.cell.set == RigSet::Dev).collect();
    assert_eq!(dev_part, dev.specs().collect::<Vec<_>>());
    // Unique ids; `--rigs 2` plans the first two rigs' runs unchanged.
    let mut ids: Vec<&str> = both.specs().map(|s| s.id.as_str()).collect();
    ids.sort_unstable();
    let n = ids.len();
    ids.dedup();
    assert_eq!(ids.len(), n, "run ids are unique");
    let two = plan(&PlanConfig {
        rigs: Some(2),
        ..Default::default()
    });
    assert!(two.specs().all(|s| s.cell.rig <= 2));
    for s in two.specs() {
        assert!(dev.specs().any(|d| d == s), "{}", s.id);
    }
}

#[test]
fn temp_column_on_even_rigs_and_quick_covers_every_condition() {
    let q = plan(&PlanConfig {
        quick: true,
        ..Default::default()
    });
    assert_eq!(q.cells.len(), DEV_RIGS.len(), "one cell per rig");
    for c in &q.cells {
        assert_eq!(c.cell.temp_column, c.cell.rig % 2 == 0);
    }
    let mut conds: Vec<(u64, u64)> = q
        .cells
        .iter()
        .map(|c| (c.cell.supply_bar as u64, c.cell.temp_c as u64))
        .collect();
    conds.sort_unstable();
    conds.dedup();
    assert_eq!(conds.len(), 4, "{conds:?}");
    // Every cell runs the faults the issue names, the valve command's
    // open wire among them (the held-out rigs run only `--quick`).
    for c in &q.cells {
        let kinds: Vec<FaultKind> = q
            .specs()
            .filter(|s| s.cell == c.cell)
            .filter_map(|s| s.fault)
            .collect();
        for kind in [
            FaultKind::SpikesXPiston,
            FaultKind::OpenWirePPiston,
            FaultKind::OpenWireUValve,
            FaultKind::FrozenXPiston,
            FaultKind::NanTime,
        ] {
            assert!(kinds.contains(&kind), "{:?} lacks {kind:?}", c.cell);
        }
    }
    // Each supply and each temperature with and without the column.
    for pick in [|c: &Cell| c.supply_bar, |c: &Cell| c.temp_c] {
        let mut seen: Vec<(u64, bool)> = q
            .cells
            .iter()
            .map(|c| (pick(&c.cell) as u64, c.cell.temp_column))
            .collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 4, "{seen:?}");
    }
    // So do the cells with the long hold and the faults in the full matrix.
    let full = plan(&PlanConfig::default());
    let mut special: Vec<(u64, u64, bool)> = full
        .specs()
        .filter(|s| s.category == Category::HealthyLongHold)
        .map(|s| {
            (
                s.cell.supply_bar as u64,
                s.cell.temp_c as u64,
                s.cell.temp_column,
            )
        })
        .collect();
    special.sort_unstable();
    special.dedup();
    assert!(special.len() >= 5, "{special:?}");
    // Step amplitudes are drawn within ±0.2..0.6, both signs.
    let amps: Vec<f64> = plan(&PlanConfig::default())
        .specs()
        .filter_map(|s| match s.scenario {
            plant::Scenario::StepTest { amplitude, .. } => Some(amplitude),
            _ => None,
        })
        .collect();
    assert!(amps.iter().all(|a| (0.2..=0.6).contains(&a.abs())));
    assert!(amps.iter().any(|a| *a > 0.0) && amps.iter().any(|a| *a < 0.0));
}

/// A short run with NaN time stamps (a time fault survives the cache).
fn short_spec() -> RunSpec {
    let mut s = spec(Category::Fault, 0.0, 0.0, 0.0);
    s.id = "test/short-nan-time".into();
    s.scenario = plant::Scenario::ClosedLoop {
        duration_s: 3.0,
        seed: 5,
    };
    s.fault = Some(FaultKind::NanTime);
    s.faults = vec![plant::Fault::NanTime {
        at_s: 1.0,
        for_s: 0.5,
    }];
    s
}

#[test]
fn cache_round_trip_gives_the_same_recording_and_result() {
    let dir = tempfile::tempdir().unwrap();
    let s = short_spec();
    let (text, cached) = exec::recording_for(&s, Some(dir.path())).unwrap();
    assert!(!cached);
    let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(files.len(), 1, "one recording, no temporary left");
    let (again, cached) = exec::recording_for(&s, Some(dir.path())).unwrap();
    assert!(cached, "second time from the cache");
    assert_eq!(text, again);
    let (fresh, _) = exec::recording_for(&s, None).unwrap();
    assert_eq!(text, fresh, "the cache stores exactly what is replayed");
    // NaN time reaches the monitor as NaN; the run replays the same.
    let samples = exec::samples_of(&text).unwrap();
    assert_eq!(samples.len(), 3000);
    assert!(samples.iter().any(|s| s.t_s.is_nan()));
    let params = Params::nominal();
    let a = exec::replay_text(&s, &text, &params).unwrap();
    let b = exec::replay_text(&s, &again, &params).unwrap();
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
    assert_eq!(a.samples, 3000);
    assert!(!a.fault_verdicts.is_empty(), "the fault window is observed");
    // Another run never reads this one's file.
    let mut other = s.clone();
    other.noise_seed = 2;
    let (_, cached) = exec::recording_for(&other, Some(dir.path())).unwrap();
    assert!(!cached);
}

#[test]
fn tiny_evaluation_end_to_end() {
    let start = Instant::now();
    let mut p = plan(&PlanConfig {
        rigs: Some(1),
        quick: true,
        calibration_s: 30.0,
        ..Default::default()
    });
    // Two short runs: healthy, and an internal leak from 12 s.
    p.jobs.retain(|j| {
        j.head.id.ends_with("/healthy-step") || j.head.id.ends_with("/internal-0.50-on30")
    });
    assert_eq!(p.jobs.len(), 2);
    for j in &mut p.jobs {
        if j.head.category == Category::Leak {
            j.head.scenario = plant::Scenario::ClosedLoop {
                duration_s: 20.0,
                seed: 3,
            };
            j.head.leak.onset_s = 12.0;
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let cfg = ExecConfig {
        jobs: 2,
        cache: Some(dir.path().to_path_buf()),
        ..ExecConfig::default()
    };
    let ticks = std::sync::atomic::AtomicUsize::new(0);
    let progress = |_: usize, total: usize| {
        assert_eq!(total, 3);
        ticks.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    };
    let ev = eval::run_plan(&p, &cfg, &progress).unwrap();
    assert_eq!(ticks.into_inner(), 3, "a calibration and two runs");
    assert_eq!(ev.cells.len(), 1);
    assert_eq!(ev.runs.len(), 2);
    let cal = &ev.cells[0].calibration;
    assert!(
        cal.status == "calibrated" || cal.status == "refused",
        "{}",
        cal.status
    );
    assert_eq!(cal.report.is_some(), cal.status == "calibrated");
    assert_eq!(cal.refused.is_some(), cal.status == "refused");
    for r in &ev.runs {
        assert_eq!(r.params, cal.status);
        assert!(r.samples > 0 && !r.verdict.is_empty());
        assert!(!r.cached);
    }
    let leak = ev
        .runs
        .iter()
        .find(|r| r.spec.category == Category::Leak)
        .unwrap();
    assert!(
        leak.truth.after_onset_lpm[0] > 0.2,
        "the plant's leak flows: {:?}",
        leak.truth
    );
    let md = report::markdown(&ev);
    for s in [
        "## Development rigs (seeds 1)",
        "### Leaks",
        "### Healthy runs",
        "### Step tests",
        "### Per condition",
        "### Calibration",
        "### Targets",
        "wall time",
    ] {
        assert!(md.contains(s), "no `{s}` in\n{md}");
    }
    assert!(!md.contains("Held-out"), "no holdout cell was run");
    let json = serde_json::to_value(&ev).unwrap();
    assert_eq!(json["runs"].as_array().unwrap().len(), 2);
    assert!(json["cells"][0]["calibration"]["status"].is_string());
    // The loop's oscillation is measured on every calibrated cell's
    // recording, whatever came of the calibration, and shown per cell.
    let share = cal.loop_oscillation_share.expect("measured");
    assert!((0.0..=1.0).contains(&share), "{share}");
    assert!(json["cells"][0]["calibration"]["loop_oscillation_share"].is_number());
    assert!(md.contains("| loop oscillating |"), "{md}");
    // From the cache: the same results.
    let again = eval::run_plan(&p, &cfg, &|_, _| {}).unwrap();
    assert!(again.runs.iter().all(|r| r.cached));
    for (a, b) in ev.runs.iter().zip(&again.runs) {
        assert_eq!(a.verdict, b.verdict);
        assert_eq!(a.alarms, b.alarms);
        assert_eq!(a.truth, b.truth);
    }
    eprintln!("tiny evaluation: {:.1} s", start.elapsed().as_secs_f64());
}

#[test]
fn cli_rejects_an_unknown_set_and_documents_the_sets() {
    let bin = env!("CARGO_BIN_EXE_host-sim");
    let out = std::process::Command::new(bin)
        .args(["eval", "--set", "tuning"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("dev") && err.contains("holdout") && err.contains("both"),
        "{err}"
    );
    let out = std::process::Command::new(bin)
        .args(["eval", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in [
        "--set", "--rigs", "--supply", "--temp", "--quick", "--jobs", "--cache", "--json",
        "--output",
    ] {
        assert!(help.contains(flag), "no {flag} in\n{help}");
    }
}

/// A cell whose calibration is refused (here: a 5 s recording) runs the
/// start parameters as a provisional set, as a user without a calibrated
/// file would; a calibrated one does not.
#[test]
fn a_refused_cell_runs_a_provisional_set() {
    let plan = plan(&PlanConfig {
        rigs: Some(1),
        quick: true,
        calibration_s: 5.0,
        ..Default::default()
    });
    let cell = exec::calibrate_cell(&plan.cells[0], &ExecConfig::default()).unwrap();
    let c = &cell.calibration;
    assert_eq!(c.status, "refused");
    assert!(c
        .refused
        .as_deref()
        .is_some_and(|why| why.contains("too short")));
    assert!(c.params.is_provisional());
    assert_eq!(
        c.params.baseline.provisional_floor_lpm,
        monitor::params::PROVISIONAL_FLOOR_LPM
    );
    // Everything else is the start set.
    let mut back = c.params.clone();
    back.baseline.provisional_floor_lpm = 0.0;
    assert_eq!(back, Params::nominal());
}

/// Where an eval run's time goes (diagnostic: `cargo test --release -p
/// host-sim --test eval -- --ignored --nocapture`).
#[test]
#[ignore = "diagnostic: prints timings"]
fn where_the_time_goes() {
    let plan = plan(&PlanConfig {
        rigs: Some(1),
        quick: true,
        ..Default::default()
    });
    let cfg = ExecConfig::default();
    let t = Instant::now();
    let cell = exec::calibrate_cell(&plan.cells[0], &cfg).unwrap();
    println!(
        "calibration (incl. simulation): {:.2} s",
        t.elapsed().as_secs_f64()
    );
    for spec in plan.specs().take(6) {
        let run = spec.run();
        let json = serde_json::to_string(&run).unwrap();
        let t = Instant::now();
        let rows = plant::simulate(&run);
        let sim = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let text = exec::recording_text(&run, &json, &rows).unwrap();
        let txt = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let r = exec::replay_text(spec, &text, &cell.calibration.params).unwrap();
        let rep = t.elapsed().as_secs_f64();
        println!(
            "{:45} {:>6} samples: simulate {sim:.2} s, text {txt:.3} s, replay {rep:.3} s",
            spec.id, r.samples
        );
    }
}

/// `--set`'s choices by name, in `--help` order.
fn set_choice_names() -> Vec<String> {
    use clap::ValueEnum;
    SetChoice::value_variants()
        .iter()
        .filter_map(|c| c.to_possible_value())
        .map(|v| v.get_name().to_string())
        .collect()
}

#[test]
fn every_rig_set_is_a_set_choice_by_its_name() {
    use clap::ValueEnum;
    // `--set` takes each set of `RigSet::ALL` by its name, once, and
    // `both`; nothing else.
    let names = set_choice_names();
    assert_eq!(names.len(), RigSet::ALL.len() + 1, "{names:?}");
    for set in RigSet::ALL {
        let choice = SetChoice::from_str(set.name(), false)
            .unwrap_or_else(|e| panic!("{}: {e}", set.name()));
        assert_eq!(choice.sets(), vec![set]);
        assert_eq!(names.iter().filter(|n| *n == set.name()).count(), 1);
    }
    let both = SetChoice::from_str("both", false).expect("both");
    assert_eq!(both.sets(), vec![RigSet::Dev, RigSet::Holdout]);
    assert!(SetChoice::from_str("survey99", false).is_err());
}

#[test]
fn the_cli_reference_lists_every_set_choice_in_help_order() {
    // docs/cli.md restates `--set`'s choices: a new survey must appear
    // there too, in the order `--help` gives.
    let expected = format!("host-sim eval [--set {}] ", set_choice_names().join("|"));
    let docs = include_str!("../../docs/cli.md");
    let line = docs
        .lines()
        .find(|l| l.starts_with("host-sim eval "))
        .expect("docs/cli.md has the eval synopsis");
    assert!(
        line.starts_with(&expected),
        "{line}\nexpected it to start with\n{expected}"
    );
}
