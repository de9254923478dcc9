//! The estimator task (high priority): moves one ADC block per millisecond
//! through `monitor::device::Estimator` (front end → acknowledge →
//! `Monitor::step` → alarm output → frames due) and carries out what it
//! returns: relay, frames into the outbox, log lines and event-memory
//! records into queues, the sample into the commissioning link's stream.
//! It decides nothing itself and never waits for anything but the next
//! block.

use core::sync::atomic::Ordering;

use embassy_time::Instant;
use monitor::acknowledge::{AckEvent, AckResult};
use monitor::device::estimator::{Estimator, Inputs};
use monitor::params::{ParamError, Params};
use monitor::protocol::{HeartbeatFrame, Message};
use monitor::signal::frontend::FrontendConfig;

use super::link::uptime_ms;
use super::shared::{LogEvent, Shared};
use super::stream::StreamTap;
use super::SAMPLE_PERIOD_US;
use crate::board::{BootInfo, CycleCounter, Overrun, RelayOutput, SampleSource};

/// The pipeline for the installation `params` on a board with the
/// analogue front end `frontend` and the cycle counter `C`.
pub fn pipeline<C: CycleCounter>(
    params: &Params,
    frontend: FrontendConfig,
) -> Result<Estimator<f32>, ParamError> {
    Estimator::new(params, frontend, SAMPLE_PERIOD_US, C::CYCLES_PER_SAMPLE)
}

/// Run the estimator for ever. The relay starts de-energised. The
/// pipeline is borrowed (it lives in a static): a 3.6 KiB value moved
/// into the task would be copied through the stack and stored twice.
pub async fn run<S: SampleSource, R: RelayOutput, C: CycleCounter>(
    mut source: S,
    relay: &R,
    cycles: C,
    estimator: &mut Estimator<f32>,
    mut boot: BootInfo,
    shared: &Shared,
) -> ! {
    relay.set_energised(false);
    let mut tap = StreamTap::new();
    let mut first_block: Option<Instant> = None;
    let mut overran = false;
    let mut dropped_before = shared.can.dropped.load(Ordering::Relaxed);
    loop {
        let raw = match source.next_block().await {
            Ok(raw) => raw,
            Err(Overrun) => {
                overran = true;
                continue;
            }
        };
        let start = cycles.cycles();
        // The sample clock counts samples; the timer is read only to date
        // the first block and to resynchronise after an overrun.
        let t0 = *first_block.get_or_insert_with(|| {
            let now = Instant::now();
            shared
                .first_sample_ms
                .store(now.as_millis() as u32, Ordering::Release);
            now
        });
        let inputs = Inputs {
            command: shared.commands.try_take(),
            stalled: shared.stalled.load(Ordering::Acquire),
            device_faults: shared.device_faults(),
            overrun_at_us: core::mem::take(&mut overran)
                .then(|| Instant::now().duration_since(t0).as_micros()),
        };
        if let Some(identity) = shared.take_monitor(|m| estimator.swap_monitor(m)) {
            boot.identity = identity;
        }
        let out = estimator.on_block(raw, &inputs);
        shared.pass(super::supervisor::ESTIMATOR);
        tap.push(&shared.stream, out.index as u32, &out.sample);
        let t_ms = out.t_ms;
        relay.set_energised(out.relay_energised());

        if let Some(lost) = out.lost {
            shared.log(LogEvent::Overrun { t_ms, lost });
        }
        if let Some(outcome) = out.acknowledged {
            // Accepted, or refused by the acknowledge policy (the CAN
            // receiver records the attempts it refused itself).
            shared.ack_attempt(AckEvent {
                t_ms,
                outcome: outcome.result(),
            });
            if outcome.result() == AckResult::Accepted {
                shared.remember((uptime_ms(), link::EventKind::Acknowledged));
            }
        }
        for &event in out.status.events.iter() {
            if let monitor::Event::AlarmRaised(_) = event {
                // The CAN receiver issues a new challenge.
                shared.alarm_raised();
            }
            shared.log(LogEvent::Monitor { t_ms, event });
            if let Some(kind) = link::memory::event_kind(&event, &out.status) {
                shared.remember((uptime_ms(), kind));
            }
        }
        if out.alarm_changed || out.first {
            // The frame and the LED state only change with the output.
            shared
                .alarm_state
                .store(out.alarm.state.code(), Ordering::Relaxed);
            shared.set_last_alarm(out.alarm_frame);
        }
        if out.alarm_changed {
            shared.log(LogEvent::Alarm {
                t_ms,
                output: out.alarm,
            });
        }

        if out.due.alarm {
            shared.post(Message::Alarm(out.alarm_frame));
        }
        if out.due.status {
            shared.post(Message::Status(out.status_frame()));
        }
        if out.due.detail {
            shared.post(Message::Detail(out.detail_frame()));
        }
        if out.due.sensitivity {
            shared.post(Message::Sensitivity(out.sensitivity_frame()));
        }
        if out.due.heartbeat {
            let report = estimator.take_load_report();
            let dropped = shared.can.dropped.load(Ordering::Relaxed);
            shared.post(Message::Heartbeat(HeartbeatFrame::new(
                boot.reset_cause,
                Instant::now().as_secs(),
                &report,
                dropped.wrapping_sub(dropped_before),
            )));
            dropped_before = dropped;
            shared.set_load(report);
        }
        if out.due.identity {
            shared.post(Message::Identity(boot.identity));
        }
        if out.due.version {
            shared.post(Message::Version(boot.version));
        }

        estimator.processed(cycles.cycles().wrapping_sub(start));
        shared
            .processed
            .store(estimator.processed_total(), Ordering::Release);
        shared
            .missed
            .store(estimator.missed_total(), Ordering::Release);
    }
}
