//! The device pipeline: everything the estimator does with one 1 ms block
//! of ADC data, in one type, so that the firmware's estimator task and the
//! emulated board's host reference (`tests/build/emu.rs`) run the same
//! sequence instead of two copies of it.
//!
//! Per block ([`Estimator::on_block`]): sample clock (resynchronised after
//! an ADC overrun) → front end (ADC codes → [`Sample`](crate::Sample),
//! `signal::frontend`) → an operator's command ([`Monitor::acknowledge`])
//! → [`Monitor::step`] → alarm output ([`AlarmOutput::of`], which also
//! applies the stall) → relay → the frames due (`protocol::schedule`). The
//! caller moves data: it passes the block, the command received and the
//! supervisor's view, and carries out the [`Outputs`] (relay, frames,
//! log). It measures the time spent and reports it back
//! ([`Estimator::processed`]) for the deadline bookkeeping.
//!
//! **Stall.** Once the supervisor has declared the estimator stalled, the
//! output is `EstimatorStalled` for good (the flag is sticky here). The
//! supervisor cannot wait for the estimator to say so (it may never run
//! again): it reports the stall itself through [`stall`], the same
//! rule ([`AlarmOutput::stalled`]) applied to the last frame sent.

use crate::decision::latch::AckOutcome;
use crate::device::alarm::AlarmOutput;
use crate::device::deadline::{DeadlineMonitor, LoadReport, SampleClock};
use crate::device::diagnostics::DeviceFaults;
use crate::device::level_peak::LevelPeak;
use crate::monitor::Monitor;
use crate::params::{ParamError, Params};
use crate::protocol::schedule::{Due, FrameScheduler};
use crate::protocol::{AlarmFrame, Command, DetailFrame, SensitivityFrame, StatusFrame};
use crate::real::Real;
use crate::sample::Sample;
use crate::signal::frontend::{Frontend, FrontendConfig};
use crate::status::Status;

/// What the estimator is given with a block, besides the ADC codes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Inputs {
    /// A command received since the previous block.
    pub command: Option<Command>,
    /// The supervisor declared the estimator stalled.
    pub stalled: bool,
    /// The device's own diagnostics found these faults (latched by the
    /// caller until reset).
    pub device_faults: DeviceFaults,
    /// ADC data was lost before this block, which was taken this long
    /// after the first block, µs: the sample clock resynchronises.
    pub overrun_at_us: Option<u64>,
}

/// What to do after a block.
#[derive(Clone, Debug)]
pub struct Outputs {
    /// Time of this sample on the sample clock, ms.
    pub t_ms: u64,
    /// The sample's index on the sample clock (0 for the first).
    pub index: u64,
    /// The sample the monitor stepped (for the commissioning link's
    /// stream: what the monitor sees, validity included).
    pub sample: Sample,
    /// Samples lost before this one (after an overrun).
    pub lost: Option<u32>,
    /// The command's outcome, if one was given.
    pub acknowledged: Option<AckOutcome>,
    /// The monitor's status.
    pub status: Status,
    /// The alarm output (relay, LED, alarm frame).
    pub alarm: AlarmOutput,
    /// The alarm output changed at this sample.
    pub alarm_changed: bool,
    /// This is the first block.
    pub first: bool,
    /// The alarm frame for the output.
    pub alarm_frame: AlarmFrame,
    /// The frames due at this sample.
    pub due: Due,
    /// The alarm levels the sensitivity frame reports when it is due
    /// (the period's highest; internal, external, l/min).
    pub sensitivity_levels: [Option<f32>; 2],
}

impl Outputs {
    /// Set the fail-safe relay to this.
    pub fn relay_energised(&self) -> bool {
        self.alarm.relay_energised()
    }

    /// The status frame for this sample.
    pub fn status_frame(&self) -> StatusFrame {
        StatusFrame::from_status(&self.status)
    }

    /// The detail frame for this sample.
    pub fn detail_frame(&self) -> DetailFrame {
        DetailFrame::from_status(&self.status)
    }

    /// The sensitivity frame for this sample (when it is due: the alarm
    /// levels are the highest since the previous one).
    pub fn sensitivity_frame(&self) -> SensitivityFrame {
        SensitivityFrame::with_levels(self.sensitivity_levels, &self.status)
    }
}

/// What the supervisor does when it declares the estimator stalled (the
/// estimator may never run again to do it): the last output the estimator
/// showed, [stalled](AlarmOutput::stalled).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stall {
    /// The output now shown (relay, LED).
    pub output: AlarmOutput,
    /// The alarm frame to send (none if the estimator never built one).
    pub frame: Option<AlarmFrame>,
}

/// The stall transition at `t_ms` (sample clock), from the last alarm
/// frame the estimator built (none if it never ran).
pub fn stall(last: Option<AlarmFrame>, t_ms: u32) -> Stall {
    let frame = last.map(|f| f.stalled(t_ms));
    Stall {
        output: frame.map_or(AlarmOutput::BOOT.stalled(), |f| f.output()),
        frame,
    }
}

/// The device pipeline around one [`Monitor`].
#[derive(Clone, Debug)]
pub struct Estimator<T: Real = f32> {
    monitor: Monitor<T>,
    frontend: Frontend,
    clock: SampleClock,
    deadline: DeadlineMonitor,
    schedule: FrameScheduler,
    level_peak: LevelPeak,
    alarm: AlarmOutput,
    changed_at_ms: u32,
    stalled: bool,
    started: bool,
}

impl<T: Real> Estimator<T> {
    /// The pipeline for the installation `params`, the board's analogue
    /// front end, a sample every `sample_period_us` µs and a budget of
    /// `cycles_per_sample` CPU cycles per sample.
    pub fn new(
        params: &Params,
        frontend: FrontendConfig,
        sample_period_us: u32,
        cycles_per_sample: u32,
    ) -> Result<Self, ParamError> {
        Ok(Self {
            monitor: Monitor::new(params)?,
            frontend: Frontend::new(frontend),
            clock: SampleClock::new(sample_period_us),
            deadline: DeadlineMonitor::new(cycles_per_sample),
            schedule: FrameScheduler::new(),
            level_peak: LevelPeak::default(),
            alarm: AlarmOutput::BOOT,
            changed_at_ms: 0,
            stalled: false,
            started: false,
        })
    }

    /// The monitor (read-only: acknowledge through a command).
    pub fn monitor(&self) -> &Monitor<T> {
        &self.monitor
    }

    /// The alarm output now ([`AlarmOutput::BOOT`] before the first block).
    pub fn alarm(&self) -> AlarmOutput {
        self.alarm
    }

    /// Process one block of interleaved ADC scans (`raw`, see
    /// [`average_scans`]).
    pub fn on_block(&mut self, raw: &[u16], inputs: &Inputs) -> Outputs {
        let first = !self.started;
        self.started = true;
        let lost = inputs.overrun_at_us.map(|us| {
            let lost = self.clock.resync(us);
            self.deadline.overrun(lost);
            lost
        });
        let index = self.clock.next_index();
        let t_ms = self.clock.t_ms(index);
        let acquired = self.frontend.convert_scans(self.clock.t_s(index), raw);
        let acknowledged = inputs.command.map(|c| match c {
            Command::AcknowledgeAlarm => self.monitor.acknowledge(),
        });
        let sample = acquired.sample;
        let status = self.monitor.step(&sample);

        self.stalled |= inputs.stalled;
        let alarm = AlarmOutput::of(&status, self.stalled).with_device_faults(inputs.device_faults);
        let alarm_changed = alarm != self.alarm;
        if alarm_changed {
            self.alarm = alarm;
            self.changed_at_ms = t_ms as u32;
        }
        let due = self.schedule.due(t_ms, alarm_changed);
        let levels = status.published_alarm_levels();
        self.level_peak.observe(levels);
        let sensitivity_levels = if due.sensitivity {
            self.level_peak.take(levels)
        } else {
            levels
        };
        Outputs {
            t_ms,
            index,
            sample,
            lost,
            acknowledged,
            status,
            alarm,
            alarm_changed,
            first,
            alarm_frame: AlarmFrame::new(&alarm, self.changed_at_ms),
            due,
            sensitivity_levels,
        }
    }

    /// Restart on another monitor (a new parameter set: its filters warm
    /// up again, latched alarms are gone), built elsewhere with
    /// `Monitor::new` — on the device by a low-priority task, so that
    /// neither its construction time nor its stack fall on the estimator.
    /// `monitor` gets the old one. The sample clock, the deadline figures
    /// and the frame schedule run on; the alarm levels' peak starts afresh.
    pub fn swap_monitor(&mut self, monitor: &mut Monitor<T>) {
        core::mem::swap(&mut self.monitor, monitor);
        // The old set's alarm levels say nothing about the new one's.
        self.level_peak = LevelPeak::default();
    }

    /// The block just processed took `busy_cycles`; returns true if that
    /// missed the deadline.
    pub fn processed(&mut self, busy_cycles: u32) -> bool {
        self.deadline.processed(busy_cycles)
    }

    /// Samples processed since start (wrapping), for the supervisor.
    pub fn processed_total(&self) -> u32 {
        self.deadline.processed_total()
    }

    /// Samples missed since start (wrapping), for the supervisor.
    pub fn missed_total(&self) -> u32 {
        self.deadline.missed_total()
    }

    /// The load figures since the previous report (for the heartbeat);
    /// starts a new period.
    pub fn take_load_report(&mut self) -> LoadReport {
        self.deadline.take_report()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::alarm::AlarmState;
    use crate::leak::LeakSet;
    use crate::signal::frontend::{tests::config, Input};
    use crate::Params;

    fn estimator() -> Estimator<f32> {
        Estimator::new(&Params::nominal(), config(Input::NotFitted), 1000, 168_000).unwrap()
    }

    #[test]
    fn swap_monitor_restarts_the_monitor_but_not_the_clock() {
        let mut e = estimator();
        let first = e.on_block(&[0; 28], &Inputs::default()).status;
        for _ in 0..200 {
            e.on_block(&[0; 28], &Inputs::default());
        }
        let mut old = e.clone();
        let mut fresh = Monitor::new(&Params::nominal()).unwrap();
        e.swap_monitor(&mut fresh);
        let out = e.on_block(&[0; 28], &Inputs::default());
        assert_eq!(
            (out.index, out.t_ms),
            (201, 201),
            "the sample clock runs on"
        );
        assert!(!out.first);
        // The monitor is where a fresh one is after its first sample.
        assert_eq!(out.status.events, first.events);
        assert_eq!(out.status.health, first.health);
        let kept = old.on_block(&[0; 28], &Inputs::default()).status;
        assert!(kept.events != first.events || kept.health != first.health);
    }

    #[test]
    fn estimator_first_block_starts_relay_off_and_sends_every_frame() {
        let mut e = estimator();
        assert_eq!(e.alarm(), AlarmOutput::BOOT);
        let out = e.on_block(&[0; 28], &Inputs::default());
        assert!(out.first && out.t_ms == 0 && out.lost.is_none());
        assert!(!out.relay_energised());
        assert!(out.due.alarm && out.due.status && out.due.detail && out.due.heartbeat);
        assert!(out.due.sensitivity);
        let out = e.on_block(&[0; 28], &Inputs::default());
        assert!(!out.first);
        assert_eq!(out.t_ms, 1);
    }

    #[test]
    fn estimator_stall_is_sticky_and_keeps_the_relay_off() {
        let mut e = estimator();
        let before = e.on_block(&[0; 28], &Inputs::default()).alarm_frame;
        let stalled = Inputs {
            stalled: true,
            ..Inputs::default()
        };
        let out = e.on_block(&[0; 28], &stalled);
        assert_eq!(out.alarm.state, AlarmState::EstimatorStalled);
        assert!(out.alarm_changed && out.due.alarm);
        assert!(!out.relay_energised());
        assert_eq!(out.alarm_frame.changed_at_ms, 1);
        // The supervisor's flag dropped (it never does): still stalled.
        let out = e.on_block(&[0; 28], &Inputs::default());
        assert_eq!(out.alarm.state, AlarmState::EstimatorStalled);
        assert!(!out.alarm_changed);
        // The supervisor's own report, from the frame before the stall, is
        // the same frame.
        let s = stall(Some(before), 1);
        let frame = s.frame.unwrap();
        assert_eq!(frame, out.alarm_frame);
        assert_eq!(s.output, out.alarm);
        assert_eq!(frame.latched, LeakSet::NONE);
        let s = stall(None, 1);
        assert_eq!(s.frame, None);
        assert_eq!(s.output.state, AlarmState::EstimatorStalled);
        assert!(!s.output.relay_energised());
    }

    #[test]
    fn estimator_shows_a_device_fault_from_the_next_block() {
        use crate::device::diagnostics::{DeviceFault, DeviceFaults};
        let mut e = estimator();
        e.on_block(&[0; 28], &Inputs::default());
        let mut faults = DeviceFaults::NONE;
        faults.raise(DeviceFault::RelayReadback);
        let inputs = Inputs {
            device_faults: faults,
            ..Inputs::default()
        };
        let out = e.on_block(&[0; 28], &inputs);
        assert_eq!(out.alarm.state, AlarmState::DeviceFault);
        assert!(out.alarm_changed && out.due.alarm && !out.relay_energised());
        assert_eq!(
            out.alarm_frame.device_fault,
            DeviceFault::RelayReadback.code()
        );
    }

    #[test]
    fn estimator_applies_an_acknowledge_command_and_resyncs_after_an_overrun() {
        let mut e = estimator();
        e.on_block(&[0; 28], &Inputs::default());
        let ack = Inputs {
            command: Some(Command::AcknowledgeAlarm),
            ..Inputs::default()
        };
        let out = e.on_block(&[0; 28], &ack);
        // Nothing latched: the acknowledge policy refuses it, and says so.
        assert_eq!(
            out.acknowledged,
            Some(AckOutcome::Refused(
                crate::acknowledge::AckRejected::NothingLatched
            ))
        );
        let overrun = Inputs {
            overrun_at_us: Some(10_000),
            ..Inputs::default()
        };
        let out = e.on_block(&[0; 28], &overrun);
        assert_eq!((out.t_ms, out.lost), (10, Some(8)));
        assert!(!e.processed(1000));
        assert_eq!(e.processed_total(), 1);
        assert_eq!(e.missed_total(), 8);
    }
}
