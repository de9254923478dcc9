//! `host-sim eval`: simulate a matrix of rigs, conditions and leaks, run the
//! monitor on each, and tabulate detection, isolation, false alarms,
//! latency and size error.
//!
//! Every rig's parameters differ from nominal (seeded variation,
//! `sim::perturbed_rig`: valve coefficients, friction, moving mass, air,
//! dead volumes, sensor offsets). With calibration on, the monitor gets the
//! parameters fitted by `host-sim calibrate` from a *separate* healthy
//! recording of that rig (120 s at 50 bar, 25 °C); otherwise the nominal
//! ones. Simulated recordings and calibrations can be cached in a directory
//! so that re-running with other monitor settings only replays.

use crate::calibrate::calibrate;
use crate::recording::{RecordingReader, RecordingWriter};
use crate::sim::{perturbed_rig, LeakLaw, Profile, Rig, Scenario, SensorModel, Simulation};
use monitor::{Hypothesis, Monitor, Params, Sample};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One simulated run of the matrix.
#[derive(Clone, Debug, Serialize)]
pub struct Case {
    /// Index of the rig variation (0 = the nominal rig when requested).
    pub rig: u64,
    /// Supply pressure, bar.
    pub supply_bar: f64,
    /// Oil temperature, °C.
    pub temp_c: f64,
    /// Whether the recording has the `temp_oil` column.
    pub with_temp: bool,
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

impl Case {
    fn file_name(&self) -> String {
        format!(
            "rig{}_{}bar_{}C{}_{}_{:.3}_on{}_{}_{}_{}s_s{}.csv.gz",
            self.rig,
            self.supply_bar,
            self.temp_c,
            if self.with_temp { "t" } else { "" },
            self.kind,
            self.size_lpm,
            self.onset_s,
            self.law,
            self.profile,
            self.duration_s,
            self.seed
        )
    }
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
    /// True internal / external flow magnitude averaged like the estimate,
    /// l/min.
    pub true_lpm: [f64; 2],
    /// Largest (signed) detection average before the onset (healthy: whole
    /// run, after warm-up), internal / external, l/min: the false-alarm
    /// margin, as the alarm's CUSUM sees it.
    pub quiet_peak_lpm: [f64; 2],
    /// When a present leak's true flow (averaged like the detection, 0.25 s)
    /// first exceeded the alarm level, s. An internal leak only flows while
    /// the chambers' pressures differ: at a hold with equal pressures a
    /// "0.3 l/min" leak may flow 0.05 l/min for seconds.
    pub flowing_s: Option<f64>,
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

    /// Seconds from onset to the first alarm, for leaks starting mid-run
    /// (a leak present from the start is limited by the warm-up).
    pub fn latency_s(&self) -> Option<f64> {
        if self.detected() && self.case.onset_s > 0.0 {
            self.first_alarm_s.map(|t| t - self.case.onset_s)
        } else {
            None
        }
    }

    /// Seconds from the leak's true flow first exceeding the alarm level to
    /// the first alarm (mid-run onsets).
    pub fn latency_flowing_s(&self) -> Option<f64> {
        if self.detected() && self.case.onset_s > 0.0 {
            match (self.first_alarm_s, self.flowing_s) {
                (Some(a), Some(f)) => Some((a - f).max(0.0)),
                _ => None,
            }
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

/// How to run the matrix.
#[derive(Clone, Debug)]
pub struct EvalConfig {
    /// Monitor parameters to start from (and to use without calibration).
    pub params: Params,
    /// Calibrate each rig from its own healthy recording.
    pub calibrate: bool,
    /// Rig 0 is the reference rig itself.
    pub nominal_rig: bool,
    /// Cache for recordings and calibrations.
    pub cache: Option<PathBuf>,
    /// Worker threads.
    pub threads: usize,
}

/// The rig of case `c`.
pub fn rig_of(rig: u64, nominal_rig: bool) -> (Rig, SensorModel) {
    if nominal_rig && rig == 0 {
        (Rig::nominal(), SensorModel::default())
    } else {
        perturbed_rig(&Params::nominal(), rig)
    }
}

/// The scenario of a case.
pub fn scenario_of(c: &Case, sensors: SensorModel) -> Scenario {
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
    Scenario {
        duration_s: c.duration_s,
        supply_bar: c.supply_bar,
        temp_c: c.temp_c,
        write_temperature: c.with_temp,
        profile,
        internal_lpm: if h.has_internal() { c.size_lpm } else { 0.0 },
        external_lpm: if h.has_external() { c.size_lpm } else { 0.0 },
        internal_law: law,
        external_law: law,
        leak_onset_s: c.onset_s,
        seed: c.seed,
        sensors,
        ..Scenario::default()
    }
}

/// Samples with the true leak flows (internal, external, l/min).
type Rows = Vec<(Sample, [f64; 2])>;

fn simulate(scenario: Scenario, rig: Rig) -> Rows {
    Simulation::new(scenario, rig)
        .map(|r| (r.sample, [r.q_internal_lpm, r.q_external_lpm]))
        .collect()
}

fn save(path: &Path, rows: &Rows, with_temp: bool) -> anyhow::Result<()> {
    // Written under a temporary name (ending in .gz, so it is compressed)
    // and renamed, so an interrupted run never leaves a truncated case.
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.part.gz"));
    let mut w =
        RecordingWriter::create(&tmp, &[], with_temp, &["q_internal_lpm", "q_external_lpm"])?;
    for (s, q) in rows {
        w.write(s, q)?;
    }
    w.close()?;
    std::fs::rename(&tmp, path)?;
    Ok(())
}

fn load(path: &Path) -> anyhow::Result<Rows> {
    let mut r = RecordingReader::open(path)?;
    let col = |name: &str, r: &RecordingReader<_>| {
        r.extra_columns()
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, i)| *i)
    };
    let (ci, ce) = (col("q_internal_lpm", &r), col("q_external_lpm", &r));
    let (Some(ci), Some(ce)) = (ci, ce) else {
        anyhow::bail!("{}: no truth columns", path.display());
    };
    let mut rows = Vec::new();
    while let Some(s) = r.next() {
        let s = s?;
        let f = |i| {
            r.last_field(i)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .unwrap_or(0.0)
        };
        rows.push((s, [f(ci), f(ce)]));
    }
    if rows.is_empty() {
        anyhow::bail!(
            "{}: no samples (delete it to simulate the case again)",
            path.display()
        );
    }
    Ok(rows)
}

/// The rows of a scenario, from the cache if there, else simulated (and
/// cached).
fn rows_for(
    cache: Option<&Path>,
    name: &str,
    scenario: Scenario,
    rig: Rig,
) -> anyhow::Result<Rows> {
    let with_temp = scenario.write_temperature;
    match cache {
        Some(dir) => {
            let path = dir.join(name);
            if path.exists() {
                return load(&path);
            }
            let rows = simulate(scenario, rig);
            save(&path, &rows, with_temp)?;
            Ok(rows)
        }
        None => Ok(simulate(scenario, rig)),
    }
}

/// Parameters of rig `rig` as the monitor will get them: calibrated from a
/// separate 120 s healthy recording at 50 bar, 25 °C, or the start values.
pub fn params_for_rig(cfg: &EvalConfig, rig: u64) -> anyhow::Result<Params> {
    if !cfg.calibrate {
        return Ok(cfg.params.clone());
    }
    let (hw, sensors) = rig_of(rig, cfg.nominal_rig);
    let sc = Scenario {
        duration_s: 120.0,
        seed: 7_000 + rig,
        sensors,
        ..Scenario::default()
    };
    let rows = rows_for(
        cfg.cache.as_deref(),
        &format!("calibration_rig{rig}.csv.gz"),
        sc,
        hw,
    )?;
    let samples: Vec<Sample> = rows.into_iter().map(|(s, _)| s).collect();
    Ok(calibrate(&samples, &cfg.params)?.params)
}

/// Run one case with the given monitor parameters.
pub fn run_case(c: &Case, rows: &Rows, params: &Params) -> CaseResult {
    let mut monitor: Monitor<f32> = Monitor::new(params).expect("validated parameters");
    let window = params.filter.evidence_window_s;
    let mut truth = [0.0f64; 2];
    let mut last_t = None;
    let mut first_alarm = None;
    let mut last = None;
    let mut peak = [0.0f64; 2];
    let h = kind_hypothesis(c.kind);
    let present = [h.has_internal(), h.has_external()];
    let mut short = [0.0f64; 2];
    let mut flowing = None;
    for (sample, q) in rows {
        let s = monitor.step(sample);
        let dt = last_t.map_or(params.filter.sample_period_s, |t0| sample.t_s - t0);
        last_t = Some(sample.t_s);
        let a = (dt / window).min(1.0);
        truth[0] += a * (q[0].abs() - truth[0]);
        truth[1] += a * (q[1].abs() - truth[1]);
        let a_short = (dt / params.filter.detection_window_s).min(1.0);
        for k in 0..2 {
            short[k] += a_short * (q[k].abs() - short[k]);
            if flowing.is_none()
                && present[k]
                && sample.t_s >= c.onset_s
                && short[k] >= params.alarm.alarm_lpm
            {
                flowing = Some(sample.t_s);
            }
        }
        let before_leak = c.kind == "healthy" || sample.t_s < c.onset_s;
        if before_leak {
            if let (Some(i), Some(e)) = (s.detect_internal_lpm, s.detect_external_lpm) {
                peak[0] = peak[0].max(i as f64);
                peak[1] = peak[1].max(e as f64);
            }
        }
        for e in &s.events {
            if let monitor::Event::AlarmRaised(v) = e {
                if first_alarm.is_none() {
                    first_alarm = Some((sample.t_s, v.name()));
                }
            }
        }
        last = Some(s);
    }
    let last = last.expect("at least one sample");
    CaseResult {
        case: c.clone(),
        verdict: last.verdict.name(),
        first_alarm_s: first_alarm.map(|a| a.0),
        first_alarm: first_alarm.map(|a| a.1),
        leading: last.leading.name(),
        est_lpm: [
            last.leak_internal_lpm.unwrap_or(0.0) as f64,
            last.leak_external_lpm.unwrap_or(0.0) as f64,
        ],
        true_lpm: truth,
        quiet_peak_lpm: peak,
        flowing_s: flowing,
    }
}

/// Run `cases` on `cfg.threads` threads.
pub fn run_all(
    cases: &[Case],
    cfg: &EvalConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> anyhow::Result<Vec<CaseResult>> {
    use std::collections::BTreeMap;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;
    if let Some(dir) = &cfg.cache {
        std::fs::create_dir_all(dir)?;
    }
    // Calibrate every rig first (in parallel too).
    let rigs: Vec<u64> = {
        let mut r: Vec<u64> = cases.iter().map(|c| c.rig).collect();
        r.sort_unstable();
        r.dedup();
        r
    };
    let params: Mutex<BTreeMap<u64, Params>> = Mutex::new(BTreeMap::new());
    let errors: Mutex<Vec<anyhow::Error>> = Mutex::new(Vec::new());
    let next = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for _ in 0..cfg.threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&rig) = rigs.get(i) else { break };
                match params_for_rig(cfg, rig) {
                    Ok(p) => {
                        params
                            .lock()
                            .expect("no panic holding the lock")
                            .insert(rig, p);
                    }
                    Err(e) => errors
                        .lock()
                        .expect("no panic holding the lock")
                        .push(e.context(format!("rig {rig}"))),
                }
            });
        }
    });
    if let Some(e) = errors.into_inner().expect("threads joined").pop() {
        return Err(e);
    }
    let params = params.into_inner().expect("threads joined");
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results = Mutex::new(Vec::with_capacity(cases.len()));
    let errors: Mutex<Vec<anyhow::Error>> = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..cfg.threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(c) = cases.get(i) else { break };
                let (rig, sensors) = rig_of(c.rig, cfg.nominal_rig);
                match rows_for(
                    cfg.cache.as_deref(),
                    &c.file_name(),
                    scenario_of(c, sensors),
                    rig,
                ) {
                    Ok(rows) => {
                        let r = run_case(c, &rows, &params[&c.rig]);
                        results
                            .lock()
                            .expect("no panic holding the lock")
                            .push((i, r));
                    }
                    Err(e) => errors.lock().expect("no panic holding the lock").push(e),
                }
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, cases.len());
            });
        }
    });
    if let Some(e) = errors.into_inner().expect("threads joined").pop() {
        return Err(e);
    }
    let mut r = results.into_inner().expect("threads joined");
    r.sort_by_key(|(i, _)| *i);
    Ok(r.into_iter().map(|(_, r)| r).collect())
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

fn pct(k: usize, n: usize) -> String {
    format!("{:.0} % ({k}/{n})", 100.0 * k as f64 / n.max(1) as f64)
}

/// The results as a Markdown table, one row per leak kind and size.
pub fn table(results: &[CaseResult]) -> String {
    use std::fmt::Write;
    let mut keys: Vec<(&'static str, u64)> = results
        .iter()
        .map(|r| (r.case.kind, (r.case.size_lpm * 1e4).round() as u64))
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
        "| leak | size l/min | runs | detected | isolated | false alarms | latency after onset s, median (max) | latency after the leak flows above the alarm level s, median (max) | median size error |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for (kind, size) in keys {
        let rs: Vec<&CaseResult> = results
            .iter()
            .filter(|r| r.case.kind == kind && (r.case.size_lpm * 1e4).round() as u64 == size)
            .collect();
        let n = rs.len();
        let fa = rs.iter().filter(|r| r.false_alarm()).count();
        let mut lat: Vec<f64> = rs.iter().filter_map(|r| r.latency_s()).collect();
        let max_lat = lat.iter().copied().fold(f64::NAN, f64::max);
        let mut flow_lat: Vec<f64> = rs.iter().filter_map(|r| r.latency_flowing_s()).collect();
        let max_flow_lat = flow_lat.iter().copied().fold(f64::NAN, f64::max);
        let mut err: Vec<f64> = rs.iter().flat_map(|r| r.size_errors()).collect();
        if kind == "healthy" {
            let peak = rs
                .iter()
                .map(|r| r.quiet_peak_lpm[0].max(r.quiet_peak_lpm[1]))
                .fold(0.0, f64::max);
            let _ = writeln!(
                out,
                "| healthy | – | {n} | – | – | {} (largest reading {peak:.3} l/min) | – | – | – |",
                pct(fa, n)
            );
        } else {
            let det = rs.iter().filter(|r| r.detected()).count();
            let iso = rs.iter().filter(|r| r.isolated()).count();
            let _ = writeln!(
                out,
                "| {kind} | {:.2} | {n} | {} | {} | {} | {} | {} | {} |",
                size as f64 / 1e4,
                pct(det, n),
                pct(iso, n),
                pct(fa, n),
                median(&mut lat).map_or("–".into(), |v| format!("{v:.2} ({max_lat:.1})")),
                median(&mut flow_lat)
                    .map_or("–".into(), |v| format!("{v:.2} ({max_flow_lat:.1})")),
                median(&mut err).map_or("–".into(), |v| format!("{:.0} %", 100.0 * v)),
            );
        }
    }
    out
}

/// A short breakdown by operating condition.
pub fn by_condition(results: &[CaseResult]) -> String {
    use std::fmt::Write;
    let mut conds: Vec<(u64, u64, bool)> = results
        .iter()
        .map(|r| {
            (
                r.case.supply_bar as u64,
                r.case.temp_c as u64,
                r.case.with_temp,
            )
        })
        .collect();
    conds.sort_unstable();
    conds.dedup();
    let mut out = String::from("| supply | oil | temp_oil column | runs | false alarms | detected (leaks) | isolated |\n|---|---|---|---|---|---|---|\n");
    for (p, t, wt) in conds {
        let rs: Vec<&CaseResult> = results
            .iter()
            .filter(|r| {
                r.case.supply_bar as u64 == p && r.case.temp_c as u64 == t && r.case.with_temp == wt
            })
            .collect();
        let leaks: Vec<&&CaseResult> = rs.iter().filter(|r| r.case.kind != "healthy").collect();
        let _ = writeln!(
            out,
            "| {p} bar | {t} °C | {} | {} | {} | {} | {} |",
            if wt { "yes" } else { "no" },
            rs.len(),
            rs.iter().filter(|r| r.false_alarm()).count(),
            pct(leaks.iter().filter(|r| r.detected()).count(), leaks.len()),
            pct(leaks.iter().filter(|r| r.isolated()).count(), leaks.len()),
        );
    }
    out
}
