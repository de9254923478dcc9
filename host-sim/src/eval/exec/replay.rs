//! Replay: the monitor over a run's recording, the truth, a follower's placement.

use super::{
    at_rate, Alarm, RunResult, TextReader, TruthSummary, FAULT_GRACE_S, HOLD_SPEED, MID_MOVE_S,
    MIN_HOLD_S, MOVE_SPEED, SIZE_SPAN_S,
};
use crate::eval::plan::{fault_window, FAULT_AT_S};
use crate::eval::{Category, Follower, Placement, RunSpec};
use anyhow::Result;
use monitor::{Event, Monitor, Params};

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
        if s.quasi_steady() {
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
    // The true flow averaged as the monitor averages the size it reports.
    let mut reported = [0.0f64; 2];
    let mut speed = 0.0f64;
    let (mut still_from, mut best_hold): (Option<f64>, Option<(f64, f64)>) = (None, None);
    let mut moving_from: Option<f64> = None;
    let mut mid_move_s = None;
    let mut last = t0;
    for (&ti, qi) in t.iter().zip(q) {
        let dt = (ti - last).max(0.0);
        last = ti;
        let a = (dt / params.filter.detection_window_s).min(1.0);
        let a_size = (dt / params.filter.evidence_window_s).min(1.0);
        for k in 0..2 {
            short[k] += a * ((qi[k] as f64).abs() - short[k]);
            reported[k] += a_size * (qi[k] as f64 - reported[k]);
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
        size_lpm: reported,
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
