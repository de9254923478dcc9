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
//! **Acknowledge policy.** Whether a request is accepted is decided in
//! [`Latch::accepts`], and only there. Today every request is; a hold-off
//! after the alarm, a rate limit or an authenticated source plug in there
//! (they may need the request's time or origin: extend
//! [`Latch::acknowledge`]'s arguments and [`AckOutcome::Refused`] is
//! already handled by every caller).

use crate::leak::LeakSet;

/// What became of an acknowledge request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckOutcome {
    /// Accepted: these leaks were latched and are cleared (possibly none).
    Cleared(LeakSet),
    /// Refused by the acknowledge policy: the latch is unchanged.
    Refused,
}

impl AckOutcome {
    /// Did the request clear a latched leak?
    pub const fn cleared_a_leak(self) -> bool {
        matches!(self, Self::Cleared(s) if !s.is_empty())
    }
}

/// The latch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Latch {
    latched: LeakSet,
}

impl Latch {
    /// Nothing latched.
    pub const fn new() -> Self {
        Self {
            latched: LeakSet::NONE,
        }
    }

    /// The latched leaks.
    pub const fn latched(&self) -> LeakSet {
        self.latched
    }

    /// Leaks `found` by the evidence: latched with those already latched.
    /// Returns the latched set when it grew (an alarm raised or escalated).
    pub fn raise(&mut self, found: LeakSet) -> Option<LeakSet> {
        let merged = self.latched.union(found);
        (merged != self.latched).then(|| {
            self.latched = merged;
            merged
        })
    }

    /// The acknowledge policy: is a request accepted now? Every request
    /// is, today. This is the place for a hold-off, a rate limit or an
    /// authentication check.
    const fn accepts(&self) -> bool {
        true
    }

    /// An operator's acknowledgement: if [accepted](Self::accepts), clear
    /// the latch.
    pub fn acknowledge(&mut self) -> AckOutcome {
        if !self.accepts() {
            return AckOutcome::Refused;
        }
        AckOutcome::Cleared(core::mem::take(&mut self.latched))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latch_raises_escalates_and_ignores_what_it_holds() {
        let mut l = Latch::new();
        assert_eq!(l.raise(LeakSet::NONE), None);
        assert_eq!(l.raise(LeakSet::INTERNAL), Some(LeakSet::INTERNAL));
        assert_eq!(l.raise(LeakSet::INTERNAL), None, "already latched");
        assert_eq!(l.raise(LeakSet::EXTERNAL), Some(LeakSet::BOTH), "escalates");
        assert_eq!(l.raise(LeakSet::INTERNAL), None, "never de-escalates");
        assert_eq!(l.latched(), LeakSet::BOTH);
    }

    #[test]
    fn latch_is_cleared_only_by_acknowledgement() {
        let mut l = Latch::new();
        assert_eq!(l.acknowledge(), AckOutcome::Cleared(LeakSet::NONE));
        assert!(!l.acknowledge().cleared_a_leak());
        l.raise(LeakSet::EXTERNAL);
        let ack = l.acknowledge();
        assert_eq!(ack, AckOutcome::Cleared(LeakSet::EXTERNAL));
        assert!(ack.cleared_a_leak());
        assert_eq!(l.latched(), LeakSet::NONE);
        assert_eq!(
            l.raise(LeakSet::EXTERNAL),
            Some(LeakSet::EXTERNAL),
            "raised anew"
        );
    }
}
