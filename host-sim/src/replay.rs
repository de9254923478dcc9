//! `host-sim replay`: the monitor over a recording, sample by sample,
//! exactly as the device would see it.

use crate::calibrate::oscillation;
use crate::recording::{RecordingError, RecordingReader};
use monitor::{Event, Monitor, Params, Real, Sample, Status, Verdict};
use serde::Serialize;
use std::io::{BufRead, Write};

/// One entry of the replay's event list (JSON contract: `host-sim-cli.md`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EventRecord {
    /// Sample time, s.
    pub t: f64,
    /// `alarm`, `alarm_cleared`, `sensor_fault`, `sensor_recovered`,
    /// `data_gap` or `filter_reset`.
    pub kind: &'static str,
    /// The verdict of an `alarm`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<&'static str>,
    /// The channel of a sensor event.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<&'static str>,
    /// The hypothesis of a `filter_reset`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hypothesis: Option<&'static str>,
}

impl EventRecord {
    fn new(t: f64, e: &Event) -> Self {
        let mut r = Self {
            t,
            kind: "",
            verdict: None,
            sensor: None,
            hypothesis: None,
        };
        match *e {
            Event::AlarmRaised(v) => {
                r.kind = "alarm";
                r.verdict = Some(v.name());
            }
            Event::AlarmCleared => r.kind = "alarm_cleared",
            Event::SensorFault(c) => {
                r.kind = "sensor_fault";
                r.sensor = Some(c.name());
            }
            Event::SensorRecovered(c) => {
                r.kind = "sensor_recovered";
                r.sensor = Some(c.name());
            }
            Event::DataGap => r.kind = "data_gap",
            Event::FilterReset(h) => {
                r.kind = "filter_reset";
                r.hypothesis = Some(h.name());
            }
        }
        r
    }
}

/// The replay result. Field names are a public contract: add, never rename.
#[derive(Clone, Debug, Serialize)]
pub struct ReplaySummary {
    /// The recording's path as given.
    pub recording: String,
    /// Samples processed.
    pub samples: u64,
    /// Last minus first sample time, s.
    pub duration_s: f64,
    /// Verdict at the end of the recording.
    pub verdict: &'static str,
    /// Time of the first leak alarm, s.
    pub first_alarm_s: Option<f64>,
    /// Internal leak flow estimate at the end, l/min (mean over the last
    /// seconds of estimation).
    pub leak_internal_lpm: Option<f64>,
    /// External leak flow estimate at the end, l/min.
    pub leak_external_lpm: Option<f64>,
    /// Alarm, sensor and filter events in time order.
    pub events: Vec<EventRecord>,
    /// 1σ of the internal leak estimate, l/min.
    pub leak_internal_sd_lpm: Option<f64>,
    /// 1σ of the external leak estimate, l/min.
    pub leak_external_sd_lpm: Option<f64>,
    /// The best-supported hypothesis at the end (before debounce/latching).
    pub leading: &'static str,
    /// Posterior probabilities at the end: healthy, internal, external, both.
    pub probabilities: [f64; 4],
    /// Fraction of samples flagged as model mismatch.
    pub model_mismatch_fraction: f64,
    /// Fraction of samples whose verdict was `inconclusive`.
    pub inconclusive_fraction: f64,
    /// Samples with a reading rejected as an outlier (spike, or a valve
    /// command the motion contradicts).
    pub outlier_samples: u64,
    /// White-noise σ of the readings at the end, as estimated from the
    /// data: position (m), piston and rod chamber pressure (bar).
    pub noise: NoiseSummary,
    /// Mean NIS of the leading hypothesis over the samples after the
    /// warm-up (≈ 3 when the filters are consistent with the data).
    pub mean_nis: Option<f64>,
    /// Events after the first [`MAX_EVENTS`] (alarms: after twice that),
    /// counted but not kept in
    /// `events` (a recording of endless gaps or faults stays bounded).
    pub events_dropped: u64,
    /// The parameters were provisional (not calibrated for the
    /// installation: `replay` without `--params`): the gross leak level
    /// above which alone leaks alarm, l/min; the verdict is never
    /// `healthy`. `null`: the parameters describe the installation.
    pub provisional_floor_lpm: Option<f64>,
    /// Alarm level in use for the internal leak at the end, l/min: the
    /// level a leak flow estimate (after the healthy baseline) had to
    /// exceed to raise an alarm there, the user's level raised to the
    /// installation's floor in the operating region
    /// (`Status::alarm_level_lpm`): what a `healthy` verdict is measured
    /// against. Taken with the leak estimates (`null` where they are).
    pub alarm_level_internal_lpm: Option<f64>,
    /// Alarm level in use for the external leak at the end, l/min.
    pub alarm_level_external_lpm: Option<f64>,
    /// Share of the recording in which the machine's position loop
    /// oscillates (`calibrate::oscillation`: a chamber pressure swinging
    /// ≥ 10 % of the supply with the valve command, in 0.2 s windows); no
    /// sample there is leak evidence. `null` without supply, chamber
    /// pressures and command in a single window.
    pub loop_oscillation_share: Option<f64>,
    /// Frequency of that oscillation, Hz (`null` where the share is, or
    /// none oscillates).
    pub loop_oscillation_hz: Option<f64>,
    /// Fraction of samples at which the monitor itself said the loop hunts
    /// (`health::LOOP_OSCILLATING`: most of its last 2 s oscillated), as the
    /// device reports it over CAN.
    pub loop_hunting_fraction: f64,
    /// Fraction of samples the monitor counted as no evidence because its
    /// valve flow gains stood beyond what the valve model describes
    /// (`health::VALVE_MISFIT`), as the device reports it over CAN.
    pub valve_misfit_fraction: f64,
    /// Fraction of samples at which the loop had held the piston with a
    /// valve command away from the leak-free installation's
    /// (`health::HOLD_COMMAND_SHIFTED`): `healthy` withheld there, as the
    /// device reports it over CAN. 0 when the parameter set has no
    /// holding command (`baseline.hold_command_tolerance` 0).
    pub hold_command_shifted_fraction: f64,
}

/// Most events a replay keeps in its summary.
pub const MAX_EVENTS: usize = 10_000;

/// Noise levels in the replay JSON.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct NoiseSummary {
    /// Position reading, m.
    pub x_piston_m: f64,
    /// Piston chamber pressure, bar.
    pub p_piston_bar: f64,
    /// Rod chamber pressure, bar.
    pub p_rod_bar: f64,
}

/// Why a replay stopped.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The recording is malformed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The parameters are invalid.
    #[error("{0}")]
    Params(monitor::params::ParamError),
    /// Writing the trace failed.
    #[error("writing the trace: {0}")]
    Trace(std::io::Error),
}

/// Per-sample hook (traces, tests).
pub trait Observer {
    /// Called after every sample.
    fn observe(&mut self, sample: &Sample, status: &Status) -> std::io::Result<()>;
}

impl Observer for () {
    fn observe(&mut self, _: &Sample, _: &Status) -> std::io::Result<()> {
        Ok(())
    }
}

/// A CSV trace of every `every`-th status.
pub struct TraceWriter<W: Write> {
    w: W,
    every: u64,
    n: u64,
}

impl<W: Write> TraceWriter<W> {
    /// Start a trace.
    pub fn new(mut w: W, every: u64) -> std::io::Result<Self> {
        writeln!(
            w,
            "t,verdict,leading,p_healthy,p_internal,p_external,p_both,nis_healthy,nis_internal,nis_external,nis_both,leak_internal_lpm,leak_external_lpm,detect_internal_lpm,detect_external_lpm,gain_extend,gain_retract,evidence_weight,health"
        )?;
        Ok(Self {
            w,
            every: every.max(1),
            n: 0,
        })
    }
}

impl<W: Write> Observer for TraceWriter<W> {
    fn observe(&mut self, _: &Sample, s: &Status) -> std::io::Result<()> {
        self.n += 1;
        if !self.n.is_multiple_of(self.every) {
            return Ok(());
        }
        let e = &s.evidence;
        writeln!(
            self.w,
            "{:.4},{},{},{:.4},{:.4},{:.4},{:.4},{:.2},{:.2},{:.2},{:.2},{},{},{},{},{:.4},{:.4},{:.3},{}",
            s.t_s,
            s.verdict.name(),
            s.leading.name(),
            e[0].probability,
            e[1].probability,
            e[2].probability,
            e[3].probability,
            e[0].mean_nis,
            e[1].mean_nis,
            e[2].mean_nis,
            e[3].mean_nis,
            s.leak_internal_lpm.map_or(String::new(), |v| format!("{v:.4}")),
            s.leak_external_lpm.map_or(String::new(), |v| format!("{v:.4}")),
            s.detect_internal_lpm.map_or(String::new(), |v| format!("{v:.4}")),
            s.detect_external_lpm.map_or(String::new(), |v| format!("{v:.4}")),
            s.valve_gain_deviation[0],
            s.valve_gain_deviation[1],
            s.evidence_weight,
            s.health
        )
    }
}

/// The nominal sample period: metadata `sample_rate_hz` if present, else
/// the first time step (so gap detection works at any rate). Every command
/// that runs the monitor over a recording derives it here.
pub fn sample_period(
    meta_rate: Option<&str>,
    first: &Sample,
    second: Option<&Sample>,
) -> Option<f64> {
    if let Some(rate) = meta_rate.and_then(|r| r.trim().parse::<f64>().ok()) {
        if rate.is_finite() && rate > 0.0 {
            return Some(1.0 / rate);
        }
    }
    second.map(|s| s.t_s - first.t_s).filter(|d| *d > 0.0)
}

/// Replay `reader` through a monitor of scalar `T` with `params`.
pub fn replay<T: Real, R: BufRead>(
    mut reader: RecordingReader<R>,
    name: &str,
    params: &Params,
    observer: &mut dyn Observer,
) -> Result<ReplaySummary, ReplayError> {
    let mut params = params.clone();
    let first = reader.next().transpose()?;
    let second = reader.next().transpose()?;
    if let Some(f) = &first {
        if let Some(p) = sample_period(reader.meta("sample_rate_hz"), f, second.as_ref()) {
            params.filter.sample_period_s = p;
        }
    }
    let mut monitor: Monitor<T> = Monitor::new(&params).map_err(ReplayError::Params)?;
    let mut summary = ReplaySummary {
        recording: name.to_string(),
        samples: 0,
        duration_s: 0.0,
        // No sample is no evidence.
        verdict: Verdict::Inconclusive.name(),
        first_alarm_s: None,
        leak_internal_lpm: None,
        leak_external_lpm: None,
        events: Vec::new(),
        leak_internal_sd_lpm: None,
        leak_external_sd_lpm: None,
        leading: "healthy",
        probabilities: [0.25; 4],
        model_mismatch_fraction: 0.0,
        inconclusive_fraction: 0.0,
        outlier_samples: 0,
        noise: NoiseSummary::default(),
        mean_nis: None,
        events_dropped: 0,
        provisional_floor_lpm: params
            .is_provisional()
            .then_some(params.baseline.provisional_floor_lpm),
        alarm_level_internal_lpm: None,
        alarm_level_external_lpm: None,
        loop_oscillation_share: None,
        loop_oscillation_hz: None,
        loop_hunting_fraction: 0.0,
        valve_misfit_fraction: 0.0,
        hold_command_shifted_fraction: 0.0,
    };
    let mut loop_meter = oscillation::Meter::default();
    let (mut inconclusive, mut nis_sum, mut nis_n) = (0u64, 0.0, 0u64);
    let t0 = first.as_ref().map(|s| s.t_s);
    let (mut mismatch, mut hunting, mut misfit, mut shifted) = (0u64, 0u64, 0u64, 0u64);
    let head = first.into_iter().chain(second).map(Ok);
    for sample in head.chain(reader) {
        let sample = sample?;
        loop_meter.push(&sample);
        let status = monitor.step(&sample);
        observer
            .observe(&sample, &status)
            .map_err(ReplayError::Trace)?;
        summary.samples += 1;
        summary.duration_s = sample.t_s - t0.unwrap_or(sample.t_s);
        summary.verdict = status.verdict.name();
        summary.leading = status.leading.name();
        summary.probabilities = status.evidence.map(|e| round4(e.probability as f64));
        if status.health & monitor::status::health::MODEL_MISMATCH != 0 {
            mismatch += 1;
        }
        if status.verdict == Verdict::Inconclusive {
            inconclusive += 1;
        }
        if status.health & monitor::status::health::LOOP_OSCILLATING != 0 {
            hunting += 1;
        }
        if status.valve_model_misfit() {
            misfit += 1;
        }
        if status.hold_command_shifted() {
            shifted += 1;
        }
        if status.health & monitor::status::health::OUTLIER != 0 {
            summary.outlier_samples += 1;
        }
        if status.leak_internal_lpm.is_some() {
            nis_sum += status.evidence[status.leading as usize].mean_nis as f64;
            nis_n += 1;
        }
        let [nx, n3, n4] = status.noise_sigma.map(|v| v as f64);
        summary.noise = NoiseSummary {
            x_piston_m: (nx * 1e7).round() / 1e7,
            p_piston_bar: round4(n3),
            p_rod_bar: round4(n4),
        };
        if let (Some(i), Some(e)) = (status.leak_internal_lpm, status.leak_external_lpm) {
            summary.leak_internal_lpm = Some(round4(i as f64));
            summary.leak_external_lpm = Some(round4(e as f64));
            summary.leak_internal_sd_lpm = status.leak_internal_sd_lpm.map(|v| round4(v as f64));
            summary.leak_external_sd_lpm = status.leak_external_sd_lpm.map(|v| round4(v as f64));
            let [li, le] = status.published_alarm_levels();
            summary.alarm_level_internal_lpm = li.map(|v| round4(v as f64));
            summary.alarm_level_external_lpm = le.map(|v| round4(v as f64));
        }
        for e in &status.events {
            if matches!(e, Event::AlarmRaised(_)) && summary.first_alarm_s.is_none() {
                summary.first_alarm_s = Some(sample.t_s);
            }
            // Alarms are kept past the cap (the contract lists every
            // alarm); they latch, so there are few, and a second cap still
            // bounds the list.
            let alarm = matches!(e, Event::AlarmRaised(_) | Event::AlarmCleared);
            let room = if alarm { 2 * MAX_EVENTS } else { MAX_EVENTS };
            if summary.events.len() < room {
                summary.events.push(EventRecord::new(sample.t_s, e));
            } else {
                summary.events_dropped += 1;
            }
        }
    }
    let samples = summary.samples.max(1) as f64;
    let fraction = |count: u64| count as f64 / samples;
    summary.model_mismatch_fraction = fraction(mismatch);
    summary.inconclusive_fraction = round4(fraction(inconclusive));
    summary.loop_hunting_fraction = round4(fraction(hunting));
    summary.valve_misfit_fraction = round4(fraction(misfit));
    summary.hold_command_shifted_fraction = round4(fraction(shifted));
    summary.mean_nis = (nis_n > 0).then(|| round4(nis_sum / nis_n as f64));
    if let Some(o) = loop_meter.finish() {
        summary.loop_oscillation_share = Some(round4(o.share));
        summary.loop_oscillation_hz =
            (o.frequency_hz > 0.0).then(|| (o.frequency_hz * 10.0).round() / 10.0);
    }
    Ok(summary)
}

fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Human-readable summary.
pub fn print_summary(s: &ReplaySummary, out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(out, "recording   {}", s.recording)?;
    writeln!(out, "samples     {} over {:.3} s", s.samples, s.duration_s)?;
    writeln!(out, "verdict     {}", s.verdict.to_uppercase())?;
    match s.first_alarm_s {
        Some(t) => writeln!(out, "first alarm at t = {t:.3} s")?,
        None => writeln!(out, "no leak alarm")?,
    }
    let fmt = |v: Option<f64>, sd: Option<f64>| match (v, sd) {
        (Some(v), Some(sd)) => format!("{v:.3} l/min (±{sd:.3})"),
        (Some(v), None) => format!("{v:.3} l/min"),
        _ => "n/a".to_string(),
    };
    writeln!(
        out,
        "leak size   internal {}, external {}",
        fmt(s.leak_internal_lpm, s.leak_internal_sd_lpm),
        fmt(s.leak_external_lpm, s.leak_external_sd_lpm)
    )?;
    writeln!(
        out,
        "alarm level internal {}, external {}",
        fmt(s.alarm_level_internal_lpm, None),
        fmt(s.alarm_level_external_lpm, None)
    )?;
    let p = s.probabilities;
    writeln!(
        out,
        "evidence    leading {}; P(healthy) {:.3}, P(internal) {:.3}, P(external) {:.3}, P(both) {:.3}",
        s.leading, p[0], p[1], p[2], p[3]
    )?;
    if let Some(gross) = s.provisional_floor_lpm {
        writeln!(
            out,
            "parameters  provisional, not calibrated for this installation: never `healthy`, leaks alarm above {gross:.2} l/min only (give --params, e.g. from host-sim calibrate)"
        )?;
    }
    if s.model_mismatch_fraction > 0.01 {
        writeln!(
            out,
            "warning     the model fits poorly on {:.0} % of samples: calibrate this installation (host-sim calibrate)",
            100.0 * s.model_mismatch_fraction
        )?;
    }
    if s.valve_misfit_fraction >= crate::calibrate::WARN_VALVE_MISFIT_FRACTION {
        writeln!(
            out,
            "warning     the valve flow gains stood beyond what the valve model describes on {:.0} % of samples: no evidence there (recalibrate this installation, or check the valve)",
            100.0 * s.valve_misfit_fraction
        )?;
    }
    if s.hold_command_shifted_fraction > 0.0 {
        writeln!(
            out,
            "note        the loop held the piston with a valve command away from the installation's on {:.1} % of samples: healthy withheld there (a flow fed through the valve: a leak the filters did not name, or a valve null that moved)",
            100.0 * s.hold_command_shifted_fraction
        )?;
    }
    if let Some(share) = s
        .loop_oscillation_share
        .filter(|&v| oscillation::share_worth_a_warning(v))
    {
        writeln!(
            out,
            "warning     the position loop oscillates{} during {:.0} % of the recording: no sample there is leak evidence (stabilise the loop for full monitoring)",
            s.loop_oscillation_hz
                .map_or(String::new(), |hz| format!(" at ≈ {hz:.0} Hz")),
            100.0 * share
        )?;
    }
    if !s.events.is_empty() {
        writeln!(out, "events")?;
        for e in s.events.iter().take(50) {
            let what = e.verdict.or(e.sensor).or(e.hypothesis).unwrap_or("");
            writeln!(out, "  {:>10.3} s  {} {}", e.t, e.kind, what)?;
        }
        if s.events.len() > 50 {
            writeln!(out, "  … {} more", s.events.len() - 50)?;
        }
    }
    if s.events_dropped > 0 {
        writeln!(
            out,
            "  … and {} more events not kept (only the first {MAX_EVENTS} are)",
            s.events_dropped
        )?;
    }
    Ok(())
}
