//! Shared helpers of the end-to-end tests.
#![allow(dead_code)]

use host_sim::sim::{Profile, Rig, Scenario, Simulation};
use monitor::{Event, Monitor, Params, Sample, Status, Verdict};

/// What a whole run produced.
pub struct Outcome {
    pub final_status: Status,
    pub first_alarm: Option<(f64, Verdict)>,
    pub alarms: Vec<(f64, Verdict)>,
    pub samples: usize,
}

/// Simulate `scenario` on the nominal rig and run the f32 monitor with the
/// nominal parameters over it, in memory (the CSV layer has its own tests).
pub fn run(scenario: Scenario) -> Outcome {
    run_with(scenario, Rig::reference(), &Params::nominal())
}

/// As `run`, with a given rig and monitor parameters.
pub fn run_with(scenario: Scenario, rig: Rig, params: &Params) -> Outcome {
    let mut m: Monitor<f32> = Monitor::new(params).expect("valid parameters");
    let mut alarms = Vec::new();
    let mut last = None;
    let mut samples = 0;
    for row in Simulation::new(scenario, rig) {
        let s = m.step(&Sample::from(&row));
        for e in &s.events {
            if let Event::AlarmRaised(v) = e {
                alarms.push((s.t_s, *v));
            }
        }
        samples += 1;
        last = Some(s);
    }
    Outcome {
        final_status: last.expect("samples"),
        first_alarm: alarms.first().copied(),
        alarms,
        samples,
    }
}

/// A 60 s thesis-profile scenario.
pub fn scenario(supply: f64, internal: f64, external: f64, onset: f64, seed: u64) -> Scenario {
    Scenario {
        duration_s: 60.0,
        supply_bar: supply,
        internal_lpm: internal,
        external_lpm: external,
        leak_onset_s: onset,
        seed,
        profile: Profile::Thesis,
        ..Scenario::default()
    }
}

/// Every running filter's smallest covariance eigenvalue, after checking
/// each covariance is finite and exactly symmetric; `None` while the bank
/// is not running.
pub fn min_covariance_eigenvalues(m: &Monitor<f32>) -> Option<[f64; 4]> {
    let filters = m.filter_states()?;
    Some(filters.map(|f| {
        let n = f.x.len();
        assert!(f.p.iter().all(|v| v.is_finite()), "non-finite covariance");
        let d = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            assert_eq!(f.p[i + n * j], f.p[j + n * i], "P not symmetric");
            f.p[i + n * j] as f64
        });
        d.symmetric_eigen().eigenvalues.min()
    }))
}
