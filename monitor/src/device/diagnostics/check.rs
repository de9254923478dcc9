//! The supervisor's diagnostics of one check period, as one rule: the
//! board's self-test result, the relay read-back and the program-flow
//! checkpoints in, the device faults found and whether the watchdog may be
//! fed out. The firmware only reads the inputs and acts on the result.

use super::flow::{Checkpoint, Flow, FlowMonitor};
use super::relay::{ReadbackConfig, RelayReadback};
use super::{DeviceFault, DeviceFaults};

/// What the supervisor read in one check period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CheckInputs {
    /// The board's background self-test found this fault.
    pub self_test: Option<DeviceFault>,
    /// What the relay is driven to.
    pub relay_commanded: bool,
    /// What the relay reads back.
    pub relay_read_back: bool,
    /// Checkpoints passed since the previous check (bit per checkpoint).
    pub checkpoints: u16,
    /// The estimator has produced (or missed) a sample: before that the
    /// supervisor's start-up grace applies.
    pub started: bool,
    /// The estimator was declared stalled: the stall is the reaction, its
    /// checkpoint stays unmet.
    pub stalled: bool,
}

/// The outcome of one check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CheckOutcome {
    /// Faults found in this check (latching is the caller's).
    pub found: DeviceFaults,
    /// Every checkpoint was met: the watchdog may be fed.
    pub flow_kept: bool,
}

/// The supervisor's diagnostics state.
#[derive(Clone, Debug)]
pub struct SupervisorChecks<const N: usize> {
    readback: RelayReadback,
    flow: FlowMonitor<N>,
}

impl<const N: usize> SupervisorChecks<N> {
    /// Checks of these program-flow checkpoints.
    pub const fn new(checkpoints: [Checkpoint; N]) -> Self {
        Self {
            readback: RelayReadback::new(ReadbackConfig::DEFAULT),
            flow: FlowMonitor::new(checkpoints),
        }
    }

    /// One check period.
    pub fn check(&mut self, i: &CheckInputs) -> CheckOutcome {
        let mut found = DeviceFaults::NONE;
        if let Some(f) = i.self_test {
            found.raise(f);
        }
        if self.readback.check(i.relay_commanded, i.relay_read_back) {
            found.raise(DeviceFault::RelayReadback);
        }
        let flow_kept = if !i.started || i.stalled {
            true
        } else {
            match self.flow.check(i.checkpoints) {
                Flow::Ok => true,
                Flow::Missed(_) => {
                    found.raise(DeviceFault::ProgramFlow);
                    false
                }
            }
        };
        CheckOutcome { found, flow_kept }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EST: Checkpoint = Checkpoint {
        bit: 0,
        deadline_checks: 1,
    };

    fn running(checkpoints: u16) -> CheckInputs {
        CheckInputs {
            checkpoints,
            started: true,
            ..CheckInputs::default()
        }
    }

    #[test]
    fn a_missed_checkpoint_is_a_flow_fault_only_once_started_and_not_after_a_stall() {
        let mut c = SupervisorChecks::new([EST]);
        for _ in 0..5 {
            let idle = CheckInputs::default();
            assert_eq!(c.check(&idle).found, DeviceFaults::NONE, "start-up grace");
        }
        assert!(c.check(&running(1)).flow_kept);
        assert!(c.check(&running(0)).flow_kept, "within its deadline");
        let out = c.check(&running(0));
        assert!(!out.flow_kept);
        assert!(out.found.contains(DeviceFault::ProgramFlow));
        let stalled = CheckInputs {
            stalled: true,
            ..running(0)
        };
        assert_eq!(c.check(&stalled).found, DeviceFaults::NONE);
    }

    #[test]
    fn self_test_and_read_back_faults_are_reported() {
        let mut c = SupervisorChecks::new([EST]);
        let flash = CheckInputs {
            self_test: Some(DeviceFault::FlashImage),
            ..running(1)
        };
        assert!(c.check(&flash).found.contains(DeviceFault::FlashImage));
        let welded = CheckInputs {
            relay_read_back: true,
            ..running(1)
        };
        let found = (0..3).fold(DeviceFaults::NONE, |mut acc, _| {
            if c.check(&welded).found.any() {
                acc.raise(DeviceFault::RelayReadback);
            }
            acc
        });
        assert!(found.contains(DeviceFault::RelayReadback));
    }
}
