//! The acknowledge policy: when an operator's acknowledgement may clear a
//! latched leak alarm, and when the relay may come back afterwards. A pure
//! state machine on the sample clock (ms); the owner of the alarm latch
//! calls it and acts on its answers. See `docs/acknowledge.md`.
//!
//! Rules:
//!
//! 1. **Hold-off.** A latched alarm cannot be acknowledged during the
//!    first [`HOLD_OFF_MS`] after it was raised (or escalated, or raised
//!    again).
//! 2. **Rate.** At most one acknowledge is accepted per
//!    [`MIN_INTERVAL_MS`].
//! 3. **Evidence before the relay.** An accepted acknowledge clears the
//!    latch (the monitor starts collecting leak evidence afresh), but the
//!    relay stays off until the monitor has given [`EVIDENCE_MS`] of
//!    uninterrupted *conclusive healthy* verdicts. A leak that is still
//!    there is raised again long before that (see the constants), and
//!    re-latches; an inconclusive or faulted monitor never completes the
//!    period.
//! 4. **Nothing twice.** An acknowledge while the evidence period runs
//!    does nothing (it neither clears anything nor restarts the period).
//! 5. **Every attempt is an event** ([`AckEvent`]): accepted, or rejected
//!    with its reason, including the transport and authentication
//!    reasons found before the policy is asked ([`AckPolicy::rejected`]).
//!
//! The only way the relay is energised after an acknowledge is therefore:
//! accepted acknowledge, then [`EVIDENCE_MS`] of conclusive healthy
//! verdicts, then healthy — exactly as after boot, where the relay also
//! waits for a conclusive healthy verdict.

/// Hold-off after an alarm is raised before it may be acknowledged, ms.
///
/// Why 10 s: a reset must be a deliberate act after the cause was looked
/// at (ISO 13849-1, manual reset), not a reflex or a controller that
/// acknowledges whatever it sees. In 10 s the alarm frame has been sent at
/// once and refreshed ten times, so every HMI on the bus shows it, and a
/// controller that acknowledges automatically is slowed to a rate where it
/// cannot keep the alarm down (with rule 2 and the evidence period).
pub const HOLD_OFF_MS: u64 = 10_000;

/// Shortest time between two accepted acknowledges, ms.
///
/// Why 60 s: each accepted acknowledge restarts the monitor's leak
/// evidence; bounding their rate bounds how often a persisting leak can
/// be un-latched (a flood of valid acknowledges gains one per minute,
/// and the evidence period keeps the relay off through each), and leaves
/// the operator enough attempts after a real repair.
pub const MIN_INTERVAL_MS: u64 = 60_000;

/// Uninterrupted conclusive healthy verdicts needed after an accepted
/// acknowledge before the relay may be energised again, ms.
///
/// Why 30 s: a leak that persists is raised again after the monitor's
/// debounce, 2.5 s of quiet evidence time at 1.2× the alarm level with
/// the reference parameters (0.5 s at 2×), so 30 s is an order of
/// magnitude of margin; it equals the monitor's recent-evidence memory
/// (`filter.evidence_memory_s`), so the verdicts that complete it rest on
/// evidence gathered after the acknowledge. Verdicts that are not
/// `healthy` (inconclusive, sensor fault, leak) restart it.
pub const EVIDENCE_MS: u64 = 30_000;

/// The policy's times (the constants above unless a test needs others).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AckTiming {
    /// See [`HOLD_OFF_MS`].
    pub hold_off_ms: u64,
    /// See [`MIN_INTERVAL_MS`].
    pub min_interval_ms: u64,
    /// See [`EVIDENCE_MS`].
    pub evidence_ms: u64,
}

impl AckTiming {
    /// The documented times.
    pub const DEFAULT: Self = Self {
        hold_off_ms: HOLD_OFF_MS,
        min_interval_ms: MIN_INTERVAL_MS,
        evidence_ms: EVIDENCE_MS,
    };
}

impl Default for AckTiming {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why an acknowledge attempt was not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckRejected {
    /// Policy: no leak alarm is latched.
    NothingLatched,
    /// Policy: the alarm was raised less than [`HOLD_OFF_MS`] ago.
    HoldOff,
    /// Policy: an acknowledge was accepted less than [`MIN_INTERVAL_MS`]
    /// ago.
    RateLimited,
    /// Policy: an accepted acknowledge's evidence period is running.
    EvidencePending,
    /// Authentication: the tag is right for no recent challenge (forged,
    /// or a frame recorded long ago).
    BadMac,
    /// Authentication: the tag answers the previous challenge (a recorded
    /// frame played again, or a controller that raced a rotation).
    StaleChallenge,
    /// E2E: the same counter as the previous authentic command.
    Repeated,
    /// E2E: wrong length, CRC, counter range or command code.
    Malformed,
    /// E2E: the command channel's state machine is INVALID (too many bad
    /// frames in its window).
    ChannelInvalid,
    /// Too many command frames to check: this one was dropped unchecked.
    Busy,
}

/// The outcome of one acknowledge attempt.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckResult {
    /// The latched alarm was cleared; the evidence period starts.
    Accepted,
    /// Nothing changed.
    Rejected(AckRejected),
}

impl AckResult {
    /// Every outcome, in wire-code order (codes 1..; 0 is "none yet").
    pub const ALL: [AckResult; 11] = [
        Self::Accepted,
        Self::Rejected(AckRejected::NothingLatched),
        Self::Rejected(AckRejected::HoldOff),
        Self::Rejected(AckRejected::RateLimited),
        Self::Rejected(AckRejected::EvidencePending),
        Self::Rejected(AckRejected::BadMac),
        Self::Rejected(AckRejected::StaleChallenge),
        Self::Rejected(AckRejected::Repeated),
        Self::Rejected(AckRejected::Malformed),
        Self::Rejected(AckRejected::ChannelInvalid),
        Self::Rejected(AckRejected::Busy),
    ];

    /// Wire code (challenge frame `AckResult`; 0 means no attempt yet).
    pub fn code(self) -> u8 {
        Self::ALL
            .iter()
            .position(|&o| o == self)
            .map_or(0, |i| i as u8 + 1)
    }

    /// The outcome of a wire code (`None` for 0 and unknown codes).
    pub fn from_code(code: u8) -> Option<Self> {
        (code as usize)
            .checked_sub(1)
            .and_then(|i| Self::ALL.get(i).copied())
    }

    /// Lower-case name (logs, DBC value table).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Accepted => "accepted",
            Self::Rejected(r) => match r {
                AckRejected::NothingLatched => "nothing_latched",
                AckRejected::HoldOff => "hold_off",
                AckRejected::RateLimited => "rate_limited",
                AckRejected::EvidencePending => "evidence_pending",
                AckRejected::BadMac => "bad_mac",
                AckRejected::StaleChallenge => "stale_challenge",
                AckRejected::Repeated => "repeated",
                AckRejected::Malformed => "malformed",
                AckRejected::ChannelInvalid => "channel_invalid",
                AckRejected::Busy => "busy",
            },
        }
    }
}

/// One acknowledge attempt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AckEvent {
    /// When, ms on the sample clock.
    pub t_ms: u64,
    /// What came of it.
    pub outcome: AckResult,
}

/// Where the policy stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckPhase {
    /// No alarm raised since boot or since the last evidence period ended.
    Idle,
    /// An alarm was raised at `raised_ms` (it may have been cleared by
    /// other means since; the latch owner knows).
    Raised {
        /// When it was raised.
        raised_ms: u64,
    },
    /// An acknowledge was accepted at `accepted_ms`; the relay stays off
    /// until `healthy_since_ms` is [`EVIDENCE_MS`] old.
    Evidence {
        /// When the acknowledge was accepted.
        accepted_ms: u64,
        /// Start of the current run of conclusive healthy verdicts.
        healthy_since_ms: Option<u64>,
    },
}

/// The acknowledge policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AckPolicy {
    timing: AckTiming,
    phase: AckPhase,
    last_accepted_ms: Option<u64>,
}

impl Default for AckPolicy {
    fn default() -> Self {
        Self::new(AckTiming::DEFAULT)
    }
}

impl AckPolicy {
    /// The policy at boot: nothing raised.
    pub const fn new(timing: AckTiming) -> Self {
        Self {
            timing,
            phase: AckPhase::Idle,
            last_accepted_ms: None,
        }
    }

    /// Where it stands.
    pub const fn phase(&self) -> AckPhase {
        self.phase
    }

    /// May the relay be energised (as far as acknowledgement goes)? False
    /// while an evidence period runs.
    pub const fn relay_permitted(&self) -> bool {
        !matches!(self.phase, AckPhase::Evidence { .. })
    }

    /// An alarm was raised, escalated or raised again at `t_ms`: the
    /// hold-off restarts, and a running evidence period ends (the latch is
    /// back, which keeps the relay off).
    pub fn raised(&mut self, t_ms: u64) {
        self.phase = AckPhase::Raised { raised_ms: t_ms };
    }

    /// An authentic acknowledge at `t_ms`; `latched`: a leak alarm is
    /// latched now. On [`AckResult::Accepted`] the caller clears the
    /// latch (and rotates the challenge).
    pub fn request(&mut self, t_ms: u64, latched: bool) -> AckEvent {
        let outcome = match self.decide(t_ms, latched) {
            Ok(()) => {
                self.last_accepted_ms = Some(t_ms);
                self.phase = AckPhase::Evidence {
                    accepted_ms: t_ms,
                    healthy_since_ms: None,
                };
                AckResult::Accepted
            }
            Err(r) => AckResult::Rejected(r),
        };
        AckEvent { t_ms, outcome }
    }

    fn decide(&self, t_ms: u64, latched: bool) -> Result<(), AckRejected> {
        let since = |t0: u64| t_ms.saturating_sub(t0);
        if let AckPhase::Evidence { .. } = self.phase {
            return Err(AckRejected::EvidencePending);
        }
        if !latched {
            return Err(AckRejected::NothingLatched);
        }
        if let AckPhase::Raised { raised_ms } = self.phase {
            if since(raised_ms) < self.timing.hold_off_ms {
                return Err(AckRejected::HoldOff);
            }
        }
        if let Some(last) = self.last_accepted_ms {
            if since(last) < self.timing.min_interval_ms {
                return Err(AckRejected::RateLimited);
            }
        }
        Ok(())
    }

    /// An attempt rejected before the policy was asked (transport or
    /// authentication): nothing changes, but it is an event too.
    pub const fn rejected(t_ms: u64, reason: AckRejected) -> AckEvent {
        AckEvent {
            t_ms,
            outcome: AckResult::Rejected(reason),
        }
    }

    /// The monitor's verdict at `t_ms`: `healthy` when it is a conclusive
    /// healthy verdict. Returns true when an evidence period completed
    /// with this sample (the relay may follow the alarm logic again).
    pub fn verdict(&mut self, t_ms: u64, healthy: bool) -> bool {
        let AckPhase::Evidence {
            accepted_ms,
            healthy_since_ms,
        } = self.phase
        else {
            return false;
        };
        if !healthy {
            self.phase = AckPhase::Evidence {
                accepted_ms,
                healthy_since_ms: None,
            };
            return false;
        }
        let since = healthy_since_ms.unwrap_or(t_ms);
        if t_ms.saturating_sub(since) >= self.timing.evidence_ms {
            self.phase = AckPhase::Idle;
            true
        } else {
            self.phase = AckPhase::Evidence {
                accepted_ms,
                healthy_since_ms: Some(since),
            };
            false
        }
    }
}

/// A sample time (s) as ms on the sample clock for the policy's timers,
/// rounded to the nearest ms (half up). Times at or before 0, and NaN,
/// count as 0; times from 2⁵² s on saturate (the policy only compares
/// differences).
///
/// Integer arithmetic on the f64's bits: on the Cortex-M4F f64 is
/// soft-float, and `(t_s * 1000.0 + 0.5) as u64` cost ≈ 425 instructions
/// on the step that raises an alarm (the worst step of the benchmark);
/// this costs a few dozen.
pub fn sample_ms(t_s: f64) -> u64 {
    const MANTISSA_BITS: u32 = 52;
    if !(t_s > 0.0) {
        return 0;
    }
    let bits = t_s.to_bits();
    let biased = ((bits >> MANTISSA_BITS) & 0x7ff) as i32;
    let fraction = bits & ((1 << MANTISSA_BITS) - 1);
    // t_s = mantissa · 2^exp exactly (subnormals have no implicit bit).
    let (mantissa, exp) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | 1 << MANTISSA_BITS, biased - 1075)
    };
    if exp >= 0 {
        return u64::MAX;
    }
    // < 2⁵³ · 1000 < 2⁶³: no overflow.
    let ms_scaled = mantissa * 1000;
    let shift = exp.unsigned_abs();
    if shift >= 64 {
        return 0;
    }
    (ms_scaled >> shift) + ((ms_scaled >> (shift - 1)) & 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_ms_rounds_to_the_nearest_ms() {
        for n in (0..20_000_000u64).step_by(997) {
            let t = n as f64 / 1000.0;
            assert_eq!(sample_ms(t), n, "{t}");
            assert_eq!(sample_ms(t + 0.000_25), n, "{t} + 0.25 ms");
            assert_eq!(sample_ms(t + 0.000_75), n + 1, "{t} + 0.75 ms");
        }
        assert_eq!(sample_ms(0.0005), 1, "half up");
        assert_eq!(sample_ms(0.000_499), 0);
        for t in [0.0, -0.0, -1.0, f64::NAN, f64::NEG_INFINITY, 1e-320, 1e-30] {
            assert_eq!(sample_ms(t), 0, "{t}");
        }
        assert_eq!(sample_ms(f64::INFINITY), u64::MAX);
        assert_eq!(sample_ms(1e17), u64::MAX);
        // A long time on the 1 ms grid: 100 days.
        assert_eq!(sample_ms(8_640_000.001), 8_640_000_001);
    }

    fn rejected(r: AckRejected) -> AckResult {
        AckResult::Rejected(r)
    }

    #[test]
    fn hold_off_then_accept_then_evidence() {
        let mut p = AckPolicy::default();
        assert!(p.relay_permitted());
        assert_eq!(
            p.request(1_000, false).outcome,
            rejected(AckRejected::NothingLatched)
        );
        p.raised(5_000);
        assert_eq!(
            p.request(5_001, true).outcome,
            rejected(AckRejected::HoldOff)
        );
        assert_eq!(
            p.request(14_999, true).outcome,
            rejected(AckRejected::HoldOff)
        );
        let e = p.request(15_000, true);
        assert_eq!(
            e,
            AckEvent {
                t_ms: 15_000,
                outcome: AckResult::Accepted
            }
        );
        assert!(!p.relay_permitted());
        // 30 s of healthy verdicts, interrupted once: restarts.
        for t in 15_001..20_000 {
            assert!(!p.verdict(t, true));
        }
        assert!(!p.verdict(20_000, false));
        for t in 20_001..50_001 {
            assert!(!p.verdict(t, true), "{t}");
            assert!(!p.relay_permitted());
        }
        assert!(p.verdict(50_001, true));
        assert!(p.relay_permitted());
        assert_eq!(p.phase(), AckPhase::Idle);
    }

    #[test]
    fn a_repeated_acknowledge_inside_the_evidence_period_does_nothing() {
        let mut p = AckPolicy::default();
        p.raised(0);
        assert_eq!(p.request(10_000, true).outcome, AckResult::Accepted);
        p.verdict(10_001, true);
        let before = p;
        // Even long after the rate limit, and even if something is
        // latched (by the latch owner's account), nothing changes.
        for t in [10_002, 20_000, 39_000] {
            for latched in [false, true] {
                assert_eq!(
                    p.request(t, latched).outcome,
                    rejected(AckRejected::EvidencePending)
                );
                assert_eq!(p, before, "state changed at {t}");
            }
        }
        // The period still completes 30 s after its first healthy verdict.
        assert!(p.verdict(40_001, true));
    }

    #[test]
    fn at_most_one_accepted_per_interval_and_raising_again_restarts_the_hold_off() {
        let mut p = AckPolicy::default();
        p.raised(0);
        assert_eq!(p.request(10_000, true).outcome, AckResult::Accepted);
        // The leak persists: raised again 2 s later; the evidence period
        // ends (the latch is back).
        p.raised(12_000);
        assert!(p.relay_permitted());
        assert_eq!(
            p.request(21_999, true).outcome,
            rejected(AckRejected::HoldOff)
        );
        assert_eq!(
            p.request(22_000, true).outcome,
            rejected(AckRejected::RateLimited)
        );
        assert_eq!(
            p.request(69_999, true).outcome,
            rejected(AckRejected::RateLimited)
        );
        assert_eq!(p.request(70_000, true).outcome, AckResult::Accepted);
    }

    #[test]
    fn a_flood_gains_one_acknowledge_per_interval_and_never_the_relay() {
        // Valid acknowledges every millisecond while a leak is re-raised
        // 3 s after every clear: the relay is never permitted while
        // latched or proving, and accepted ones are ≥ 60 s apart.
        let mut p = AckPolicy::default();
        let mut latched = false;
        let mut cleared_at = None;
        let mut accepted: heapless::Vec<u64, 16> = heapless::Vec::new();
        for t in 0..600_000u64 {
            if t == 2_000 || cleared_at.is_some_and(|c| t == c + 3_000) {
                latched = true;
                p.raised(t);
            }
            if p.request(t, latched).outcome == AckResult::Accepted {
                latched = false;
                cleared_at = Some(t);
                accepted.push(t).unwrap();
            }
            p.verdict(t, !latched);
            if t >= 2_000 {
                assert!(latched || !p.relay_permitted(), "relay at {t}");
            }
        }
        assert!(accepted.windows(2).all(|w| w[1] - w[0] >= MIN_INTERVAL_MS));
        assert_eq!(accepted.first(), Some(&12_000));
        assert_eq!(accepted.len(), 10);
    }

    #[test]
    fn other_rejections_are_events_and_change_nothing() {
        let mut p = AckPolicy::default();
        p.raised(0);
        let before = p;
        for o in AckResult::ALL {
            if let AckResult::Rejected(r) = o {
                let e = AckPolicy::rejected(7, r);
                assert_eq!(e.outcome, o);
                assert_eq!(e.t_ms, 7);
            }
        }
        assert_eq!(p, before);
    }

    #[test]
    fn outcome_codes_round_trip() {
        for (i, o) in AckResult::ALL.into_iter().enumerate() {
            assert_eq!(o.code(), i as u8 + 1);
            assert_eq!(AckResult::from_code(o.code()), Some(o));
        }
        assert_eq!(AckResult::from_code(0), None);
        assert_eq!(AckResult::from_code(12), None);
        assert_eq!(AckResult::Accepted.name(), "accepted");
        assert_eq!(
            AckResult::Rejected(AckRejected::StaleChallenge).name(),
            "stale_challenge"
        );
    }
}
