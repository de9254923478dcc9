//! Running the matrix: simulate each run on the plant (or take it from the
//! cache), calibrate each cell from its own healthy recording, replay every
//! run through the monitor and summarise what it did and what was true.

use super::plan::{CellPlan, Plan, PlanConfig};
use super::{Cell, Job, RunSpec};
use crate::calibrate::{calibrate_given, oscillation, Fit};
use anyhow::{Context, Result};
use monitor::Params;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

mod recording;
mod replay;

pub use recording::{
    cache_key, cache_path, recording_for, recording_reusing, recording_text, row_sample,
    samples_of, TextReader,
};
pub use replay::{place, replay_text, truth_summary};

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
/// The span of [`TruthSummary::last_lpm`], s.
pub const SIZE_SPAN_S: f64 = 4.0;

/// How to execute a plan.
#[derive(Clone, Debug)]
pub struct ExecConfig {
    /// Parameters to calibrate from (and to use where calibration is off;
    /// where it is refused, as a provisional set): the reference rig's
    /// unless given.
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
    /// `calibrated`, `refused` (the cell runs with the start parameters as
    /// a provisional set, as a user would without a calibrated file) or
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
    /// Share of the calibration recording in which the position loop
    /// oscillates (`calibrate::oscillation`), whatever the calibration's
    /// outcome; `None` where it cannot be measured or calibration is off.
    pub loop_oscillation_share: Option<f64>,
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
    /// Mean true internal / external flow over the last 4 s, l/min, in the
    /// run JSON for comparison (the size error uses `size_lpm`).
    pub last_lpm: [f64; 2],
    /// The true flows at the end averaged as the monitor averages the
    /// size it reports (exponentially over `filter.evidence_window_s`),
    /// l/min: what the size error compares against.
    pub size_lpm: [f64; 2],
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
    /// Fraction of samples quasi-steady enough to count as evidence
    /// (`Status::quasi_steady`).
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
        loop_oscillation_share: None,
        wall_s: 0.0,
        params: start.clone(),
    };
    if cfg.calibrate {
        let (text, _) = recording_for(&cp.calibration, cfg.cache.as_deref())?;
        let samples = samples_of(&text)?;
        drop(text);
        let loop_oscillation = oscillation::measure(&samples);
        out.loop_oscillation_share = loop_oscillation.as_ref().map(|o| o.share);
        match calibrate_given(&samples, &start, loop_oscillation.as_ref()) {
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
                out.params = out.params.into_provisional();
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

/// Simulate (or load) and replay one run; `motion` as in
/// [`recording_reusing`].
fn execute(
    spec: &RunSpec,
    cell: &CellResult,
    cache: Option<&Path>,
    motion: &mut Option<plant::Motion>,
) -> Result<RunResult> {
    let start = Instant::now();
    let (text, cached) = recording_reusing(spec, cache, motion)?;
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
    // The followers of a healthy run are its faults, on its plant: its
    // motion serves them all.
    let mut motion = None;
    let head = execute(&job.head, cell, cache, &mut motion)?;
    done();
    let mut out = Vec::with_capacity(1 + job.followers.len());
    for f in &job.followers {
        let spec = place(f, &head.truth);
        out.push(execute(&spec, cell, cache, &mut motion)?);
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
