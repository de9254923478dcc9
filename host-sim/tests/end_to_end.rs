//! End to end on simulated recordings of the reference rig: the monitor's
//! verdicts on healthy runs and on the thesis' Level 4 leaks (≈ 0.4 l/min at
//! 50 bar), single and combined.

mod common;
use common::{run, scenario};
use monitor::Verdict;

fn assert_healthy(supply: f64) {
    let o = run(scenario(supply, 0.0, 0.0, 0.0, 21));
    assert_eq!(o.first_alarm, None, "false alarm at {supply} bar");
    assert_eq!(o.final_status.verdict, Verdict::Healthy);
    // Its size estimates stay well below the alarm level.
    let li = o.final_status.leak_internal_lpm.unwrap();
    let le = o.final_status.leak_external_lpm.unwrap();
    assert!(
        li.abs() < 0.06 && le.abs() < 0.06,
        "healthy run estimates {li} / {le} l/min"
    );
}

#[test]
fn healthy_at_50_bar_raises_no_alarm() {
    assert_healthy(50.0);
}

#[test]
fn healthy_at_100_bar_raises_no_alarm() {
    assert_healthy(100.0);
}

/// A leak starting mid-run is detected, isolated, and sized.
fn assert_leak(supply: f64, internal: f64, external: f64, want: Verdict) {
    let onset = 20.0;
    let o = run(scenario(supply, internal, external, onset, 22));
    let (t, _) = o
        .first_alarm
        .unwrap_or_else(|| panic!("{want:?} leak not detected at {supply} bar"));
    assert!(t >= onset, "alarm at {t} s before the leak began");
    assert!(t < onset + 10.0, "alarm {:.1} s after onset", t - onset);
    assert_eq!(o.final_status.verdict, want, "alarms: {:?}", o.alarms);
}

#[test]
fn internal_leak_level_4_is_detected_and_isolated() {
    assert_leak(50.0, 0.4, 0.0, Verdict::Internal);
}

#[test]
fn external_leak_level_4_is_detected_and_isolated() {
    assert_leak(50.0, 0.0, 0.4, Verdict::External);
}

#[test]
fn both_leaks_at_once_are_reported_as_both() {
    // The thesis could not isolate combined leaks.
    assert_leak(50.0, 0.4, 0.4, Verdict::Both);
}

#[test]
fn leaks_at_100_bar_are_detected_and_isolated() {
    assert_leak(100.0, 0.4, 0.0, Verdict::Internal);
    assert_leak(100.0, 0.0, 0.4, Verdict::External);
}

#[test]
fn leak_sizes_are_estimated() {
    // Level 4 leaks from the start: the estimate at the end of the run is
    // within 25 % of the true flow averaged the same way.
    use host_sim::sim::{Rig, Simulation};
    use monitor::{Monitor, Params, Sample};
    for (int, ext) in [(0.4, 0.0), (0.0, 0.4), (0.4, 0.4)] {
        let sc = scenario(50.0, int, ext, 0.0, 23);
        let params = Params::nominal();
        let mut m: Monitor<f32> = Monitor::new(&params).unwrap();
        let (mut ti, mut te) = (0.0f64, 0.0f64);
        let mut last = None;
        for row in Simulation::new(sc, Rig::reference()) {
            let a = 0.001 / params.filter.evidence_window_s;
            ti += a * (row.q_internal_lpm.abs() - ti);
            te += a * (row.q_external_lpm.abs() - te);
            last = Some(m.step(&Sample::from(&row)));
        }
        let s = last.unwrap();
        let (ei, ee) = (
            s.leak_internal_lpm.unwrap() as f64,
            s.leak_external_lpm.unwrap() as f64,
        );
        for (est, truth) in [(ei, ti), (ee, te)] {
            if truth > 0.05 {
                assert!(
                    (est - truth).abs() < 0.25 * truth,
                    "estimate {est:.3} vs true {truth:.3} l/min"
                );
            } else {
                assert!(est.abs() < 0.06, "absent leak estimated at {est:.3} l/min");
            }
        }
    }
}
