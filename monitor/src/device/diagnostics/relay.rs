//! Relay read-back: the relay driver's output (or an auxiliary contact)
//! is read back on an input pin. Commanded and read state must agree once
//! the relay has had its operate time; a relay that stays energised when
//! commanded off (welded contact, shorted driver) defeats the fail-safe
//! output, so it is a device fault.

/// Limits of the read-back check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReadbackConfig {
    /// Consecutive disagreeing checks tolerated: the relay's operate or
    /// release time (≤ 10 ms for a typical PCB relay) at one check per
    /// 10 ms, plus one.
    pub settle_checks: u8,
}

impl ReadbackConfig {
    /// Two 10 ms checks.
    pub const DEFAULT: Self = Self { settle_checks: 2 };
}

/// The read-back check.
#[derive(Clone, Debug)]
pub struct RelayReadback {
    cfg: ReadbackConfig,
    disagree: u8,
}

impl RelayReadback {
    /// A check with no disagreement yet.
    pub const fn new(cfg: ReadbackConfig) -> Self {
        Self { cfg, disagree: 0 }
    }

    /// Compare the commanded and the read state; true when they have
    /// disagreed for longer than the settle time.
    pub fn check(&mut self, commanded: bool, read_back: bool) -> bool {
        if commanded == read_back {
            self.disagree = 0;
        } else {
            self.disagree = self.disagree.saturating_add(1);
        }
        self.disagree > self.cfg.settle_checks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn switching_settles_a_stuck_relay_is_a_fault() {
        let mut r = RelayReadback::new(ReadbackConfig::DEFAULT);
        assert!(!r.check(true, false), "operating");
        assert!(!r.check(true, false));
        assert!(!r.check(true, true), "operated");
        // Commanded off, stays on (welded contact).
        assert!(!r.check(false, true));
        assert!(!r.check(false, true));
        assert!(r.check(false, true));
    }
}
