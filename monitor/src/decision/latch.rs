//! The leak-alarm latch: the one place that remembers which leak alarms
//! were raised and decides whether an acknowledgement clears them.
//!
//! A raised leak stays latched — through sensor faults, data gaps and
//! filter restarts — until an operator acknowledges it. A new leak while
//! one is latched escalates (internal + external = both). Everything that
//! shows an alarm (the verdict, the `ALARM_LATCHED` flag, the relay, the
//! CAN alarm frame) reads this latch through [`Status`](crate::Status);
//! nothing else latches.
//!
//! **Acknowledge policy.** Whether a request is accepted is decided here,
//! and only here, by [`AckPolicy`](super::acknowledge::AckPolicy) (see
//! `decision/acknowledge.rs` and `docs/acknowledge.md`): not within 10 s
//! of the alarm being raised, at most one per 60 s, and after an accepted
//! one the relay stays off until 30 s of conclusive healthy verdicts
//! ([`Latch::relay_permitted`]). Times are the monitor's sample times, ms.
//! Whether the request came from an authentic source is checked before
//! (`protocol::gate`).

use super::acknowledge::{sample_ms, AckPolicy, AckRejected, AckResult, AckTiming};
use crate::leak::LeakSet;

/// What became of an acknowledge request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckOutcome {
    /// Accepted: these leaks were latched and are cleared.
    Cleared(LeakSet),
    /// Refused by the acknowledge policy: the latch is unchanged.
    Refused(AckRejected),
}

impl AckOutcome {
    /// Did the request clear a latched leak?
    pub const fn cleared_a_leak(self) -> bool {
        matches!(self, Self::Cleared(s) if !s.is_empty())
    }

    /// As an acknowledge event's result.
    pub const fn result(self) -> AckResult {
        match self {
            Self::Cleared(_) => AckResult::Accepted,
            Self::Refused(r) => AckResult::Rejected(r),
        }
    }
}

/// The latch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Latch {
    latched: LeakSet,
    policy: AckPolicy,
}

impl Latch {
    /// Nothing latched; the documented acknowledge timing.
    pub const fn new() -> Self {
        Self::with_timing(AckTiming::DEFAULT)
    }

    /// Nothing latched; acknowledge `timing` (tests and studies).
    pub const fn with_timing(timing: AckTiming) -> Self {
        Self {
            latched: LeakSet::NONE,
            policy: AckPolicy::new(timing),
        }
    }

    /// The latched leaks.
    pub const fn latched(&self) -> LeakSet {
        self.latched
    }

    /// Leaks `found` by the evidence at sample time `t_s` (s): latched with
    /// those already latched. Returns the latched set when it grew (an
    /// alarm raised or escalated: the acknowledge hold-off starts again).
    pub fn raise(&mut self, found: LeakSet, t_s: f64) -> Option<LeakSet> {
        let merged = self.latched.union(found);
        (merged != self.latched).then(|| {
            self.latched = merged;
            self.policy.raised(sample_ms(t_s));
            merged
        })
    }

    /// An operator's (authentic) acknowledgement at `t_ms`: if the policy
    /// accepts it, clear the latch.
    pub fn acknowledge(&mut self, t_ms: u64) -> AckOutcome {
        let event = self.policy.request(t_ms, !self.latched.is_empty());
        match event.outcome {
            AckResult::Accepted => AckOutcome::Cleared(core::mem::take(&mut self.latched)),
            AckResult::Rejected(r) => AckOutcome::Refused(r),
        }
    }

    /// The verdict at sample time `t_s` (s) was a conclusive healthy one
    /// (`healthy`) or not: counts towards an accepted acknowledge's
    /// evidence period.
    pub fn verdict(&mut self, t_s: f64, healthy: bool) {
        // Outside an evidence period there is nothing to count: the time is
        // converted to ms only inside one (f64 is soft-float on the M4F,
        // and this runs every sample).
        if !self.policy.relay_permitted() {
            self.policy.verdict(sample_ms(t_s), healthy);
        }
    }

    /// May the relay be energised as far as acknowledgement goes? False
    /// from an accepted acknowledge until its evidence period completed.
    pub const fn relay_permitted(&self) -> bool {
        self.policy.relay_permitted()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latch_raises_escalates_and_ignores_what_it_holds() {
        let mut l = Latch::new();
        assert_eq!(l.raise(LeakSet::NONE, 0.0), None);
        assert_eq!(l.raise(LeakSet::INTERNAL, 0.0), Some(LeakSet::INTERNAL));
        assert_eq!(l.raise(LeakSet::INTERNAL, 0.0), None, "already latched");
        assert_eq!(
            l.raise(LeakSet::EXTERNAL, 0.0),
            Some(LeakSet::BOTH),
            "escalates"
        );
        assert_eq!(l.raise(LeakSet::INTERNAL, 0.0), None, "never de-escalates");
        assert_eq!(l.latched(), LeakSet::BOTH);
    }

    #[test]
    fn latch_is_cleared_only_by_an_accepted_acknowledgement() {
        use crate::decision::acknowledge::{EVIDENCE_MS, HOLD_OFF_MS};
        let mut l = Latch::new();
        assert_eq!(
            l.acknowledge(0),
            AckOutcome::Refused(AckRejected::NothingLatched)
        );
        l.raise(LeakSet::EXTERNAL, 1.0);
        let early = l.acknowledge(1_000 + HOLD_OFF_MS - 1);
        assert_eq!(early, AckOutcome::Refused(AckRejected::HoldOff));
        assert!(!early.cleared_a_leak());
        assert_eq!(l.latched(), LeakSet::EXTERNAL);
        let ack = l.acknowledge(1_000 + HOLD_OFF_MS);
        assert_eq!(ack, AckOutcome::Cleared(LeakSet::EXTERNAL));
        assert!(ack.cleared_a_leak() && ack.result() == AckResult::Accepted);
        assert_eq!(l.latched(), LeakSet::NONE);
        // Cleared, but the relay waits for the evidence period.
        assert!(!l.relay_permitted());
        let t0 = 1_000 + HOLD_OFF_MS + 1;
        for t in t0..=t0 + EVIDENCE_MS {
            l.verdict(t as f64 / 1000.0, true);
        }
        assert!(l.relay_permitted());
        assert_eq!(
            l.raise(LeakSet::EXTERNAL, (t0 + EVIDENCE_MS) as f64 / 1000.0),
            Some(LeakSet::EXTERNAL),
            "raised anew"
        );
    }
}
