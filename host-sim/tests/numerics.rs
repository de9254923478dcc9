//! Numerical behaviour of the same filter code: f32 against its f64
//! reference, determinism, faults and gaps, and covariance health.

mod common;
use common::scenario;
use host_sim::sim::{Rig, Simulation};
use monitor::{Event, Monitor, Params, Sample, Status, Verdict};

fn samples(internal: f64, external: f64, seed: u64) -> Vec<Sample> {
    Simulation::new(
        scenario(50.0, internal, external, 0.0, seed),
        Rig::reference(),
    )
    .map(Sample::from)
    .collect()
}

fn replay<T: monitor::Real>(s: &[Sample]) -> Vec<Status> {
    let mut m: Monitor<T> = Monitor::new(&Params::nominal()).unwrap();
    s.iter().map(|x| m.step(x)).collect()
}

#[test]
fn f32_filter_agrees_with_its_f64_reference() {
    let s = samples(0.4, 0.0, 31);
    let a = replay::<f32>(&s);
    let b = replay::<f64>(&s);
    let last = (a.last().unwrap(), b.last().unwrap());
    assert_eq!(last.0.verdict, last.1.verdict);
    for (x, y) in [
        (last.0.leak_internal_lpm, last.1.leak_internal_lpm),
        (last.0.leak_external_lpm, last.1.leak_external_lpm),
    ] {
        let (x, y) = (x.unwrap(), y.unwrap());
        assert!((x - y).abs() < 0.01, "f32 {x} vs f64 {y} l/min");
    }
    // The size estimates track each other throughout, not just at the end.
    let worst = a
        .iter()
        .zip(&b)
        .filter_map(|(p, q)| Some((p.leak_internal_lpm? - q.leak_internal_lpm?).abs()))
        .fold(0.0f32, f32::max);
    assert!(
        worst < 0.02,
        "f32 and f64 size estimates differ by up to {worst} l/min"
    );
}

#[test]
fn same_input_same_output_bit_for_bit() {
    let s = samples(0.0, 0.3, 32);
    assert_eq!(replay::<f32>(&s), replay::<f32>(&s));
}

#[test]
fn a_missing_reading_is_a_sensor_fault_never_healthy_nor_a_leak() {
    let mut s = samples(0.0, 0.0, 33);
    for x in &mut s[20_000..20_500] {
        x.p_rod_bar = None;
    }
    let st = replay::<f32>(&s);
    assert_eq!(st[20_000].verdict, Verdict::SensorFault);
    assert!(st[20_000]
        .events
        .contains(&Event::SensorFault(monitor::Channel::PRod)));
    assert!(st[20_000..20_500]
        .iter()
        .all(|x| x.verdict == Verdict::SensorFault));
    assert!(st[20_500]
        .events
        .contains(&Event::SensorRecovered(monitor::Channel::PRod)));
    assert!(
        st.iter().all(|x| !x.verdict.is_leak()),
        "fault reported as a leak"
    );
}

#[test]
fn a_frozen_reading_is_a_sensor_fault_never_healthy_nor_a_leak() {
    // A logger or transmitter that repeats its last value: each channel
    // frozen from 20 s to the end of a healthy 60 s run. Unchecked, a
    // frozen position reads as a leak (the oil goes somewhere) and a frozen
    // pressure as "healthy".
    let clean = samples(0.0, 0.0, 36);
    let frozen_from = 20_000;
    for ch in [
        monitor::Channel::XPiston,
        monitor::Channel::PPiston,
        monitor::Channel::PRod,
    ] {
        let mut s = clean.clone();
        let held = s[frozen_from];
        for x in &mut s[frozen_from..] {
            match ch {
                monitor::Channel::XPiston => x.x_piston_m = held.x_piston_m,
                monitor::Channel::PPiston => x.p_piston_bar = held.p_piston_bar,
                _ => x.p_rod_bar = held.p_rod_bar,
            }
        }
        let st = replay::<f32>(&s);
        let at = st
            .iter()
            .position(|x| x.events.contains(&Event::SensorFault(ch)))
            .unwrap_or_else(|| panic!("{ch:?} frozen but never faulted"));
        let delay = st[at].t_s - s[frozen_from].t_s;
        assert!(delay <= 3.0, "{ch:?} faulted {delay:.3} s after it froze");
        assert!(
            st[at..].iter().all(|x| x.verdict == Verdict::SensorFault),
            "{ch:?}: verdict left sensor fault while frozen"
        );
        assert!(
            st.iter().all(|x| !x.verdict.is_leak()),
            "{ch:?} frozen reported as a leak"
        );
    }
    // The same run unfrozen: no fault at all.
    assert!(replay::<f32>(&clean)
        .iter()
        .all(|x| x.faulted_channels == 0));
}

#[test]
fn a_sensor_fault_takes_precedence_over_a_latched_alarm() {
    let mut s = samples(0.5, 0.0, 34);
    let n = s.len();
    for x in &mut s[n - 100..] {
        x.x_piston_m = Some(9.0); // implausible: far outside the stroke
    }
    let st = replay::<f32>(&s);
    assert!(st[n - 101].verdict.is_leak());
    assert_eq!(st[n - 1].verdict, Verdict::SensorFault);
}

#[test]
fn a_gap_in_time_restarts_the_filters() {
    let mut s = samples(0.0, 0.0, 35);
    for x in &mut s[30_000..] {
        x.t_s += 1.0;
    }
    let st = replay::<f32>(&s);
    assert!(st[30_000].events.contains(&Event::DataGap));
    // Never a leak; right after the gap no claim (the filters restart),
    // and healthy again once they have seen evidence.
    assert!(st.iter().all(|x| !x.verdict.is_leak()));
    assert_eq!(st[30_000].verdict, Verdict::Inconclusive);
    assert_eq!(st[30_500].verdict, Verdict::Inconclusive);
    assert_eq!(st.last().unwrap().verdict, Verdict::Healthy);
}

#[test]
fn covariances_stay_symmetric_positive_definite() {
    let s = samples(0.3, 0.3, 36);
    let mut m: Monitor<f32> = Monitor::new(&Params::nominal()).unwrap();
    for (k, x) in s.iter().enumerate() {
        m.step(x);
        if k % 5000 == 4999 {
            let mins = common::min_covariance_eigenvalues(&m).expect("filters running");
            for (i, e) in mins.iter().enumerate() {
                assert!(*e > -1e-9, "filter {i}: min eigenvalue {e}");
            }
        }
    }
}
