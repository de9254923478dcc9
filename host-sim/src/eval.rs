//! `host-sim eval`: simulate a matrix of rigs, conditions and leaks, run the
//! monitor on each, and tabulate detection, isolation, false alarms,
//! latency and size error.
//!
//! Every case runs on a rig whose parameters differ from nominal (seeded
//! variation, `sim::perturbed_rig`); the monitor gets either the nominal
//! parameters or the ones calibrated from a *separate* healthy recording of
//! that rig.

use crate::sim::{perturbed_rig, LeakLaw, Profile, Rig, Scenario, SensorModel, Simulation};
use monitor::{Hypothesis, Monitor, Params, Verdict};
use serde::Serialize;

/// One simulated run of the matrix.
#[derive(Clone, Debug, Serialize)]
pub struct Case {
    /// Index of the rig variation (0 = nominal rig when `nominal_rig`).
    pub rig: u64,
    /// Supply pressure, bar.
    pub supply_bar: f64,
    /// Oil temperature, °C.
    pub temp_c: f64,
    /// Which leaks.
    pub kind: &'static str,
    /// Size of each present leak, l/min (mean flow after onset).
    pub size_lpm: f64,
    /// Leak onset, s.
    pub onset_s: f64,
    /// Noise seed.
    pub seed: u64,
    /// Leak flow law.
    pub law: &'static str,
    /// Motion profile.
    pub profile: &'static str,
    /// Run length, s.
    pub duration_s: f64,
}

/// What the monitor made of one case.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// The case.
    #[serde(flatten)]
    pub case: Case,
    /// Latched verdict at the end.
    pub verdict: &'static str,
    /// First alarm time, s.
    pub first_alarm_s: Option<f64>,
    /// Verdict of the first alarm.
    pub first_alarm: Option<&'static str>,
    /// Leading hypothesis at the end.
    pub leading: &'static str,
    /// Estimated internal / external flow at the end, l/min.
    pub est_lpm: [f64; 2],
    /// True internal / external flow averaged like the estimate, l/min.
    pub true_lpm: [f64; 2],
    /// Samples flagged model-mismatch, fraction.
    pub mismatch: f64,
}

impl CaseResult {
    /// An alarm before the leak existed (or on a healthy run).
    pub fn false_alarm(&self) -> bool {
        match self.first_alarm_s {
            None => false,
            Some(t) => self.case.kind == "healthy" || t < self.case.onset_s,
        }
    }

    /// An alarm after onset.
    pub fn detected(&self) -> bool {
        self.case.kind != "healthy" && self.first_alarm_s.is_some_and(|t| t >= self.case.onset_s)
    }

    /// Detected with the right leak(s) at the end.
    pub fn isolated(&self) -> bool {
        self.detected() && self.verdict == self.case.kind
    }

    /// Seconds from onset to the first alarm.
    pub fn latency_s(&self) -> Option<f64> {
        if self.detected() {
            self.first_alarm_s.map(|t| t - self.case.onset_s)
        } else {
            None
        }
    }

    /// Relative size error of each present leak at the end.
    pub fn size_errors(&self) -> Vec<f64> {
        let h = kind_hypothesis(self.case.kind);
        let mut v = Vec::new();
        for (k, present) in [h.has_internal(), h.has_external()].into_iter().enumerate() {
            if present && self.true_lpm[k] > 1e-6 {
                v.push((self.est_lpm[k] - self.true_lpm[k]).abs() / self.true_lpm[k]);
            }
        }
        v
    }
}

fn kind_hypothesis(kind: &str) -> Hypothesis {
    match kind {
        "internal" => Hypothesis::Internal,
        "external" => Hypothesis::External,
        "both" => Hypothesis::Both,
        _ => Hypothesis::Healthy,
    }
}

/// How each rig is described to the monitor.
pub trait ParamSource: Sync {
    /// Parameters for rig `rig` (with its hardware and sensors).
    fn params_for(&self, rig_index: u64, rig: &Rig, sensors: &SensorModel) -> Params;
}

/// The monitor is given the nominal parameters.
pub struct Nominal(pub Params);

impl ParamSource for Nominal {
    fn params_for(&self, _: u64, _: &Rig, _: &SensorModel) -> Params {
        self.0.clone()
    }
}

/// The rig of case `c` (nominal when `rig == 0 && nominal_rig`).
pub fn rig_of(c: &Case, nominal_rig: bool) -> (Rig, SensorModel) {
    if nominal_rig && c.rig == 0 {
        (Rig::nominal(), SensorModel::default())
    } else {
        perturbed_rig(&Params::nominal(), c.rig)
    }
}

/// Run one case.
pub fn run_case(c: &Case, rig: Rig, sensors: SensorModel, params: &Params) -> CaseResult {
    let h = kind_hypothesis(c.kind);
    let law = if c.law == "orifice" {
        LeakLaw::Orifice
    } else {
        LeakLaw::Laminar
    };
    let profile = match c.profile {
        "random" => Profile::Random,
        "steps" => Profile::Steps,
        "hold" => Profile::Hold,
        _ => Profile::Thesis,
    };
    let scenario = Scenario {
        duration_s: c.duration_s,
        supply_bar: c.supply_bar,
        temp_c: c.temp_c,
        write_temperature: false,
        profile,
        internal_lpm: if h.has_internal() { c.size_lpm } else { 0.0 },
        external_lpm: if h.has_external() { c.size_lpm } else { 0.0 },
        internal_law: law,
        external_law: law,
        leak_onset_s: c.onset_s,
        seed: c.seed,
        sensors,
        ..Scenario::default()
    };
    let mut monitor: Monitor<f32> = Monitor::new(params).expect("validated parameters");
    let window = params.filter.evidence_window_s;
    let mut truth = [0.0f64; 2];
    let mut last_t = None;
    let mut first_alarm = None;
    let mut last = None;
    let mut mismatch = 0u64;
    let mut n = 0u64;
    for row in Simulation::new(scenario, rig) {
        let s = monitor.step(&row.sample);
        let dt = last_t.map_or(0.001, |t0| row.sample.t_s - t0);
        last_t = Some(row.sample.t_s);
        let a = (dt / window).min(1.0);
        truth[0] += a * (row.q_internal_lpm - truth[0]);
        truth[1] += a * (row.q_external_lpm - truth[1]);
        for e in &s.events {
            if let monitor::Event::AlarmRaised(v) = e {
                if first_alarm.is_none() {
                    first_alarm = Some((row.sample.t_s, v.name()));
                }
            }
        }
        if s.health & monitor::status::health::MODEL_MISMATCH != 0 {
            mismatch += 1;
        }
        n += 1;
        last = Some(s);
    }
    let last = last.expect("at least one sample");
    CaseResult {
        case: c.clone(),
        verdict: if last.verdict == Verdict::SensorFault {
            "sensor_fault"
        } else {
            last.verdict.name()
        },
        first_alarm_s: first_alarm.map(|a| a.0),
        first_alarm: first_alarm.map(|a| a.1),
        leading: last.leading.name(),
        est_lpm: [
            last.leak_internal_lpm.unwrap_or(0.0) as f64,
            last.leak_external_lpm.unwrap_or(0.0) as f64,
        ],
        true_lpm: truth,
        mismatch: mismatch as f64 / n.max(1) as f64,
    }
}

/// Run `cases` on `threads` threads.
pub fn run_all(
    cases: &[Case],
    source: &dyn ParamSource,
    nominal_rig: bool,
    threads: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Vec<CaseResult> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::with_capacity(cases.len()));
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if i >= cases.len() {
                    break;
                }
                let c = &cases[i];
                let (rig, sensors) = rig_of(c, nominal_rig);
                let params = source.params_for(c.rig, &rig, &sensors);
                let r = run_case(c, rig, sensors, &params);
                results
                    .lock()
                    .expect("no panics while holding the lock")
                    .push((i, r));
                let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(d, cases.len());
            });
        }
    });
    let mut r = results.into_inner().expect("threads joined");
    r.sort_by_key(|(i, _)| *i);
    r.into_iter().map(|(_, r)| r).collect()
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    })
}

/// The results as a Markdown table, one row per leak kind and size.
pub fn table(results: &[CaseResult]) -> String {
    use std::fmt::Write;
    let mut keys: Vec<(&'static str, u64)> = results
        .iter()
        .map(|r| (r.case.kind, (r.case.size_lpm * 1e4) as u64))
        .collect();
    let order = |k: &str| {
        ["healthy", "internal", "external", "both"]
            .iter()
            .position(|x| *x == k)
            .unwrap_or(9)
    };
    keys.sort_by_key(|(k, s)| (order(k), *s));
    keys.dedup();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| leak | size l/min | runs | detected | isolated | false alarms | median latency s | median size error |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for (kind, size) in keys {
        let rs: Vec<&CaseResult> = results
            .iter()
            .filter(|r| r.case.kind == kind && (r.case.size_lpm * 1e4) as u64 == size)
            .collect();
        let n = rs.len();
        let fa = rs.iter().filter(|r| r.false_alarm()).count();
        let mut lat: Vec<f64> = rs.iter().filter_map(|r| r.latency_s()).collect();
        let mut err: Vec<f64> = rs.iter().flat_map(|r| r.size_errors()).collect();
        let pct = |k: usize| format!("{:.0} % ({k}/{n})", 100.0 * k as f64 / n.max(1) as f64);
        if kind == "healthy" {
            let _ = writeln!(out, "| healthy | – | {n} | – | – | {} | – | – |", pct(fa));
        } else {
            let det = rs.iter().filter(|r| r.detected()).count();
            let iso = rs.iter().filter(|r| r.isolated()).count();
            let _ = writeln!(
                out,
                "| {kind} | {:.2} | {n} | {} | {} | {} | {} | {} |",
                size as f64 / 1e4,
                pct(det),
                pct(iso),
                pct(fa),
                median(&mut lat).map_or("–".into(), |v| format!("{v:.2}")),
                median(&mut err).map_or("–".into(), |v| format!("{:.0} %", 100.0 * v)),
            );
        }
    }
    out
}
