//! The supervisor task (low priority, every 10 ms): feeds the watchdog
//! only while the estimator keeps its deadline (`monitor::device::supervisor`),
//! de-energises the relay for good when the estimator stalls (the
//! watchdog then resets the board), runs the device diagnostics (the
//! board's self-test step, relay read-back and program flow every check,
//! a VREFINT conversion every 100 ms, an LSI measurement every second;
//! a fault drops the relay until reset), drives the status LED, and
//! writes the log: the estimator's events as they come, a summary every
//! second.

use core::sync::atomic::Ordering;

use embassy_time::{Duration, Instant, Ticker};
use monitor::device::alarm::AlarmState;
use monitor::device::diagnostics::check::{CheckInputs, SupervisorChecks};
use monitor::device::diagnostics::flow::Checkpoint;
use monitor::device::diagnostics::DeviceFault;
use monitor::device::estimator::stall;
use monitor::device::supervisor::{Supervision, Supervisor, SupervisorConfig};
use monitor::protocol::Message;

use super::shared::{LogEvent, Shared};
use crate::board::{RelayOutput, SelfTest, StatusLed, Watchdog};

/// How often the estimator is checked.
pub const CHECK_PERIOD: Duration = Duration::from_millis(10);

/// Program-flow checkpoint of the estimator, passed every block. Its
/// deadline is longer than the stall rule's, which reacts first.
pub const ESTIMATOR: Checkpoint = Checkpoint {
    bit: 0,
    deadline_checks: 3,
};

/// Program-flow checkpoint of the CAN transmitter, passed after every
/// batch of frames (a status frame is due every 100 ms).
pub const CAN_TX: Checkpoint = Checkpoint {
    bit: 1,
    deadline_checks: 50,
};

/// Checks per VREFINT conversion (every 100 ms): the ADC reference check
/// (`monitor::device::diagnostics::reference`) faults after 10 readings out
/// of range in a row, about 1 s.
pub const REFERENCE_EVERY: u32 = 10;

/// Checks per LSI measurement (every 1 s, one window of sample time; the
/// first after one window of running): the clock cross-check
/// (`monitor::device::diagnostics::clock`) takes the first as its
/// reference and faults after two windows out of tolerance.
pub const CLOCK_EVERY: u32 = 100;

/// Checks per summary log line.
const SUMMARY_EVERY: u32 = 100;

fn log_event(e: LogEvent) {
    match e {
        LogEvent::Monitor { t_ms, event } => defmt::info!("{=u64} ms: {}", t_ms, event),
        LogEvent::Alarm { t_ms, output } => defmt::warn!(
            "{=u64} ms: alarm output {} (latched {}, faulted channels {=u8:#x}), relay {}",
            t_ms,
            output.state,
            output.latched,
            output.faulted_channels,
            if output.relay_energised() {
                "energised"
            } else {
                "off"
            }
        ),
        LogEvent::AckAttempt(e) => match e.outcome {
            monitor::acknowledge::AckResult::Accepted => {
                defmt::warn!("{=u64} ms: acknowledge accepted", e.t_ms)
            }
            monitor::acknowledge::AckResult::Rejected(r) => {
                defmt::warn!("{=u64} ms: acknowledge rejected: {}", e.t_ms, r)
            }
        },
        LogEvent::Overrun { t_ms, lost } => {
            defmt::warn!("{=u64} ms: ADC overrun, {} samples lost", t_ms, lost)
        }
    }
}

/// The device diagnostics of check number `check` (from 1; the rule is
/// `monitor::device::diagnostics::check`): read the inputs (VREFINT and the
/// LSI only when due), latch what is found in `shared` (the estimator
/// shows it from its next block) and drop the relay at once. Returns false
/// when a checkpoint was missed.
fn diagnose<R: RelayOutput, S: SelfTest>(
    diagnostics: &mut SupervisorChecks<2>,
    self_test: &mut S,
    relay: &R,
    shared: &Shared,
    started: bool,
    check: u32,
) -> bool {
    let lsi_cycles = if check.is_multiple_of(CLOCK_EVERY) {
        let n = self_test.lsi_cycles_per_window();
        if n.is_none() {
            defmt::warn!("clock check: no valid LSI measurement in this window");
        }
        n
    } else {
        None
    };
    let inputs = CheckInputs {
        self_test: self_test.step(),
        relay_commanded: relay.commanded(),
        relay_read_back: relay.read_back(),
        checkpoints: shared.take_checkpoints(),
        started,
        stalled: shared.stalled.load(Ordering::Acquire),
        vrefint: check
            .is_multiple_of(REFERENCE_EVERY)
            .then(|| self_test.vrefint_code()),
        lsi_cycles,
        clock_failed: self_test.clock_failed(),
    };
    // Bring-up aid, compiled in with DEFMT_LOG=debug: the raw readings
    // once a second.
    if let (Some(code), Some(n)) = (inputs.vrefint, inputs.lsi_cycles) {
        defmt::debug!(
            "diagnostics: VREFINT code {=u16}, LSI {=u32} cycles/s",
            code,
            n
        );
    }
    let had_reference = diagnostics.clock_reference().is_some();
    let out = diagnostics.check(&inputs);
    if let (false, Some(r)) = (had_reference, diagnostics.clock_reference()) {
        defmt::info!(
            "clock check: LSI reference {=u32} cycles per second of samples",
            r
        );
    }
    for f in DeviceFault::ALL {
        if out.found.contains(f) {
            relay.set_energised(false);
            if shared.raise_device_fault(f) {
                defmt::error!("device fault: {}: relay off until reset", f.name());
            }
        }
    }
    out.flow_kept
}

/// Run the supervisor for ever.
pub async fn run<W: Watchdog, R: RelayOutput, L: StatusLed, S: SelfTest>(
    mut watchdog: W,
    relay: &R,
    mut led: L,
    mut self_test: S,
    shared: &Shared,
) -> ! {
    let mut supervisor = Supervisor::new(SupervisorConfig::DEFAULT);
    let mut diagnostics = SupervisorChecks::new([ESTIMATOR, CAN_TX]);
    let mut ticker = Ticker::every(CHECK_PERIOD);
    let mut checks = 0u32;
    loop {
        ticker.next().await;
        checks = checks.wrapping_add(1);
        let now_ms = Instant::now().as_millis();
        let processed = shared.processed.load(Ordering::Acquire);
        let missed = shared.missed.load(Ordering::Acquire);
        let started = processed != 0 || missed != 0;
        let flow_kept = diagnose(
            &mut diagnostics,
            &mut self_test,
            relay,
            shared,
            started,
            checks,
        );
        match supervisor.check(processed, missed) {
            // A task that missed its checkpoint withholds the watchdog too.
            Supervision::Feed if flow_kept => watchdog.feed(),
            Supervision::Feed => {}
            Supervision::Withhold => {}
            Supervision::Stalled => {
                if !shared.stalled.swap(true, Ordering::AcqRel) {
                    let stall = stall(shared.last_alarm(), shared.sample_clock_ms(now_ms));
                    relay.set_energised(stall.output.relay_energised());
                    shared
                        .alarm_state
                        .store(stall.output.state.code(), Ordering::Relaxed);
                    if let Some(frame) = stall.frame {
                        shared.post(Message::Alarm(frame));
                    }
                    defmt::error!(
                        "estimator stalled after {} samples: relay off, watchdog no longer fed",
                        processed
                    );
                }
            }
        }
        let state = AlarmState::from_code(shared.alarm_state.load(Ordering::Relaxed))
            .unwrap_or(AlarmState::Starting);
        led.set(state.led_on(now_ms as u32));

        while let Some(e) = shared.next_log() {
            log_event(e);
        }
        if checks.is_multiple_of(SUMMARY_EVERY) {
            let load = shared.load();
            defmt::info!(
                "{=u64} s: {} | samples {} missed {} | load {}% peak {}% | CAN sent {} dropped {} replaced {} rejected {} bus errors {} | log dropped {} | events not remembered {}",
                now_ms / 1000,
                state,
                processed,
                missed,
                load.load_pct,
                load.peak_pct,
                shared.can.sent.load(Ordering::Relaxed),
                shared.can.dropped.load(Ordering::Relaxed),
                shared.replaced(),
                shared.can.rejected.load(Ordering::Relaxed),
                shared.can.bus_errors.load(Ordering::Relaxed),
                shared.log_dropped(),
                shared.memory_dropped()
            );
        }
    }
}
