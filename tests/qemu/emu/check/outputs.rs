//! Everything but the frames' schedule and contents: the replay itself,
//! the relay, the announced verdict against the golden (unquantised
//! readings), the command frames, the watchdog and the firmware's
//! counters.

use embassy_time::{Duration, Instant};
use firmware::app::shared::Shared;
use firmware::app::supervisor::{CHECK_PERIOD, CLOCK_EVERY, REFERENCE_EVERY};
use heapless::Vec;
use monitor::Event;
use monitor::LeakSet;

use super::frames::Frames;
use super::{Check, Expect, Findings};
use crate::emu::case::EmuCase;
use crate::emu::record::{Log, Readings, RelayChange, MAX_RELAY};

/// How far (samples = ms) an alarm may be raised from the golden's time
/// for the same recording before ADC quantisation (a 12-bit code is
/// 0.1 bar; averaged over 4 scans, 0.026 bar).
pub const GOLDEN_TOLERANCE: u32 = 100;

/// When the last block was complete.
fn last_block(case: &EmuCase, log: &Log) -> Option<Instant> {
    let period = Duration::from_micros(u64::from(case.sample_period_us));
    log.t0.map(|t0| t0 + period * (case.samples - 1))
}

/// Every block replayed once, none lost, nothing overflowed.
pub fn replay(case: &EmuCase, log: &Log, f: &mut Findings) {
    if log.overflow || log.t0.is_none() || log.blocks != case.samples || log.overruns != 0 {
        f.fail(
            Check::Log,
            format_args!(
                "replay: {} of {} blocks, {} overruns, record overflow {}, t0 {:?}",
                log.blocks, case.samples, log.overruns, log.overflow, log.t0
            ),
        );
    }
}

/// After the warm-up, the monitor needs at most this many samples of a
/// quiet healthy recording to claim healthy.
const EVIDENCE_SAMPLES: u32 = 3_000;

/// The relay: written de-energised before the first sample; then changed
/// exactly where the host's alarm output changes it; off during the
/// warm-up and energised within [`EVIDENCE_SAMPLES`] after it (unless the
/// golden raised an alarm by then); always agreeing with the alarm frames; de-energised when
/// the estimator stalls.
pub fn relay(case: &EmuCase, log: &Log, frames: &Frames, f: &mut Findings) {
    let (Some(t0), Some(t_end)) = (log.t0, last_block(case, log)) else {
        return;
    };
    match log.relay.first() {
        Some(c) if c.at < t0 && !c.energised => f.note(format_args!(
            "relay: de-energised at boot ({} µs, before the first sample)",
            c.at.as_micros()
        )),
        other => f.fail(Check::Relay, format_args!("first relay write: {:?}", other)),
    }
    let mut host: Vec<(u32, bool), MAX_RELAY> = Vec::new();
    let mut on = false;
    for (k, a) in case.alarm_changes() {
        if a.relay_energised != on {
            on = a.relay_energised;
            let _ = host.push((k, on));
        }
    }
    let firmware: Vec<(u32, bool), MAX_RELAY> = log
        .relay
        .iter()
        .skip(1)
        .filter(|c| c.at <= t_end + Duration::from_millis(1) && c.at >= t0)
        .filter_map(|c| Some((log.sample_at(c.at)?, c.energised)))
        .collect();
    if firmware != host {
        f.fail(
            Check::Relay,
            format_args!(
                "relay changes (sample, energised): firmware {:?}, host {:?}",
                firmware, host
            ),
        );
    } else {
        f.note(format_args!(
            "relay changes (sample, energised), as the host's: {:?}",
            firmware
        ));
    }
    // Independently of the host's run: off through the warm-up, then
    // energised once the monitor has seen enough evidence to claim healthy
    // (`healthy` is a claim: `filter.min_evidence_s` of quasi-steady data
    // after the warm-up), unless the golden raised an alarm by then.
    let warm_up = case.warm_up_samples();
    let early_alarm = EmuCase::decoded(case.golden_events)
        .any(|(k, e)| k <= warm_up + EVIDENCE_SAMPLES && matches!(e, Event::AlarmRaised(_)));
    let energised_in_time = matches!(
        firmware.first(),
        Some(&(k, true)) if k >= warm_up && k <= warm_up + EVIDENCE_SAMPLES
    );
    if !early_alarm && !energised_in_time {
        f.fail(
            Check::Relay,
            format_args!(
                "not energised within {EVIDENCE_SAMPLES} samples after the warm-up (sample {warm_up}): first change {:?}",
                firmware.first()
            ),
        );
    }
    if let Some(&(k, _)) = firmware.iter().find(|c| c.1 && c.0 < warm_up) {
        f.fail(
            Check::Relay,
            format_args!("energised during the warm-up, at sample {k}"),
        );
    }
    for d in &frames.list {
        if let (Some(k), monitor::protocol::Message::Alarm(a)) = (d.k, d.msg) {
            if k < case.samples && log.relay_at(d.at) != a.relay_energised {
                f.fail(
                    Check::Relay,
                    format_args!(
                        "sample {k}: alarm frame says relay {}, relay is {}",
                        a.relay_energised, !a.relay_energised
                    ),
                );
            }
        }
    }
    // The supervisor switches the relay off just before it posts the
    // stalled alarm frame.
    let stalled_at = frames.stall.map_or(t_end + CHECK_PERIOD * 3, |(at, _)| at);
    let after_end = |c: &&RelayChange| c.at > t_end + Duration::from_millis(1);
    let stall_writes: Vec<RelayChange, MAX_RELAY> =
        log.relay.iter().filter(after_end).copied().collect();
    let want: &[bool] = if on { &[false] } else { &[] };
    let switched_off = stall_writes
        .iter()
        .map(|c| c.energised)
        .eq(want.iter().copied())
        && stall_writes
            .iter()
            .all(|c| c.at <= stalled_at && c.at + Duration::from_millis(1) > stalled_at);
    if switched_off && !log.relay_at(stalled_at) {
        f.note(format_args!(
            "relay after the samples stopped: {}",
            if on {
                "switched off by the supervisor"
            } else {
                "stays off"
            }
        ));
    } else {
        f.fail(
            Check::Relay,
            format_args!(
                "relay after the samples stopped: {:?} (stalled at {} µs)",
                stall_writes,
                stalled_at.as_micros()
            ),
        );
    }
}

/// The leak the firmware announced (alarm frames before the acknowledge)
/// against the golden's alarms, computed on the host from the
/// unquantised readings: the same kinds in the same order, each within
/// [`GOLDEN_TOLERANCE`] samples; the latched leak at the end (or before
/// the acknowledge) is the golden's final verdict.
pub fn verdict(case: &EmuCase, frames: &Frames, f: &mut Findings) {
    let end = case.ack_sample.unwrap_or(case.samples);
    let mut firmware: Vec<(u32, LeakSet), 16> = Vec::new();
    let mut latched = LeakSet::NONE;
    for (k, a) in frames.alarms().filter(|&(k, _)| k < end) {
        if a.latched != latched {
            latched = a.latched;
            if firmware.push((k, latched)).is_err() {
                f.fail(Check::Verdict, format_args!("more than 16 alarm changes"));
                return;
            }
        }
    }
    let golden: Vec<(u32, LeakSet), 16> = EmuCase::decoded(case.golden_events)
        .filter_map(|(k, e)| match e {
            Event::AlarmRaised(v) if k < end => Some((k, v.leaks())),
            _ => None,
        })
        .collect();
    let want = case.golden_verdict().leaks();
    let agree = firmware.len() == golden.len()
        && firmware
            .iter()
            .zip(&golden)
            .all(|(a, b)| a.1 == b.1 && a.0.abs_diff(b.0) <= GOLDEN_TOLERANCE);
    let host: Vec<(u32, Event), 16> = EmuCase::decoded(case.events).take(16).collect();
    f.note(format_args!(
        "host's monitor events for these ADC codes: {:?}",
        host
    ));
    if agree && latched == want {
        f.note(format_args!(
            "verdict: announced (sample, latched leak) {:?}; golden (unquantised, host) {:?}; latched {} = the golden's final verdict {}",
            firmware,
            golden,
            latched.name(),
            case.golden_verdict().name()
        ));
    } else {
        f.fail(
            Check::Verdict,
            format_args!(
                "announced {:?}, latched {} at the end; the golden raised {:?} and ended {}",
                firmware,
                latched.name(),
                golden,
                case.golden_verdict().name()
            ),
        );
    }
}

/// The corrupted and the replayed command are rejected by the CAN
/// receiver; the authentic acknowledge reaches the estimator, whose
/// acknowledge policy refuses it (it comes within the hold-off after the
/// alarm) and changes nothing. Every attempt shows in `LM_Challenge`:
/// (attempts, last result) runs (1, malformed), (2, hold_off),
/// (3, stale_challenge), and the challenge changes with each alarm raised
/// and with the authentic frame (its answer is used up).
pub fn commands(
    case: &EmuCase,
    frames: &Frames,
    shared: &Shared,
    expect: &Expect,
    f: &mut Findings,
) {
    use core::sync::atomic::Ordering::Relaxed;
    use monitor::acknowledge::{AckRejected, AckResult};
    let rejected = shared.can.rejected.load(Relaxed);
    let bus_errors = shared.can.bus_errors.load(Relaxed);
    if rejected != expect.rejected_commands || bus_errors != 0 {
        f.fail(
            Check::Commands,
            format_args!(
                "{rejected} commands rejected (want {}), {bus_errors} bus errors",
                expect.rejected_commands
            ),
        );
    }
    // Every challenge frame: distinct (attempts, result) and challenges.
    let mut results: Vec<(u8, Option<AckResult>), 8> = Vec::new();
    let mut challenges: Vec<u32, 16> = Vec::new();
    for d in frames.list.iter() {
        if let monitor::protocol::Message::Challenge(c) = d.msg {
            if results.last() != Some(&(c.ack_attempts, c.last_ack)) {
                let _ = results.push((c.ack_attempts, c.last_ack));
            }
            if challenges.last() != Some(&c.challenge) {
                let _ = challenges.push(c.challenge);
            }
        }
    }
    let Some(ack) = case.ack_sample else {
        if results.as_slice() != [(0, None)] || challenges.is_empty() {
            f.fail(
                Check::Commands,
                format_args!("no command sent, yet challenge frames show {results:?}, challenges {challenges:?}"),
            );
        }
        return;
    };
    let want = [
        (0, None),
        (1, Some(AckResult::Rejected(AckRejected::Malformed))),
        (2, Some(AckResult::Rejected(AckRejected::HoldOff))),
        (3, Some(AckResult::Rejected(AckRejected::StaleChallenge))),
    ];
    // The boot's challenge, one per alarm raised, one after the authentic
    // frame (alarms raised after it add more).
    let min_challenges = 2 + case.ack_rotations as usize;
    let before = frames.alarms().filter(|&(k, _)| k < ack).last();
    let after = frames.alarms().filter(|&(k, _)| k <= ack + 50).last();
    let unchanged = matches!((before, after), (Some((_, b)), Some((_, a))) if b.latched == a.latched && b.latched != LeakSet::NONE && !a.relay_energised);
    if results.as_slice() == want && challenges.len() >= min_challenges && unchanged {
        f.note(format_args!(
            "acknowledge at sample {ack} (inside the hold-off): refused, latch and relay unchanged; challenge frames: {:?}; {} challenges ({} alarms raised before it); {rejected} commands rejected by the receiver",
            results.as_slice(),
            challenges.len(),
            case.ack_rotations
        ));
    } else {
        f.fail(
            Check::Commands,
            format_args!(
                "acknowledge at sample {ack}: challenge frames {:?} (want {want:?}), {} challenges (want at least {min_challenges}), alarm frames before/after {:?}/{:?}",
                results.as_slice(),
                challenges.len(),
                before,
                after
            ),
        );
    }
}

/// Fed every check period while samples came; no longer once they
/// stopped.
pub fn watchdog(case: &EmuCase, log: &Log, frames: &Frames, f: &mut Findings) {
    let Some(t_end) = last_block(case, log) else {
        return;
    };
    let Some((first, last)) = log.feed_span else {
        f.fail(Check::Watchdog, format_args!("never fed"));
        return;
    };
    let stalled = frames.stall.map_or(t_end, |(at, _)| at);
    let ok = log.max_feed_gap <= CHECK_PERIOD + Duration::from_millis(1)
        && last + CHECK_PERIOD >= t_end
        && last < stalled
        && first <= log.t0.unwrap_or(t_end) + CHECK_PERIOD;
    if ok {
        f.note(format_args!(
            "watchdog: {} feeds from {} to {} ms, at most {} ms apart; none after the samples stopped",
            log.feeds,
            first.as_millis(),
            last.as_millis(),
            log.max_feed_gap.as_millis()
        ));
    } else {
        f.fail(
            Check::Watchdog,
            format_args!(
                "{} feeds from {} to {} µs, max gap {} µs; last sample {} µs, stalled {} µs",
                log.feeds,
                first.as_micros(),
                last.as_micros(),
                log.max_feed_gap.as_micros(),
                t_end.as_micros(),
                stalled.as_micros()
            ),
        );
    }
}

/// The supervisor takes its diagnostic readings at their pace for the
/// whole run: VREFINT every `REFERENCE_EVERY` checks (100 ms), the LSI
/// every `CLOCK_EVERY` checks (1 s), the first one period after it
/// started (`record::Log::feed_span` dates its first check, within a
/// check period of the first sample), the last within a period of the
/// end of the run (the checker runs 50 ms after the last sample).
/// Healthy readings must raise no device fault: the frames' contents
/// (against the host's, which has none) check that.
pub fn diagnostics(case: &EmuCase, log: &Log, f: &mut Findings) {
    let (Some(t_end), Some((first_feed, _))) = (last_block(case, log), log.feed_span) else {
        return;
    };
    let slack = Duration::from_millis(1);
    let mut cadence = |name: &str, r: &Readings, every: u32| {
        let period = CHECK_PERIOD * every;
        let ok = match (r.span, r.gaps) {
            (Some((first, last)), Some((lo, hi))) => {
                lo + slack >= period
                    && hi <= period + slack
                    && first <= first_feed + period
                    && last + period + slack >= t_end
            }
            _ => false,
        };
        if ok {
            f.note(format_args!(
                "diagnostics: {} {name} readings, every {} ms",
                r.count,
                period.as_millis()
            ));
        } else {
            f.fail(
                Check::Diagnostics,
                format_args!(
                    "{name} readings: {} taken, span {:?}, gaps {:?}, want every {} ms to {} ms",
                    r.count,
                    r.span,
                    r.gaps,
                    period.as_millis(),
                    t_end.as_millis()
                ),
            );
        }
    };
    cadence("VREFINT", &log.vrefint, REFERENCE_EVERY);
    cadence("LSI", &log.lsi, CLOCK_EVERY);
}

/// The firmware's counters: every sample processed in time, every frame
/// sent, nothing dropped or replaced in the outbox, no log line lost.
pub fn counters(case: &EmuCase, log: &Log, shared: &Shared, f: &mut Findings) {
    use core::sync::atomic::Ordering::Relaxed;
    let processed = shared.processed.load(Relaxed);
    let missed = shared.missed.load(Relaxed);
    let sent = shared.can.sent.load(Relaxed);
    let dropped = shared.can.dropped.load(Relaxed);
    let replaced = shared.replaced();
    let log_dropped = shared.log_dropped();
    if processed != case.samples
        || missed != 0
        || sent as usize != log.frames.len()
        || dropped != 0
        || replaced != 0
        || log_dropped != 0
    {
        f.fail(
            Check::Counters,
            format_args!(
                "processed {processed} of {}, missed {missed}, CAN sent {sent} (board saw {}), dropped {dropped}, outbox replaced {replaced}, log dropped {log_dropped}",
                case.samples,
                log.frames.len()
            ),
        );
    }
}
