//! The estimator task (high priority): one ADC block per millisecond →
//! front end (codes → units, NE43) → `Monitor::step` → alarm logic →
//! relay → frames due. It never waits for anything but the next block:
//! frames go into the outbox, log lines into a queue.

use core::sync::atomic::Ordering;

use embassy_time::Instant;
use monitor::device::alarm::AlarmLogic;
use monitor::device::deadline::{DeadlineMonitor, SampleClock};
use monitor::protocol::schedule::FrameScheduler;
use monitor::protocol::{AlarmFrame, Command, DetailFrame, HeartbeatFrame, Message, StatusFrame};
use monitor::signal::frontend::{average_scans, Frontend, FrontendConfig};
use monitor::Monitor;

use super::shared::{LogEvent, Shared};
use super::SAMPLE_PERIOD_US;
use crate::board::{BootInfo, CycleCounter, Overrun, RelayOutput, SampleSource};

/// Run the estimator for ever. The relay starts de-energised. The monitor
/// is borrowed (it lives in a static): a 3.6 KiB value moved into the
/// task would be copied through the stack and stored twice.
pub async fn run<S: SampleSource, R: RelayOutput, C: CycleCounter>(
    mut source: S,
    relay: &R,
    cycles: C,
    monitor: &mut Monitor<f32>,
    frontend: FrontendConfig,
    boot: BootInfo,
    shared: &Shared,
) -> ! {
    relay.set_energised(false);
    let mut frontend = Frontend::new(frontend);
    let mut clock = SampleClock::new(SAMPLE_PERIOD_US);
    let mut deadline = DeadlineMonitor::new(C::CYCLES_PER_SAMPLE);
    let mut alarm = AlarmLogic::new();
    let mut schedule = FrameScheduler::new();
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
        let first = first_block.is_none();
        if first {
            let now = Instant::now();
            shared
                .first_sample_ms
                .store(now.as_millis() as u32, Ordering::Release);
            first_block = Some(now);
        }
        let lost = core::mem::take(&mut overran).then(|| {
            let since_first =
                first_block.map_or(0, |t0| Instant::now().duration_since(t0).as_micros());
            let lost = clock.resync(since_first);
            deadline.overrun(lost);
            lost
        });
        let index = clock.next_index();
        let t_ms = clock.t_ms(index);
        if let Some(lost) = lost {
            shared.log(LogEvent::Overrun { t_ms, lost });
        }
        let acquired = frontend.convert(clock.t_s(index), &average_scans(raw));

        if let Some(Command::AcknowledgeAlarm) = shared.commands.try_take() {
            let was_latched = alarm.acknowledge(monitor);
            shared.log(LogEvent::Acknowledged { t_ms, was_latched });
        }
        let status = monitor.step(&acquired.sample);
        for &event in status.events.iter() {
            shared.log(LogEvent::Monitor { t_ms, event });
        }

        let stalled = shared.stalled.load(Ordering::Acquire);
        if stalled {
            alarm.estimator_stalled(t_ms as u32);
        }
        let changed = alarm.update(&status, t_ms as u32);
        let output = alarm.output();
        // Belt and braces: a stalled estimator's relay stays off whatever
        // the alarm logic says.
        relay.set_energised(output.relay_energised() && !stalled);
        if changed || first {
            // The frame and the LED state only change with the output.
            shared
                .alarm_state
                .store(output.state.code(), Ordering::Relaxed);
            shared.set_last_alarm(AlarmFrame::from_logic(&alarm));
        }
        if changed {
            shared.log(LogEvent::Alarm { t_ms, output });
        }

        let due = schedule.due(t_ms, changed);
        if due.alarm {
            shared.post(Message::Alarm(AlarmFrame::from_logic(&alarm)));
        }
        if due.status {
            shared.post(Message::Status(StatusFrame::from_status(&status)));
        }
        if due.detail {
            shared.post(Message::Detail(DetailFrame::from_status(&status)));
        }
        if due.heartbeat {
            let report = deadline.take_report();
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

        deadline.processed(cycles.cycles().wrapping_sub(start));
        shared
            .processed
            .store(deadline.processed_total(), Ordering::Release);
        shared
            .missed
            .store(deadline.missed_total(), Ordering::Release);
    }
}
