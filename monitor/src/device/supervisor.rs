//! Supervision of the estimator from the low-priority side: the watchdog
//! is fed only while the estimator keeps its deadline, and an estimator
//! that stops producing samples is declared stalled (relay off; the
//! watchdog then resets the board).
//!
//! Called every check period (10 ms on the STM32) with the estimator's
//! running totals of processed and missed samples.

/// Supervisor thresholds, in check periods and samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SupervisorConfig {
    /// Consecutive checks without a processed sample that mean stalled.
    pub stall_checks: u32,
    /// Missed samples within one check period still tolerated.
    pub max_missed_per_check: u32,
    /// Checks allowed before the very first sample (start-up).
    pub startup_checks: u32,
}

impl SupervisorConfig {
    /// For 10 ms checks of a 1 kHz estimator: stalled after 20 ms without
    /// a sample, deadline kept while at most 2 of ~10 samples per check
    /// are missed, 500 ms for the first sample.
    pub const DEFAULT: Self = Self {
        stall_checks: 2,
        max_missed_per_check: 2,
        startup_checks: 50,
    };
}

/// What to do after a check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Supervision {
    /// The estimator keeps its deadline: feed the watchdog.
    Feed,
    /// Deadline not kept in this period: do not feed (the watchdog resets
    /// the board if this lasts longer than its timeout).
    Withhold,
    /// The estimator stalled: relay off, never feed again.
    Stalled,
}

/// The supervisor.
#[derive(Clone, Debug)]
pub struct Supervisor {
    cfg: SupervisorConfig,
    last: Option<(u32, u32)>,
    idle_checks: u32,
    stalled: bool,
}

impl Supervisor {
    /// A supervisor that has seen no sample yet.
    pub const fn new(cfg: SupervisorConfig) -> Self {
        Self {
            cfg,
            last: None,
            idle_checks: 0,
            stalled: false,
        }
    }

    /// Check the estimator's running totals (wrapping counters).
    pub fn check(&mut self, processed: u32, missed: u32) -> Supervision {
        if self.stalled {
            return Supervision::Stalled;
        }
        let verdict = match self.last {
            None if processed == 0 => {
                self.idle_checks += 1;
                if self.idle_checks > self.cfg.startup_checks {
                    Supervision::Stalled
                } else {
                    Supervision::Feed
                }
            }
            None => {
                self.idle_checks = 0;
                Supervision::Feed
            }
            Some((p0, m0)) => {
                if processed == p0 {
                    self.idle_checks += 1;
                    if self.idle_checks >= self.cfg.stall_checks {
                        Supervision::Stalled
                    } else {
                        Supervision::Withhold
                    }
                } else {
                    self.idle_checks = 0;
                    if missed.wrapping_sub(m0) > self.cfg.max_missed_per_check {
                        Supervision::Withhold
                    } else {
                        Supervision::Feed
                    }
                }
            }
        };
        if processed != 0 || self.last.is_some() {
            self.last = Some((processed, missed));
        }
        self.stalled = verdict == Supervision::Stalled;
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feeds_while_the_estimator_keeps_its_deadline() {
        let mut s = Supervisor::new(SupervisorConfig::DEFAULT);
        let mut done = 0u32;
        for _ in 0..100 {
            done = done.wrapping_add(10);
            assert_eq!(s.check(done, 0), Supervision::Feed);
        }
        // Counters wrap without harm.
        let mut s = Supervisor::new(SupervisorConfig::DEFAULT);
        assert_eq!(s.check(u32::MAX - 5, 7), Supervision::Feed);
        assert_eq!(s.check(4, 9), Supervision::Feed);
    }

    #[test]
    fn withholds_when_too_many_samples_are_missed() {
        let mut s = Supervisor::new(SupervisorConfig::DEFAULT);
        assert_eq!(s.check(10, 0), Supervision::Feed);
        assert_eq!(s.check(17, 2), Supervision::Feed);
        assert_eq!(s.check(22, 5), Supervision::Withhold);
        assert_eq!(s.check(32, 5), Supervision::Feed, "recovered");
    }

    #[test]
    fn no_progress_is_a_stall_for_good() {
        let mut s = Supervisor::new(SupervisorConfig::DEFAULT);
        assert_eq!(s.check(10, 0), Supervision::Feed);
        assert_eq!(s.check(10, 0), Supervision::Withhold);
        assert_eq!(s.check(10, 0), Supervision::Stalled);
        assert_eq!(s.check(20, 0), Supervision::Stalled, "stays stalled");
    }

    #[test]
    fn start_up_grace_then_stall_if_no_sample_ever_arrives() {
        let cfg = SupervisorConfig::DEFAULT;
        let mut s = Supervisor::new(cfg);
        for _ in 0..cfg.startup_checks {
            assert_eq!(s.check(0, 0), Supervision::Feed);
        }
        assert_eq!(s.check(0, 0), Supervision::Stalled);
        // A first sample within the grace period starts normal checks.
        let mut s = Supervisor::new(cfg);
        assert_eq!(s.check(0, 0), Supervision::Feed);
        assert_eq!(s.check(3, 0), Supervision::Feed);
        assert_eq!(s.check(3, 0), Supervision::Withhold);
    }
}
