//! Running the matrix: simulate each run on the plant (or take it from the
//! cache), calibrate each cell from its own healthy recording, replay every
//! run through the monitor and summarise what it did and what was true.

use super::plan::{fault_window, CellPlan, Plan, PlanConfig, FAULT_AT_S};
use super::{fnv1a64, Category, Cell, Follower, Job, Placement, RunSpec};
use crate::calibrate::{calibrate, Fit};
use crate::recording::RecordingWriter;
use anyhow::{Context, Result};
use monitor::{Event, Monitor, Params, Sample};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Truth columns of the recordings (after the recording format's columns).
pub const TRUTH_COLUMNS: [&str; 3] = ["q_internal_lpm", "q_external_lpm", "v_m_s"];

/// Bump when the recording text of a run changes for the same `Run`.
const CACHE_VERSION: u32 = 1;

/// Verdict samples of a fault run count from this long after the fault
/// starts, s (the monitor's reaction time).
pub const FAULT_GRACE_S: f64 = 0.1;

/// A piston is holding when its (0.1 s averaged) speed is below this, m/s.
const HOLD_SPEED: f64 = 0.002;
/// A piston is moving when its (0.1 s averaged) speed is above this, m/s,
/// and mid-move once it has for [`MID_MOVE_S`].
const MOVE_SPEED: f64 = 0.003;
/// See [`MOVE_SPEED`], s.
const MID_MOVE_S: f64 = 0.3;
/// Shortest still interval that counts as a hold, s.
const MIN_HOLD_S: f64 = 5.0;
/// Size error is measured against the true flow over this last span, s.
pub const SIZE_SPAN_S: f64 = 4.0;

/// How to execute a plan.
#[derive(Clone, Debug)]
pub struct ExecConfig {
    /// Parameters to calibrate from (and to use where calibration is
    /// refused or off): the reference rig's unless given.
    pub start: Params,
    /// Calibrate each cell (off: every cell gets `start`).
    pub calibrate: bool,
    /// Worker threads.
    pub jobs: usize,
    /// Cache of simulated recordings.
    pub cache: Option<PathBuf>,
}

impl Default for ExecConfig {
    fn default() -> Self {
        Self {
            start: Params::nominal(),
            calibrate: true,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            cache: None,
        }
    }
}

/// A cell's calibration and what came of it.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationOutcome {
    /// `calibrated`, `refused` (the cell runs with the start parameters) or
    /// `off` (`--no-calibration`).
    pub status: &'static str,
    /// Why calibration refused the recording.
    pub refused: Option<String>,
    /// `Calibration::report()`.
    pub report: Option<String>,
    /// What was fitted, with quality.
    pub fits: Vec<Fit>,
    /// Calibration's warnings.
    pub warnings: Vec<String>,
    /// Healthy-filter mean NIS on the calibration recording before / after.
    pub nis_before: Option<f64>,
    /// As above, after.
    pub nis_after: Option<f64>,
    /// Largest leak reading on the calibration recording before, l/min.
    pub leak_before_lpm: Option<[f64; 2]>,
    /// As above, after.
    pub leak_after_lpm: Option<[f64; 2]>,
    /// Wall time of the calibration, s.
    pub wall_s: f64,
    /// The parameters the cell's runs use.
    pub params: Params,
}

/// One cell: the rig as drawn and its calibration.
#[derive(Clone, Debug, Serialize)]
pub struct CellResult {
    /// The cell.
    pub cell: Cell,
    /// The rig (every randomised property).
    pub rig: plant::RigSpec,
    /// The calibration run.
    pub calibration_run: RunSpec,
    /// Its outcome.
    pub calibration: CalibrationOutcome,
}

/// An alarm (or a sensor event).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Alarm {
    /// True time of the sample, s.
    pub t_s: f64,
    /// `Verdict::name()` of the alarm, or the channel of a sensor event.
    pub what: String,
}

/// What was true during a run (from the plant's truth, not the recording).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TruthSummary {
    /// Length, s.
    pub duration_s: f64,
    /// Mean true internal / external flow over the last 4 s, l/min.
    pub last_lpm: [f64; 2],
    /// Mean true flows from the onset to the end, l/min.
    pub after_onset_lpm: [f64; 2],
    /// When a present leak's true flow, averaged like the detection
    /// (`filter.detection_window_s`), first reached the alarm level at or
    /// after onset, s.
    pub flowing_s: Option<f64>,
    /// Start and end of the longest hold (≥ 5 s still), s.
    pub hold_s: Option<[f64; 2]>,
    /// First instant at or after 20 s at which the piston has been moving
    /// for 0.3 s, s.
    pub mid_move_s: Option<f64>,
}

/// What the monitor made of one run.
#[derive(Clone, Debug, Serialize)]
pub struct RunResult {
    /// The run.
    pub spec: RunSpec,
    /// The cell's calibration status (`calibrated`, `refused`, `off`).
    pub params: &'static str,
    /// Samples replayed.
    pub samples: u64,
    /// Final verdict (`Verdict::name()`).
    pub verdict: String,
    /// First alarm.
    pub first_alarm: Option<Alarm>,
    /// Every `AlarmRaised`.
    pub alarms: Vec<Alarm>,
    /// Sensor-fault events (first per channel).
    pub sensor_faults: Vec<Alarm>,
    /// Final reported internal / external leak flow (last estimate), l/min.
    pub est_lpm: [Option<f64>; 2],
    /// Mean over the run after warm-up of the leading hypothesis' windowed
    /// mean NIS.
    pub nis_leading_mean: Option<f64>,
    /// The leading hypothesis' mean NIS at the end.
    pub nis_leading_end: f64,
    /// Fraction of samples with evidence weight > 0.5.
    pub evidence_fraction: f64,
    /// Filter resets.
    pub filter_resets: u32,
    /// Data gaps.
    pub data_gaps: u32,
    /// Largest detection average before the onset (no leak: the whole
    /// run), internal / external, l/min: the false-alarm margin.
    pub peak_detect_lpm: [f64; 2],
    /// Samples per verdict while the fault is active (from 0.1 s after it
    /// starts; fault runs only).
    pub fault_verdicts: BTreeMap<String, u64>,
    /// First time the verdict was `sensor_fault` after the fault started, s.
    pub sensor_fault_verdict_s: Option<f64>,
    /// The alarm level the run was scored with, l/min.
    pub alarm_lpm: f64,
    /// Truth.
    pub truth: TruthSummary,
    /// From the cache (not simulated now).
    pub cached: bool,
    /// Wall time to simulate (or load) and replay, s.
    pub wall_s: f64,
}

impl RunResult {
    /// A result with nothing observed yet (verdict `healthy`, no alarm):
    /// the start of a replay, and hand-made results in tests.
    pub fn empty(spec: RunSpec, alarm_lpm: f64) -> Self {
        Self {
            spec,
            params: "",
            samples: 0,
            verdict: monitor::Verdict::Healthy.name().to_string(),
            first_alarm: None,
            alarms: Vec::new(),
            sensor_faults: Vec::new(),
            est_lpm: [None; 2],
            nis_leading_mean: None,
            nis_leading_end: f64::NAN,
            evidence_fraction: 0.0,
            filter_resets: 0,
            data_gaps: 0,
            peak_detect_lpm: [0.0; 2],
            fault_verdicts: BTreeMap::new(),
            sensor_fault_verdict_s: None,
            alarm_lpm,
            truth: TruthSummary::default(),
            cached: false,
            wall_s: 0.0,
        }
    }
}

/// The whole evaluation.
#[derive(Clone, Debug, Serialize)]
pub struct Evaluation {
    /// The matrix as planned.
    pub config: PlanConfig,
    /// Calibration status of the start parameters (`--no-calibration`).
    pub calibrate: bool,
    /// Worker threads.
    pub jobs: usize,
    /// Cells.
    pub cells: Vec<CellResult>,
    /// Runs, in plan order.
    pub runs: Vec<RunResult>,
    /// Wall time of the whole evaluation, s.
    pub wall_s: f64,
}

/// Progress of [`run_plan`]: units done (calibrations and runs) of total.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

// ---------------------------------------------------------------------------
// Recordings

/// The monitor's sample of a plant row (`None` stays an empty field, a NaN
/// time stays NaN).
pub fn row_sample(r: &plant::Row) -> Sample {
    let f = |v: Option<f64>| v.map(|v| v as f32);
    Sample {
        t_s: r.t,
        p_supply_bar: f(r.p_supply),
        p_piston_bar: f(r.p_piston),
        p_rod_bar: f(r.p_rod),
        p_tank_bar: f(r.p_tank),
        x_piston_m: f(r.x_piston),
        u_valve: f(r.u_valve),
        temp_oil_c: f(r.temp_oil),
    }
}

/// The recording text of `rows` (format of `recording-csv.md`, plus the
/// truth columns), with the run as metadata.
pub fn recording_text(run: &plant::Run, run_json: &str, rows: &[plant::Row]) -> Result<Vec<u8>> {
    let mut buf = Vec::with_capacity(rows.len() * 80 + 4096);
    let meta = [
        ("sample_rate_hz", format!("{}", run.sample_rate_hz)),
        (
            "source",
            format!("host-sim {} eval, plant", env!("CARGO_PKG_VERSION")),
        ),
        ("eval_run", run_json.to_string()),
    ];
    let mut w = RecordingWriter::new(&mut buf, &meta, run.temp_column, &TRUTH_COLUMNS)?;
    for r in rows {
        w.write(
            &row_sample(r),
            &[r.truth.internal_lpm, r.truth.external_lpm, r.truth.v_m_s],
        )?;
    }
    w.finish()?;
    Ok(buf)
}

/// A recording as this module wrote it, read leniently: a NaN time, a
/// repeated time and empty fields come through as they are.
pub struct TextReader<R: BufRead> {
    r: R,
    meta: Vec<(String, String)>,
    /// Column of t, the seven channels and the truth columns.
    cols: [Option<usize>; 11],
    line: String,
    line_no: u64,
}

impl<R: BufRead> TextReader<R> {
    /// Read the metadata and header.
    pub fn new(mut r: R) -> Result<Self> {
        let mut meta = Vec::new();
        let mut line = String::new();
        let mut line_no = 0;
        let header = loop {
            line.clear();
            if r.read_line(&mut line)? == 0 {
                anyhow::bail!("no header line");
            }
            line_no += 1;
            let text = line.trim_end();
            if let Some(rest) = text.strip_prefix('#') {
                if let Some((k, v)) = rest.trim_start().split_once('=') {
                    meta.push((k.to_string(), v.to_string()));
                }
                continue;
            }
            break text.to_string();
        };
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let wanted = [
            "t",
            "p_supply",
            "p_piston",
            "p_rod",
            "p_tank",
            "x_piston",
            "u_valve",
            "temp_oil",
            TRUTH_COLUMNS[0],
            TRUTH_COLUMNS[1],
            TRUTH_COLUMNS[2],
        ];
        let mut cols = [None; 11];
        for (c, w) in cols.iter_mut().zip(wanted) {
            *c = names.iter().position(|n| *n == w);
        }
        anyhow::ensure!(
            cols[..7].iter().all(Option::is_some),
            "header `{header}` lacks a required column"
        );
        Ok(Self {
            r,
            meta,
            cols,
            line,
            line_no,
        })
    }

    /// A metadata value.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.meta
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The next row: the sample and the truth (internal, external flow,
    /// velocity; 0 where absent).
    pub fn next_row(&mut self) -> Result<Option<(Sample, [f64; 3])>> {
        loop {
            self.line.clear();
            if self.r.read_line(&mut self.line)? == 0 {
                return Ok(None);
            }
            self.line_no += 1;
            if !self.line.trim().is_empty() {
                break;
            }
        }
        let mut fields = [""; 16];
        let mut n = 0;
        for f in self.line.trim_end().split(',') {
            anyhow::ensure!(n < fields.len(), "line {}: too many fields", self.line_no);
            fields[n] = f;
            n += 1;
        }
        let line_no = self.line_no;
        let get = |c: Option<usize>| -> Result<Option<f64>> {
            match c {
                Some(i) if i < n && !fields[i].is_empty() => fields[i]
                    .parse::<f64>()
                    .map(Some)
                    .with_context(|| format!("line {line_no}: `{}`", fields[i])),
                Some(i) if i >= n => anyhow::bail!("line {line_no}: too few fields"),
                _ => Ok(None),
            }
        };
        let c = self.cols;
        let ch = |i: usize| -> Result<Option<f32>> { Ok(get(c[i])?.map(|v| v as f32)) };
        let sample = Sample {
            t_s: get(c[0])?.unwrap_or(f64::NAN),
            p_supply_bar: ch(1)?,
            p_piston_bar: ch(2)?,
            p_rod_bar: ch(3)?,
            p_tank_bar: ch(4)?,
            x_piston_m: ch(5)?,
            u_valve: ch(6)?,
            temp_oil_c: ch(7)?,
        };
        let truth = [
            get(c[8])?.unwrap_or(0.0),
            get(c[9])?.unwrap_or(0.0),
            get(c[10])?.unwrap_or(0.0),
        ];
        Ok(Some((sample, truth)))
    }
}

/// The cache key of a run: its plant `Run` as JSON (which holds the whole
/// drawn rig, so a change of the rig draws is a new key).
pub fn cache_key(run_json: &str) -> u64 {
    fnv1a64(format!("eval-cache/{CACHE_VERSION}\n{run_json}").as_bytes())
}

/// Where a run's recording is cached.
pub fn cache_path(dir: &Path, run_json: &str) -> PathBuf {
    dir.join(format!("run-{:016x}.csv.gz", cache_key(run_json)))
}

fn read_cached(path: &Path, run_json: &str) -> Result<Option<Vec<u8>>> {
    let f = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("{}", path.display())),
    };
    let mut text = Vec::new();
    flate2::read::MultiGzDecoder::new(std::io::BufReader::new(f))
        .read_to_end(&mut text)
        .with_context(|| format!("{}: delete it to simulate again", path.display()))?;
    let r = TextReader::new(&text[..])
        .with_context(|| format!("{}: delete it to simulate again", path.display()))?;
    // A different run under the same key (or another plant version's file).
    if r.meta("eval_run") != Some(run_json) {
        return Ok(None);
    }
    Ok(Some(text))
}

fn write_cached(path: &Path, text: &[u8]) -> Result<()> {
    // Written under a temporary name and renamed: an interrupted run never
    // leaves a truncated recording.
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(
        ".{name}.{}.part",
        std::process::id() as u64 * 1000 + thread_tag()
    ));
    let f = std::fs::File::create(&tmp).with_context(|| format!("{}", tmp.display()))?;
    // The fastest level: the default one costs about 0.2 s per minute of
    // recording (a quarter of the plant's time) for files ~40 % smaller.
    let mut gz =
        flate2::write::GzEncoder::new(std::io::BufWriter::new(f), flate2::Compression::fast());
    gz.write_all(text)?;
    gz.finish()?.flush()?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}", path.display()))?;
    Ok(())
}

fn thread_tag() -> u64 {
    fnv1a64(format!("{:?}", std::thread::current().id()).as_bytes()) % 1000
}

/// The recording text of `spec`: from the cache, or simulated on the plant
/// (and cached). Second: whether it came from the cache.
pub fn recording_for(spec: &RunSpec, cache: Option<&Path>) -> Result<(Vec<u8>, bool)> {
    let run = spec.run();
    let json = serde_json::to_string(&run)?;
    let path = cache.map(|d| cache_path(d, &json));
    if let Some(p) = &path {
        if let Some(text) = read_cached(p, &json)? {
            return Ok((text, true));
        }
    }
    let rows = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| plant::simulate(&run)))
        .map_err(|e| {
            let msg = e
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| e.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            anyhow::anyhow!("the plant panicked: {msg}")
        })
        .with_context(|| format!("simulating {}", spec.id))?;
    anyhow::ensure!(!rows.is_empty(), "{}: the plant gave no rows", spec.id);
    let text = recording_text(&run, &json, &rows)?;
    drop(rows);
    if let Some(p) = &path {
        write_cached(p, &text)?;
    }
    Ok((text, false))
}

/// Every sample of a recording text.
pub fn samples_of(text: &[u8]) -> Result<Vec<Sample>> {
    let mut r = TextReader::new(text)?;
    let mut v = Vec::new();
    while let Some((s, _)) = r.next_row()? {
        v.push(s);
    }
    Ok(v)
}

/// `params` at the run's sample rate (the period `replay` derives from the
/// recording's `sample_rate_hz`).
fn at_rate(params: &Params, rate_hz: f64) -> Params {
    let mut p = params.clone();
    if rate_hz.is_finite() && rate_hz > 0.0 {
        p.filter.sample_period_s = 1.0 / rate_hz;
    }
    p
}

// ---------------------------------------------------------------------------
// Calibration

/// Calibrate a cell from its healthy recording.
pub fn calibrate_cell(cp: &CellPlan, cfg: &ExecConfig) -> Result<CellResult> {
    let start_time = Instant::now();
    let start = at_rate(&cfg.start, cp.calibration.sample_rate_hz);
    let rig = cp.cell.rig_spec();
    let mut out = CalibrationOutcome {
        status: "off",
        refused: None,
        report: None,
        fits: Vec::new(),
        warnings: Vec::new(),
        nis_before: None,
        nis_after: None,
        leak_before_lpm: None,
        leak_after_lpm: None,
        wall_s: 0.0,
        params: start.clone(),
    };
    if cfg.calibrate {
        let (text, _) = recording_for(&cp.calibration, cfg.cache.as_deref())?;
        let samples = samples_of(&text)?;
        drop(text);
        match calibrate(&samples, &start) {
            Ok(c) => {
                out.status = "calibrated";
                out.report = Some(c.report());
                out.nis_before = Some(c.nis_before);
                out.nis_after = Some(c.nis_after);
                out.leak_before_lpm = Some(c.leak_before_lpm);
                out.leak_after_lpm = Some(c.leak_after_lpm);
                out.fits = c.fits;
                out.warnings = c.warnings;
                out.params = c.params;
            }
            Err(e) => {
                out.status = "refused";
                out.refused = Some(e.to_string());
            }
        }
    }
    out.wall_s = start_time.elapsed().as_secs_f64();
    Ok(CellResult {
        cell: cp.cell.clone(),
        rig,
        calibration_run: cp.calibration.clone(),
        calibration: out,
    })
}

// ---------------------------------------------------------------------------
// Replay

/// Run the monitor over a run's recording text and summarise.
pub fn replay_text(spec: &RunSpec, text: &[u8], params: &Params) -> Result<RunResult> {
    let params = at_rate(params, spec.sample_rate_hz);
    let mut monitor: Monitor<f32> =
        Monitor::new(&params).map_err(|e| anyhow::anyhow!("parameters: {e}"))?;
    let mut r = TextReader::new(text)?;
    let period = params.filter.sample_period_s;
    let onset = if spec.has_leak() {
        spec.leak.onset_s
    } else {
        f64::INFINITY
    };
    let window = fault_window(&spec.faults).filter(|_| spec.category == Category::Fault);
    let warm_up = params.filter.warm_up_s;
    let mut res = RunResult::empty(spec.clone(), params.alarm.alarm_lpm);
    let mut t_true: Vec<f64> = Vec::new();
    let mut q: Vec<[f32; 3]> = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    let (mut nis_sum, mut nis_n) = (0.0f64, 0u64);
    let mut evidence = 0u64;
    let mut verdict = "";
    while let Some((sample, truth)) = r.next_row()? {
        // True time: the recorded one while it advances, else one period on.
        let t = if sample.t_s.is_finite() && sample.t_s > last_t {
            sample.t_s
        } else if last_t.is_finite() {
            last_t + period
        } else {
            0.0
        };
        last_t = t;
        t_true.push(t);
        q.push([truth[0] as f32, truth[1] as f32, truth[2] as f32]);
        let s = monitor.step(&sample);
        res.samples += 1;
        verdict = s.verdict.name();
        let lead = s.evidence[s.leading as usize].mean_nis as f64;
        res.nis_leading_end = lead;
        if t >= warm_up && lead.is_finite() {
            nis_sum += lead;
            nis_n += 1;
        }
        if s.evidence_weight > 0.5 {
            evidence += 1;
        }
        if let (Some(i), Some(e)) = (s.leak_internal_lpm, s.leak_external_lpm) {
            res.est_lpm = [Some(i as f64), Some(e as f64)];
        }
        if t < onset {
            if let (Some(i), Some(e)) = (s.detect_internal_lpm, s.detect_external_lpm) {
                res.peak_detect_lpm[0] = res.peak_detect_lpm[0].max(i as f64);
                res.peak_detect_lpm[1] = res.peak_detect_lpm[1].max(e as f64);
            }
        }
        if let Some((from, to)) = window {
            if t >= from + FAULT_GRACE_S && to.is_none_or(|to| t < to) {
                *res.fault_verdicts.entry(verdict.to_string()).or_insert(0) += 1;
            }
            if t >= from
                && res.sensor_fault_verdict_s.is_none()
                && s.verdict == monitor::Verdict::SensorFault
            {
                res.sensor_fault_verdict_s = Some(t);
            }
        }
        for e in &s.events {
            match *e {
                Event::AlarmRaised(v) => {
                    let a = Alarm {
                        t_s: t,
                        what: v.name().to_string(),
                    };
                    if res.first_alarm.is_none() {
                        res.first_alarm = Some(a.clone());
                    }
                    res.alarms.push(a);
                }
                Event::FilterReset(_) => res.filter_resets += 1,
                Event::DataGap => res.data_gaps += 1,
                Event::SensorFault(c) => {
                    if !res.sensor_faults.iter().any(|a| a.what == c.name()) {
                        res.sensor_faults.push(Alarm {
                            t_s: t,
                            what: c.name().to_string(),
                        });
                    }
                }
                Event::AlarmCleared | Event::SensorRecovered(_) => {}
            }
        }
    }
    anyhow::ensure!(res.samples > 0, "{}: no samples", spec.id);
    res.verdict = verdict.to_string();
    res.nis_leading_mean = (nis_n > 0).then(|| nis_sum / nis_n as f64);
    res.evidence_fraction = evidence as f64 / res.samples as f64;
    res.truth = truth_summary(spec, &t_true, &q, &params);
    Ok(res)
}

fn mean_where(t: &[f64], q: &[[f32; 3]], keep: impl Fn(f64) -> bool) -> [f64; 2] {
    let (mut s, mut n) = ([0.0f64; 2], 0u64);
    for (t, q) in t.iter().zip(q) {
        if keep(*t) {
            s[0] += q[0] as f64;
            s[1] += q[1] as f64;
            n += 1;
        }
    }
    if n == 0 {
        return [0.0; 2];
    }
    [s[0] / n as f64, s[1] / n as f64]
}

/// The truth of a run from its per-sample true time, flows and velocity.
pub fn truth_summary(spec: &RunSpec, t: &[f64], q: &[[f32; 3]], params: &Params) -> TruthSummary {
    let (Some(&t0), Some(&t_end)) = (t.first(), t.last()) else {
        return TruthSummary::default();
    };
    let onset = spec.leak.onset_s;
    let present = [spec.internal(), spec.external()];
    let mut flowing_s = None;
    let mut short = [0.0f64; 2];
    let mut speed = 0.0f64;
    let (mut still_from, mut best_hold): (Option<f64>, Option<(f64, f64)>) = (None, None);
    let mut moving_from: Option<f64> = None;
    let mut mid_move_s = None;
    let mut last = t0;
    for (&ti, qi) in t.iter().zip(q) {
        let dt = (ti - last).max(0.0);
        last = ti;
        let a = (dt / params.filter.detection_window_s).min(1.0);
        for k in 0..2 {
            short[k] += a * ((qi[k] as f64).abs() - short[k]);
            if flowing_s.is_none()
                && present[k]
                && ti >= onset
                && short[k] >= params.alarm.alarm_lpm
            {
                flowing_s = Some(ti);
            }
        }
        speed += (dt / 0.1).min(1.0) * ((qi[2] as f64).abs() - speed);
        if speed < HOLD_SPEED {
            let from = *still_from.get_or_insert(ti);
            if ti - from >= MIN_HOLD_S && best_hold.is_none_or(|(a, b)| ti - from > b - a) {
                best_hold = Some((from, ti));
            }
        } else {
            still_from = None;
        }
        if speed > MOVE_SPEED {
            let from = *moving_from.get_or_insert(ti);
            if mid_move_s.is_none() && ti >= FAULT_AT_S && ti - from >= MID_MOVE_S {
                mid_move_s = Some(ti);
            }
        } else {
            moving_from = None;
        }
    }
    TruthSummary {
        duration_s: t_end - t0,
        last_lpm: mean_where(t, q, |ti| ti >= t_end - SIZE_SPAN_S),
        after_onset_lpm: mean_where(t, q, |ti| ti >= onset),
        flowing_s,
        hold_s: best_hold.map(|(a, b)| [a, b]),
        mid_move_s,
    }
}

/// Place a follower's time from its twin's truth.
pub fn place(f: &Follower, twin: &TruthSummary) -> RunSpec {
    let mut s = f.spec.clone();
    match f.placement {
        Placement::OnsetAfterHold { hold_s, fallback_s } => {
            let (t, how) = match twin.hold_s {
                Some([a, b]) => (
                    a + hold_s,
                    format!(
                        "onset {hold_s} s after the twin's hold began ({a:.2} s; still until {b:.2} s)"
                    ),
                ),
                None => (
                    fallback_s,
                    format!("no hold in the twin: onset at {fallback_s} s"),
                ),
            };
            s.leak.onset_s = t;
            s.placed = Some(how);
        }
        Placement::FaultMidMove { after_s } => {
            let (t, how) = match twin.mid_move_s {
                Some(t) => (t, format!("fault at {t:.3} s, mid-move in the twin")),
                None => (
                    after_s,
                    format!("no move in the twin: fault at {after_s} s"),
                ),
            };
            for fault in &mut s.faults {
                match fault {
                    plant::Fault::Spikes { at_s, .. }
                    | plant::Fault::OpenWire { at_s, .. }
                    | plant::Fault::Frozen { at_s, .. }
                    | plant::Fault::StuckTime { at_s, .. }
                    | plant::Fault::NanTime { at_s, .. } => *at_s = t,
                    plant::Fault::RandomNoise => {}
                }
            }
            s.placed = Some(how);
        }
    }
    s
}

/// Simulate (or load) and replay one run.
pub fn execute(spec: &RunSpec, cell: &CellResult, cache: Option<&Path>) -> Result<RunResult> {
    let start = Instant::now();
    let (text, cached) = recording_for(spec, cache)?;
    let mut r = replay_text(spec, &text, &cell.calibration.params)
        .with_context(|| format!("replaying {}", spec.id))?;
    r.params = cell.calibration.status;
    r.cached = cached;
    r.wall_s = start.elapsed().as_secs_f64();
    Ok(r)
}

fn execute_job(
    job: &Job,
    cell: &CellResult,
    cache: Option<&Path>,
    done: &dyn Fn(),
) -> Result<Vec<RunResult>> {
    let head = execute(&job.head, cell, cache)?;
    done();
    let mut out = Vec::with_capacity(1 + job.followers.len());
    for f in &job.followers {
        let spec = place(f, &head.truth);
        out.push(execute(&spec, cell, cache)?);
        done();
    }
    out.insert(0, head);
    Ok(out)
}

/// Map `f` over `items` on `jobs` threads, in order of `order`; results in
/// item order. Stops handing out work after the first error.
fn parallel<T: Sync, R: Send>(
    items: &[T],
    order: &[usize],
    jobs: usize,
    f: &(dyn Fn(&T) -> Result<R> + Sync),
) -> Result<Vec<R>> {
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<R>>> = Mutex::new((0..items.len()).map(|_| None).collect());
    let error: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..jobs.clamp(1, items.len().max(1)) {
            s.spawn(|| loop {
                if failed.load(Ordering::Relaxed) {
                    break;
                }
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&i) = order.get(k) else { break };
                match f(&items[i]) {
                    Ok(r) => results.lock().expect("no panic holding the lock")[i] = Some(r),
                    Err(e) => {
                        failed.store(true, Ordering::Relaxed);
                        error
                            .lock()
                            .expect("no panic holding the lock")
                            .get_or_insert(e);
                    }
                }
            });
        }
    });
    if let Some(e) = error.into_inner().expect("threads joined") {
        return Err(e);
    }
    Ok(results
        .into_inner()
        .expect("threads joined")
        .into_iter()
        .map(|r| r.expect("every item ran"))
        .collect())
}

/// Execute `plan`: calibrate every cell, then every job (longest first) on
/// `cfg.jobs` threads. `progress(done, total)` counts calibrations and runs.
pub fn run_plan(plan: &Plan, cfg: &ExecConfig, progress: Progress) -> Result<Evaluation> {
    let start = Instant::now();
    if let Some(dir) = &cfg.cache {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    }
    let total = plan.cells.len() + plan.runs();
    let done = AtomicUsize::new(0);
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
    let cell_order: Vec<usize> = (0..plan.cells.len()).collect();
    let cells = parallel(&plan.cells, &cell_order, cfg.jobs, &|cp| {
        let r = calibrate_cell(cp, cfg).with_context(|| format!("calibrating {}", cp.cell.id()));
        tick();
        r
    })?;
    let cell_index = |c: &Cell| {
        plan.cells
            .iter()
            .position(|p| p.cell == *c)
            .expect("every run's cell is planned")
    };
    // Longest jobs first: the long holds do not end up alone at the end.
    let mut order: Vec<usize> = (0..plan.jobs.len()).collect();
    order.sort_by(|&a, &b| plan.jobs[b].cost().total_cmp(&plan.jobs[a].cost()));
    let results = parallel(&plan.jobs, &order, cfg.jobs, &|job| {
        let cell = &cells[cell_index(&job.head.cell)];
        execute_job(job, cell, cfg.cache.as_deref(), &tick)
    })?;
    Ok(Evaluation {
        config: plan.config.clone(),
        calibrate: cfg.calibrate,
        jobs: cfg.jobs,
        cells,
        runs: results.into_iter().flatten().collect(),
        wall_s: start.elapsed().as_secs_f64(),
    })
}
