//! Program-flow checkpoints: every task that matters marks its checkpoint
//! each time it completes a cycle, and the supervisor verifies, before it
//! feeds the watchdog, that each checkpoint was passed within its own
//! deadline (IEC 61508-2 Table A.10, "program sequence monitoring"). A task
//! that hangs, or a loop that skips its work, withholds the watchdog and is
//! a device fault — the estimator alone keeping time is not enough.

/// A checkpoint: one bit in the set the tasks mark.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Checkpoint {
    /// Bit index (0..16) in the marked set.
    pub bit: u8,
    /// Supervisor checks (10 ms each on the STM32) it may stay unmarked.
    pub deadline_checks: u16,
}

/// The verdict of one supervisor check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Flow {
    /// Every checkpoint within its deadline.
    Ok,
    /// These checkpoints (bit set) missed their deadlines.
    Missed(u16),
}

/// The checkpoint verifier for up to `N` checkpoints.
#[derive(Clone, Debug)]
pub struct FlowMonitor<const N: usize> {
    points: [Checkpoint; N],
    since: [u16; N],
}

impl<const N: usize> FlowMonitor<N> {
    /// A verifier of these checkpoints, all just passed.
    pub const fn new(points: [Checkpoint; N]) -> Self {
        Self {
            points,
            since: [0; N],
        }
    }

    /// One supervisor check with the bits marked since the last one.
    pub fn check(&mut self, marked: u16) -> Flow {
        let mut missed = 0u16;
        for (p, since) in self.points.iter().zip(self.since.iter_mut()) {
            let bit = 1u16 << p.bit;
            if marked & bit != 0 {
                *since = 0;
            } else {
                *since = since.saturating_add(1);
                if *since > p.deadline_checks {
                    missed |= bit;
                }
            }
        }
        if missed == 0 {
            Flow::Ok
        } else {
            Flow::Missed(missed)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ESTIMATOR: Checkpoint = Checkpoint {
        bit: 0,
        deadline_checks: 0,
    };
    const CAN_TX: Checkpoint = Checkpoint {
        bit: 1,
        deadline_checks: 20,
    };

    #[test]
    fn each_checkpoint_has_its_own_deadline() {
        let mut f = FlowMonitor::new([ESTIMATOR, CAN_TX]);
        for _ in 0..20 {
            assert_eq!(f.check(0b01), Flow::Ok, "CAN within its 20 checks");
        }
        assert_eq!(f.check(0b11), Flow::Ok);
        assert_eq!(
            f.check(0b10),
            Flow::Missed(0b01),
            "estimator missed one check"
        );
        for _ in 0..20 {
            f.check(0b01);
        }
        assert_eq!(f.check(0b01), Flow::Missed(0b10), "CAN task hung");
        assert_eq!(
            f.check(0b11),
            Flow::Ok,
            "recovered (the fault is latched by the caller)"
        );
    }
}
