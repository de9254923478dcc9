//! The supervisor's diagnostics of one check period, as one rule: the
//! board's self-test result, the relay read-back, the program-flow
//! checkpoints, the readings of the ADC reference and of the clocks in, the
//! device faults found and whether the watchdog may be fed out. The
//! firmware only reads the inputs and acts on the result.

use super::clock::{ClockCheck, ClockConfig};
use super::flow::{Checkpoint, Flow, FlowMonitor};
use super::reference::{ReferenceCheck, ReferenceConfig};
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
    /// A VREFINT conversion taken in this period (12-bit code; 0 when the
    /// conversion did not complete), if one was due: the ADC reference
    /// check's reading.
    pub vrefint: Option<u16>,
    /// LSI cycles per window of sample time measured in this period, if a
    /// measurement was due and could be taken: the clock cross-check's
    /// reading (the first one is its reference).
    pub lsi_cycles: Option<u32>,
    /// The clock security system has tripped (read every period).
    pub clock_failed: bool,
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
    reference: ReferenceCheck,
    clock: ClockCheck,
}

impl<const N: usize> SupervisorChecks<N> {
    /// Checks of these program-flow checkpoints.
    pub const fn new(checkpoints: [Checkpoint; N]) -> Self {
        Self {
            readback: RelayReadback::new(ReadbackConfig::DEFAULT),
            flow: FlowMonitor::new(checkpoints),
            reference: ReferenceCheck::new(ReferenceConfig::DEFAULT),
            clock: ClockCheck::new(ClockConfig::DEFAULT),
        }
    }

    /// The clock cross-check's reference (LSI cycles per window, the first
    /// measurement), once taken.
    pub const fn clock_reference(&self) -> Option<u32> {
        self.clock.reference()
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
        // Fed only when a reading was taken: the periods between readings
        // (and the start-up before the first) neither pass nor fail.
        if i.vrefint.is_some_and(|code| self.reference.check(code)) {
            found.raise(DeviceFault::AdcReference);
        }
        let clock_fault = match i.lsi_cycles {
            Some(n) => self.clock.check(n, i.clock_failed),
            None => i.clock_failed,
        };
        if clock_fault {
            found.raise(DeviceFault::Clock);
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

    /// A VREFINT code for this VDDA (typical VREFINT, 12 bits).
    fn vrefint_at(vdda: f32) -> u16 {
        (super::super::reference::VREFINT_TYPICAL_V / vdda * 4095.0).round() as u16
    }

    #[test]
    fn vrefint_readings_out_of_range_are_an_adc_reference_fault_after_debounce() {
        let mut c = SupervisorChecks::new([EST]);
        let reading = |code| CheckInputs {
            vrefint: Some(code),
            ..running(1)
        };
        for _ in 0..50 {
            assert_eq!(c.check(&reading(vrefint_at(3.3))).found, DeviceFaults::NONE);
        }
        // VDDA sagged to 2.9 V: ten readings, with periods without a
        // reading in between (they neither count nor reset the count).
        for k in 1..=10 {
            let out = c.check(&reading(vrefint_at(2.9)));
            assert_eq!(
                out.found.contains(DeviceFault::AdcReference),
                k == 10,
                "{k}"
            );
            for _ in 0..9 {
                assert_eq!(c.check(&running(1)).found, DeviceFaults::NONE);
            }
        }
        let mut c = SupervisorChecks::new([EST]);
        for _ in 0..9 {
            c.check(&reading(0));
        }
        assert!(
            c.check(&reading(0))
                .found
                .contains(DeviceFault::AdcReference),
            "a conversion that never completes (code 0) is a fault too"
        );
    }

    #[test]
    fn no_reading_during_start_up_is_no_fault() {
        let mut c = SupervisorChecks::new([EST]);
        for _ in 0..1000 {
            let idle = CheckInputs::default();
            assert_eq!(c.check(&idle).found, DeviceFaults::NONE);
        }
        assert_eq!(c.clock_reference(), None, "no LSI reading, no reference");
    }

    #[test]
    fn a_clock_ratio_off_its_reference_or_a_css_trip_is_a_clock_fault() {
        let mut c = SupervisorChecks::new([EST]);
        let window = |n| CheckInputs {
            lsi_cycles: Some(n),
            ..running(1)
        };
        assert_eq!(c.check(&window(31_500)).found, DeviceFaults::NONE);
        assert_eq!(c.clock_reference(), Some(31_500));
        for _ in 0..10 {
            assert_eq!(c.check(&window(32_000)).found, DeviceFaults::NONE);
            for _ in 0..99 {
                assert_eq!(c.check(&running(1)).found, DeviceFaults::NONE);
            }
        }
        // The sample clock 10.5 times slow (PLL on the HSI): two windows.
        assert_eq!(c.check(&window(330_750)).found, DeviceFaults::NONE);
        assert!(c.check(&window(330_750)).found.contains(DeviceFault::Clock));

        // A trip of the clock security system: at once, with or without
        // an LSI reading in that period.
        let mut c = SupervisorChecks::new([EST]);
        let tripped = CheckInputs {
            clock_failed: true,
            ..running(1)
        };
        assert!(c.check(&tripped).found.contains(DeviceFault::Clock));
        let tripped = CheckInputs {
            lsi_cycles: Some(32_000),
            ..tripped
        };
        assert!(c.check(&tripped).found.contains(DeviceFault::Clock));
        // No LSI edge at all (count 0) as the first reading: no reference.
        let mut c = SupervisorChecks::new([EST]);
        assert!(c.check(&window(0)).found.contains(DeviceFault::Clock));
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
