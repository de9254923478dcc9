//! The CAN frames: each decodes (CRC, fields) with consecutive counters
//! per identifier; each kind is sent exactly at the samples its schedule
//! says (`monitor::protocol::schedule`: status every 100 ms, detail,
//! sensitivity, heartbeat, identity and version every second, alarm every
//! second and at once on a change); status, detail, sensitivity and alarm
//! frames hold exactly what the host computed for that sample, identity and version what the board
//! booted with; heartbeats report no missed samples, overruns or
//! dropped frames; after the last sample, exactly one frame: the alarm
//! frame announcing the stalled estimator, 20–30 ms later (two
//! supervisor checks without progress after the last one with).

use embassy_time::{Duration, Instant};
use firmware::app::supervisor::CHECK_PERIOD;
use heapless::Vec;
use monitor::device::alarm::AlarmState;
use monitor::protocol::schedule::{
    ALARM_REFRESH_PHASE_MS, DETAIL_PHASE_MS, HEARTBEAT_PHASE_MS, IDENTITY_PHASE_MS,
    SENSITIVITY_PHASE_MS, SLOW_PERIOD_MS, STATUS_PERIOD_MS, VERSION_PHASE_MS,
};
use monitor::protocol::{
    AlarmFrame, Decoder, HeartbeatFrame, Message, MessageKind, Node, Sequence,
};

use super::{Check, Expect, Findings};
use crate::emu::case::EmuCase;
use crate::emu::record::{Log, MAX_FRAMES};

/// A frame that decoded.
#[derive(Clone, Copy, Debug)]
pub struct Decoded {
    /// When it was sent, since boot.
    pub at: Instant,
    /// The sample being processed when it was sent (`None`: before the
    /// first).
    pub k: Option<u32>,
    /// Its message.
    pub msg: Message,
}

/// The decoded frames.
#[derive(Debug, Default)]
pub struct Frames {
    /// Every frame that decoded, in transmit order.
    pub list: Vec<Decoded, MAX_FRAMES>,
    /// The alarm frame after the last sample, and when it was sent.
    pub stall: Option<(Instant, AlarmFrame)>,
}

impl Frames {
    /// The alarm frames sent while samples were processed.
    pub fn alarms(&self) -> impl Iterator<Item = (u32, AlarmFrame)> + '_ {
        self.list.iter().filter_map(|d| match (d.k, d.msg) {
            (Some(k), Message::Alarm(a)) => Some((k, a)),
            _ => None,
        })
    }
}

/// Is a frame of `kind` due at sample time `t_ms` (`changed`: the alarm
/// output changed at this sample)?
fn due(kind: MessageKind, t_ms: u64, changed: bool) -> bool {
    let slow = |phase: u64| t_ms == 0 || t_ms % SLOW_PERIOD_MS == phase;
    match kind {
        MessageKind::Alarm => changed || slow(ALARM_REFRESH_PHASE_MS),
        MessageKind::Status => t_ms.is_multiple_of(STATUS_PERIOD_MS),
        MessageKind::Detail => slow(DETAIL_PHASE_MS),
        MessageKind::Heartbeat => slow(HEARTBEAT_PHASE_MS),
        MessageKind::Identity => slow(IDENTITY_PHASE_MS),
        MessageKind::Version => slow(VERSION_PHASE_MS),
        MessageKind::Sensitivity => slow(SENSITIVITY_PHASE_MS),
        // Sent by the CAN receiver task on its own clock.
        MessageKind::Challenge | MessageKind::Command => false,
    }
}

/// Decode every frame of `node`; check CRCs, fields and counters.
fn decode(log: &Log, node: Node, f: &mut Findings) -> Frames {
    let mut frames = Frames::default();
    let mut decoder = Decoder::for_node(node);
    for (i, sent) in log.frames.iter().enumerate() {
        let t_us = sent.at.as_micros();
        match decoder.decode(&sent.frame) {
            Err(e) => f.fail(
                Check::Decode,
                format_args!(
                    "frame #{i} (id {:#05x}, {} µs): {:?}",
                    sent.frame.id(),
                    t_us,
                    e
                ),
            ),
            Ok(r) => {
                if r.sequence.is_error() {
                    f.fail(
                        Check::Counter,
                        format_args!(
                            "frame #{i} ({}, {} µs): counter {} is {:?}",
                            r.message.kind().name(),
                            t_us,
                            r.counter,
                            r.sequence
                        ),
                    );
                }
                let first = !frames.list.iter().any(|d| d.msg.kind() == r.message.kind());
                if first && r.sequence != Sequence::First {
                    f.fail(Check::Counter, format_args!("frame #{i}: not first"));
                }
                let d = Decoded {
                    at: sent.at,
                    k: log.sample_at(sent.at),
                    msg: r.message,
                };
                // `log.frames` has the same capacity.
                let _ = frames.list.push(d);
            }
        }
    }
    frames
}

/// Check a heartbeat sent at `at`.
fn heartbeat(h: &HeartbeatFrame, at: Instant, expect: &Expect, f: &mut Findings) {
    let secs = at.as_secs();
    let ok = h.reset_cause == expect.reset_cause
        && h.missed_samples == 0
        && h.adc_overruns == 0
        && h.can_tx_dropped == 0
        && h.estimator_load_pct <= h.peak_load_pct
        && h.peak_load_pct <= 100
        && (u64::from(h.uptime_s) == secs || u64::from(h.uptime_s) + 1 == secs);
    if !ok {
        f.fail(
            Check::Heartbeat,
            format_args!("heartbeat at {} µs: {:?}", at.as_micros(), h),
        );
    }
}

/// Schedule and contents of one kind over the samples.
fn kind(case: &EmuCase, frames: &Frames, kind: MessageKind, expect: &Expect, f: &mut Findings) {
    let n = case.samples;
    let changed = |k: u32| case.alarm_changes.iter().any(|&(c, _)| c == k && k > 0);
    let t_ms = |k: u32| u64::from(k) * u64::from(case.sample_period_us) / 1000;
    let mut want = (0..n).filter(|&k| due(kind, t_ms(k), changed(k)));
    let mut got = frames
        .list
        .iter()
        .filter(|d| d.msg.kind() == kind && d.k.is_some_and(|k| k < n));
    let mut count = 0u32;
    loop {
        match (want.next(), got.next()) {
            (None, None) => break,
            (Some(w), Some(g)) if g.k == Some(w) => {
                count += 1;
                let r = case.reference(w);
                let same = match g.msg {
                    Message::Status(s) => s == r.status,
                    Message::Detail(d) => d == r.detail,
                    Message::Alarm(a) => a == r.alarm,
                    Message::Heartbeat(h) => {
                        heartbeat(&h, g.at, expect, f);
                        true
                    }
                    Message::Identity(i) => i == expect.identity,
                    Message::Version(v) => v == expect.version,
                    Message::Sensitivity(s) => s == r.sensitivity,
                    Message::Challenge(_) | Message::Command(_) => false,
                };
                if !same {
                    let host = match kind {
                        MessageKind::Status => Message::Status(r.status),
                        MessageKind::Detail => Message::Detail(r.detail),
                        MessageKind::Identity => Message::Identity(expect.identity),
                        MessageKind::Version => Message::Version(expect.version),
                        MessageKind::Sensitivity => Message::Sensitivity(r.sensitivity),
                        _ => Message::Alarm(r.alarm),
                    };
                    f.fail(
                        Check::Content,
                        format_args!(
                            "sample {w}: firmware sent {:?}, the host computed {:?}",
                            g.msg, host
                        ),
                    );
                }
            }
            (w, g) => {
                f.fail(
                    Check::Schedule,
                    format_args!(
                        "{}: after {count} frames as due, due at sample {:?}, sent at sample {:?}",
                        kind.name(),
                        w,
                        g.map(|g| g.k)
                    ),
                );
                break;
            }
        }
    }
}

/// After the last sample: exactly one frame, the stalled alarm.
fn stall(case: &EmuCase, log: &Log, frames: &mut Frames, f: &mut Findings) {
    let n = case.samples;
    let last_block = log
        .t0
        .map(|t0| t0 + Duration::from_micros(u64::from(case.sample_period_us) * u64::from(n - 1)));
    let mut after = frames.list.iter().filter(|d| d.k.is_some_and(|k| k >= n));
    let last_host = case.reference(n - 1).alarm;
    match (after.next(), after.next(), last_block) {
        (Some(d), None, Some(t_end)) => match d.msg {
            Message::Alarm(a)
                if a.state == AlarmState::EstimatorStalled
                    && !a.relay_energised
                    && a.latched == last_host.latched
                    && a.faulted_channels == last_host.faulted_channels
                    && d.at >= t_end + CHECK_PERIOD * 2
                    && d.at <= t_end + CHECK_PERIOD * 3 + Duration::from_millis(1)
                    // Alarm frames are dated on the sample clock: ms since
                    // the first sample (the board's t0).
                    && log.t0.is_some_and(|t0| {
                        u64::from(a.changed_at_ms).abs_diff((d.at - t0).as_millis()) <= 1
                    }) =>
            {
                frames.stall = Some((d.at, a));
                f.note(format_args!(
                    "stall: {} µs after the last sample, the supervisor announced {} (relay off, latched {}, changed at {} ms on the sample clock)",
                    (d.at - t_end).as_micros(),
                    a.state.name(),
                    a.latched.name(),
                    a.changed_at_ms
                ));
            }
            other => f.fail(
                Check::Stall,
                format_args!(
                    "after the last sample, sent at {} µs: {:?}",
                    d.at.as_micros(),
                    other
                ),
            ),
        },
        (d0, d1, _) => f.fail(
            Check::Stall,
            format_args!("after the last sample: {:?}, then {:?}", d0, d1),
        ),
    }
}

/// Decode and check every frame; return them for the other checks.
pub fn check(case: &EmuCase, log: &Log, expect: &Expect, f: &mut Findings) -> Frames {
    let mut frames = decode(log, expect.identity.node, f);
    print(&frames, f);
    for k in [
        MessageKind::Alarm,
        MessageKind::Status,
        MessageKind::Detail,
        MessageKind::Heartbeat,
        MessageKind::Identity,
        MessageKind::Version,
        MessageKind::Sensitivity,
    ] {
        kind(case, &frames, k, expect, f);
    }
    if let Some(d) = frames
        .list
        .iter()
        .find(|d| d.msg.kind() == MessageKind::Command)
    {
        f.fail(
            Check::Schedule,
            format_args!("the firmware sent a command: {:?}", d),
        );
    }
    if let Some(d) = frames
        .list
        .iter()
        .find(|d| d.k.is_none() && d.msg.kind() != MessageKind::Challenge)
    {
        f.fail(
            Check::Schedule,
            format_args!("sent before the first sample: {:?}", d),
        );
    }
    stall(case, log, &mut frames, f);
    frames
}

/// Print the frame sequence: counts per kind, every alarm frame and
/// heartbeat, the status frames whose verdict or health changed and the
/// sensitivity frames whose alarm levels changed.
pub fn print(frames: &Frames, f: &Findings) {
    if f.quiet {
        return;
    }
    let count = |kind: MessageKind| frames.list.iter().filter(|d| d.msg.kind() == kind).count();
    f.note(format_args!(
        "frames: {} decoded: alarm {}, status {}, detail {}, heartbeat {}, identity {}, version {}, sensitivity {}",
        frames.list.len(),
        count(MessageKind::Alarm),
        count(MessageKind::Status),
        count(MessageKind::Detail),
        count(MessageKind::Heartbeat),
        count(MessageKind::Identity),
        count(MessageKind::Version),
        count(MessageKind::Sensitivity)
    ));
    let mut last_status = None;
    let mut last_levels = None;
    for d in &frames.list {
        let k = d.k.unwrap_or(u32::MAX);
        match d.msg {
            Message::Alarm(a) => f.note(format_args!(
                "  sample {k:>5} alarm: {} latched {} relay {} faulted {:#04x} changed at {} ms",
                a.state.name(),
                a.latched.name(),
                if a.relay_energised { "on" } else { "off" },
                a.faulted_channels,
                a.changed_at_ms
            )),
            Message::Heartbeat(h) => f.note(format_args!(
                "  sample {k:>5} heartbeat: uptime {} s, load {} % peak {} %, missed {}, overruns {}, dropped {}, reset {}",
                h.uptime_s,
                h.estimator_load_pct,
                h.peak_load_pct,
                h.missed_samples,
                h.adc_overruns,
                h.can_tx_dropped,
                h.reset_cause.name()
            )),
            Message::Status(s) if last_status != Some((s.verdict, s.health)) => {
                last_status = Some((s.verdict, s.health));
                f.note(format_args!(
                    "  sample {k:>5} status: verdict {} health {:#06x} leak internal {:?} external {:?} ml/min",
                    s.verdict.name(),
                    s.health,
                    s.leak_internal_ml_min,
                    s.leak_external_ml_min
                ))
            }
            Message::Sensitivity(s) => {
                let levels = (s.alarm_level_internal_ml_min, s.alarm_level_external_ml_min);
                if last_levels != Some(levels) {
                    last_levels = Some(levels);
                    f.note(format_args!(
                        "  sample {k:>5} sensitivity: alarm level internal {:?} external {:?} ml/min, evidence weight {:?} %",
                        levels.0, levels.1, s.evidence_weight_pct
                    ))
                }
            }
            _ => {}
        }
    }
}
