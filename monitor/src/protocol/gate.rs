//! The receiving end of the acknowledge path, before the policy: the
//! device's challenge and the checks of every command frame, in one type
//! that the firmware's CAN receive task runs and host tests drive the same
//! way.
//!
//! [`AckGate::receive`] turns a received frame into one of: not a command
//! (other traffic), a rejected attempt (an [`AckEvent`] with its reason:
//! malformed, busy, bad or stale tag, repeated counter, channel invalid),
//! or an [`Authentic`] command. A frame with a right tag uses up the
//! challenge (a new one is issued at once, whatever the E2E check or the
//! acknowledge policy then decides: an answer is good once). The challenge also changes when the
//! count of raised alarms changes ([`AckGate::alarms_raised`]) and when it
//! expires ([`AckGate::tick`]). [`AckGate::frame`] is the `LM_Challenge`
//! to publish.
//!
//! The policy ([`crate::acknowledge`]) is applied by the owner of the
//! latch to the authentic commands only.

use super::auth::{AckKey, Authenticator, Challenger, Challenges, KeyKind};
use super::challenge::ChallengeFrame;
use super::command::{Authentic, CommandReceiver};
use super::Node;
use crate::decision::acknowledge::{AckEvent, AckPolicy, AckResult};

/// What a received frame is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GateOutcome {
    /// Not the command frame: not an acknowledge attempt.
    NotACommand,
    /// An acknowledge attempt rejected before the policy.
    Rejected(AckEvent),
    /// An authentic command for the policy; the challenge was renewed.
    Authentic(Authentic),
}

/// Challenge owner and command checker.
#[derive(Clone, Debug)]
pub struct AckGate {
    challenger: Challenger,
    receiver: CommandReceiver,
    raised_seen: u32,
}

impl AckGate {
    /// The gate at boot (`now_ms` on any monotonic ms clock), its first
    /// challenge derived from `seed` (different at every boot).
    pub fn new(key: &AckKey, seed: u64, now_ms: u64) -> Self {
        Self::for_node(key, Node::DEFAULT, seed, now_ms)
    }

    /// [`Self::new`] for the monitor at `node` (its command frame).
    pub fn for_node(key: &AckKey, node: Node, seed: u64, now_ms: u64) -> Self {
        Self {
            challenger: Challenger::new(key, seed, now_ms),
            receiver: CommandReceiver::new(Authenticator::for_node(key, node)),
            raised_seen: 0,
        }
    }

    /// Which key the gate checks with.
    pub const fn key_kind(&self) -> KeyKind {
        self.challenger.key_kind()
    }

    /// The challenge a command must answer now (and the previous one).
    pub const fn challenges(&self) -> Challenges {
        self.challenger.challenges()
    }

    /// The command channel's E2E state.
    pub const fn channel(&self) -> super::p01_receiver::SmState {
        self.receiver.channel()
    }

    /// Check `frame`, received at `now_ms`; `t_ms` dates the event (the
    /// sample clock).
    pub fn receive(
        &mut self,
        frame: &impl embedded_can::Frame,
        now_ms: u64,
        t_ms: u64,
    ) -> GateOutcome {
        match self
            .receiver
            .receive(frame, now_ms, self.challenger.challenges())
        {
            Ok(authentic) => {
                self.challenger.rotate(now_ms);
                GateOutcome::Authentic(authentic)
            }
            Err(e) => {
                if e.tag_was_right() {
                    self.challenger.rotate(now_ms);
                }
                match e.reason() {
                    None => GateOutcome::NotACommand,
                    Some(reason) => GateOutcome::Rejected(AckPolicy::rejected(t_ms, reason)),
                }
            }
        }
    }

    /// The number of alarms raised since boot (wrapping), as the latch's
    /// owner counts them: a new challenge when it changed, so that no
    /// answer computed before an alarm can clear it. Returns whether the
    /// challenge changed.
    pub fn alarms_raised(&mut self, count: u32, now_ms: u64) -> bool {
        let changed = count != self.raised_seen;
        if changed {
            self.raised_seen = count;
            self.challenger.rotate(now_ms);
        }
        changed
    }

    /// Renew an expired challenge; returns whether it did.
    pub fn tick(&mut self, now_ms: u64) -> bool {
        self.challenger.rotate_if_expired(now_ms)
    }

    /// The challenge frame to publish, with the last attempt's result and
    /// the attempts so far (kept by whoever sees both halves of the path).
    pub const fn frame(&self, last: Option<AckResult>, attempts: u8) -> ChallengeFrame {
        ChallengeFrame {
            key: self.challenger.key_kind(),
            challenge: self.challenger.current(),
            last_ack: last,
            ack_attempts: attempts,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decision::acknowledge::AckRejected;
    use crate::protocol::auth::{acknowledge_frame, CHALLENGE_LIFETIME_MS};
    use crate::protocol::command::MIN_CHECK_INTERVAL_MS;
    use crate::protocol::{e2e, CanFrame, MessageKind};

    fn key() -> AckKey {
        AckKey::installation(*b"installation-key")
    }

    /// A controller: answers the gate's current challenge with its own
    /// rolling counter.
    struct Controller {
        key: AckKey,
        counter: u8,
    }

    impl Controller {
        fn ack(&mut self, gate: &AckGate) -> CanFrame {
            let f = acknowledge_frame(&self.key, gate.challenges().current, self.counter);
            self.counter = (self.counter + 1) % 15;
            f
        }
    }

    fn rejected(o: GateOutcome) -> AckRejected {
        match o {
            GateOutcome::Rejected(AckEvent {
                outcome: AckResult::Rejected(r),
                ..
            }) => r,
            other => panic!("not rejected: {other:?}"),
        }
    }

    #[test]
    fn an_acknowledge_reaches_only_the_node_it_was_made_for() {
        use crate::protocol::auth::acknowledge_frame_for;
        let node = |n| Node::new(n).unwrap();
        let mut gates: [AckGate; 3] =
            core::array::from_fn(|n| AckGate::for_node(&key(), node(n as u32), 7, 0));
        // Node 2's frame, answering node 2's challenge.
        let f = acknowledge_frame_for(node(2), &key(), gates[2].challenges().current, 0);
        assert_eq!(f.id(), 0x350);
        assert!(matches!(
            gates[0].receive(&f, 0, 0),
            GateOutcome::NotACommand
        ));
        assert!(matches!(
            gates[1].receive(&f, 0, 0),
            GateOutcome::NotACommand
        ));
        assert!(matches!(
            gates[2].receive(&f, 0, 0),
            GateOutcome::Authentic(_)
        ));
        // Node 0's (same key, same challenge) re-addressed to node 1: the
        // identifier is in the CRC and in the MAC.
        let f0 = acknowledge_frame_for(node(0), &key(), gates[1].challenges().current, 1);
        let moved = CanFrame::new(MessageKind::Command.id_at(node(1)), f0.data()).unwrap();
        assert_eq!(
            rejected(gates[1].receive(&moved, 10, 10)),
            AckRejected::Malformed
        );
        let mut data = [0u8; 8];
        data.copy_from_slice(f0.data());
        e2e::protect(MessageKind::Command.id_at(node(1)), &mut data, 1);
        let resealed = CanFrame::new(MessageKind::Command.id_at(node(1)), &data).unwrap();
        assert_eq!(
            rejected(gates[1].receive(&resealed, 20, 20)),
            AckRejected::BadMac
        );
    }

    #[test]
    fn two_captured_frames_replayed_alternately_are_rejected() {
        let mut gate = AckGate::new(&key(), 1, 0);
        let mut plc = Controller {
            key: key(),
            counter: 0,
        };
        let a = plc.ack(&gate);
        assert!(matches!(gate.receive(&a, 0, 0), GateOutcome::Authentic(_)));
        let b = plc.ack(&gate);
        assert!(matches!(
            gate.receive(&b, 100, 100),
            GateOutcome::Authentic(_)
        ));
        // The attacker replays a, b, a, b, … (different counters, so the
        // E2E counter check alone would let every one through).
        let mut accepted = 0;
        for i in 0..200u64 {
            let f = if i % 2 == 0 { &a } else { &b };
            match gate.receive(f, 200 + 100 * i, 200 + 100 * i) {
                GateOutcome::Authentic(_) => accepted += 1,
                o => assert!(matches!(
                    rejected(o),
                    AckRejected::BadMac | AckRejected::StaleChallenge
                )),
            }
        }
        assert_eq!(accepted, 0);
        // The controller gets through again once the E2E window holds no
        // bad frame: its fourth frame.
        for k in 0..3u64 {
            let t = 50_000 + 100 * k;
            let o = gate.receive(&plc.ack(&gate), t, t);
            assert_eq!(rejected(o), AckRejected::ChannelInvalid);
        }
        assert!(matches!(
            gate.receive(&plc.ack(&gate), 51_000, 51_000),
            GateOutcome::Authentic(_)
        ));
    }

    #[test]
    fn a_thousand_random_forged_frames_are_all_rejected() {
        let mut gate = AckGate::new(&key(), 2, 0);
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            // xorshift64*
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            x.wrapping_mul(0x2545_F491_4F6C_DD1D)
        };
        let (mut accepted, mut bad_mac) = (0, 0);
        for i in 0..1000u64 {
            // Right layout, command and CRC (anyone can compute it), any
            // counter, a random tag; spaced so that every one is checked.
            let r = next().to_le_bytes();
            let mut d = [0, 0x10, r[0], r[1], r[2], r[3], r[4], r[5]];
            e2e::protect(0x310, &mut d, r[6] % 15);
            let f = CanFrame::new(0x310, &d).unwrap();
            let t = i * MIN_CHECK_INTERVAL_MS;
            match gate.receive(&f, t, t) {
                GateOutcome::Authentic(_) => accepted += 1,
                o => {
                    if rejected(o) == AckRejected::BadMac {
                        bad_mac += 1;
                    }
                }
            }
        }
        assert_eq!(accepted, 0);
        assert_eq!(bad_mac, 1000, "every one checked and refused on its tag");
        // Entirely random bytes fail long before the tag.
        for i in 0..1000u64 {
            let f = CanFrame::new(0x310, &next().to_le_bytes()).unwrap();
            assert!(!matches!(
                gate.receive(&f, 100_000 + i, 0),
                GateOutcome::Authentic(_)
            ));
        }
    }

    #[test]
    fn each_rejection_reason_is_an_event() {
        let mut gate = AckGate::new(&key(), 3, 0);
        let mut plc = Controller {
            key: key(),
            counter: 0,
        };
        let mut t = 0u64;
        let mut step = |gate: &mut AckGate, f: &CanFrame, gap: u64| {
            t += gap;
            gate.receive(f, t, t)
        };
        // Malformed: a flipped bit.
        let good = plc.ack(&gate);
        let mut d = [0u8; 8];
        d.copy_from_slice(good.data());
        d[4] ^= 1;
        let o = step(&mut gate, &CanFrame::new(0x310, &d).unwrap(), 100);
        assert_eq!(rejected(o), AckRejected::Malformed);
        // Authentic, then the same frame again: its challenge is used up.
        assert!(matches!(
            step(&mut gate, &good, 100),
            GateOutcome::Authentic(_)
        ));
        let o = step(&mut gate, &good, 100);
        assert_eq!(rejected(o), AckRejected::StaleChallenge);
        // Busy: the next frame within the check interval.
        let o = step(&mut gate, &good, 1);
        assert_eq!(rejected(o), AckRejected::Busy);
        // Bad MAC: another key.
        let mut thief = Controller {
            key: AckKey::development(),
            counter: 9,
        };
        let forged = thief.ack(&gate);
        let o = step(&mut gate, &forged, 100);
        assert_eq!(rejected(o), AckRejected::BadMac);
        // Repeated: a fresh answer with the last authentic counter (the
        // controller restarted its counter).
        let repeat = acknowledge_frame(&key(), gate.challenges().current, 0);
        let o = step(&mut gate, &repeat, 100);
        assert_eq!(rejected(o), AckRejected::Repeated);
        // Channel invalid: after the bad frames above the window holds
        // two errors.
        assert_eq!(
            gate.channel(),
            crate::protocol::p01_receiver::SmState::Invalid
        );
        let f = plc.ack(&gate);
        let o = step(&mut gate, &f, 100);
        assert_eq!(rejected(o), AckRejected::ChannelInvalid);
        // Other traffic is not an attempt.
        let other = CanFrame::new(0x301, &[0; 8]).unwrap();
        assert_eq!(step(&mut gate, &other, 100), GateOutcome::NotACommand);
        // Events are dated with the sample clock given.
        match gate.receive(&good, 1_000_000, 777) {
            GateOutcome::Rejected(e) => assert_eq!(e.t_ms, 777),
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn the_challenge_changes_on_alarms_and_expiry_and_is_published() {
        let mut gate = AckGate::new(&key(), 4, 0);
        let c0 = gate.challenges().current;
        assert!(!gate.alarms_raised(0, 10));
        assert_eq!(gate.challenges().current, c0);
        assert!(gate.alarms_raised(1, 20));
        let c1 = gate.challenges().current;
        assert_ne!(c1, c0);
        assert!(!gate.tick(20 + CHALLENGE_LIFETIME_MS - 1));
        assert!(gate.tick(20 + CHALLENGE_LIFETIME_MS));
        assert_ne!(gate.challenges().current, c1);
        let f = gate.frame(Some(AckResult::Accepted), 3);
        assert_eq!(f.challenge, gate.challenges().current);
        assert_eq!(f.key, KeyKind::Installation);
        assert_eq!((f.last_ack, f.ack_attempts), (Some(AckResult::Accepted), 3));
        // An answer computed before the alarm no longer works.
        let mut gate = AckGate::new(&key(), 5, 0);
        let early = acknowledge_frame(&key(), gate.challenges().current, 0);
        gate.alarms_raised(1, 1);
        assert_eq!(
            rejected(gate.receive(&early, 100, 100)),
            AckRejected::StaleChallenge
        );
    }
}
