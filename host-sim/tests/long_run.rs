//! One hour of a healthy rig at 1 kHz in f32: everything stays finite, the
//! covariances PSD, no leak and no sensor fault is ever claimed, and the
//! monitor concludes `healthy` for nearly all of it (it may say
//! `inconclusive` while warming up or short of evidence, never a leak). Takes a few minutes:
//! `cargo test --release -p host-sim --test long_run -- --ignored`

use host_sim::sim::{Profile, Rig, Scenario, Simulation};
use monitor::{Monitor, Params, Sample, Verdict};

mod common;

#[test]
#[ignore = "one simulated hour: run with --release -- --ignored"]
fn one_hour_healthy_stays_finite_psd_and_silent() {
    let sc = Scenario {
        duration_s: 3600.0,
        profile: Profile::Random,
        seed: 77,
        ..Scenario::default()
    };
    let mut m: Monitor<f32> = Monitor::new(&Params::nominal()).unwrap();
    let mut worst = f64::MAX;
    let mut n = 0u64;
    let mut healthy = 0u64;
    let mut last = Verdict::Inconclusive;
    for row in Simulation::new(sc, Rig::reference()) {
        let s = m.step(&Sample::from(&row));
        assert!(
            matches!(s.verdict, Verdict::Healthy | Verdict::Inconclusive),
            "{:?} at t = {}",
            s.verdict,
            s.t_s
        );
        healthy += u64::from(s.verdict == Verdict::Healthy);
        last = s.verdict;
        assert!(
            s.events.is_empty(),
            "event at t = {}: {:?}",
            s.t_s,
            s.events
        );
        if let Some(v) = s.leak_internal_lpm {
            assert!(v.is_finite() && s.leak_external_lpm.unwrap().is_finite());
        }
        n += 1;
        if n.is_multiple_of(60_000) {
            for e in common::min_covariance_eigenvalues(&m).unwrap() {
                worst = worst.min(e);
                assert!(e > -1e-9, "covariance not PSD at t = {}: {e}", s.t_s);
            }
        }
    }
    assert_eq!(n, 3_600_000);
    let fraction = healthy as f64 / n as f64;
    println!(
        "1 h healthy: no alarm, healthy on {:.2} % of samples, smallest covariance eigenvalue {worst:.3e}",
        100.0 * fraction
    );
    assert!(fraction > 0.95, "healthy on only {:.2} %", 100.0 * fraction);
    assert_eq!(last, Verdict::Healthy);
}
