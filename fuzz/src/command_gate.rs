//! Command acceptance: the acknowledge path's gate
//! (`monitor::protocol::gate::AckGate`, which owns the challenge and runs
//! the `CommandReceiver`) fed a sequence of frames and times. The frames
//! come from the controller that holds the installation's key (answers to
//! the current challenge), from an attacker without it (arbitrary bytes,
//! the command layout with a right CRC and a guessed tag, tags computed
//! with another key, frames of any identifier and kind) and from replays
//! of any frame seen before; the times jump arbitrarily, backwards too.
//!
//! Input: an 8-byte boot seed, then operations (see [`run`]).
//!
//! Properties: no panic; **a frame is accepted only if its bytes are the
//! answer computed with the key to the challenge current when it arrived**
//! (so nothing without the key is ever accepted, and a replayed frame only
//! if its challenge came round again); a frame made with another key is
//! never accepted; an accepted frame, or one rejected after its tag was
//! found right (repeated counter, channel invalid), renews the challenge,
//! and nothing else received does; a stale-challenge rejection is the
//! answer to the previous challenge; frames have their tag checked at most
//! once per `MIN_CHECK_INTERVAL_MS` (others are `Busy`); the controller's
//! own answers are never refused as forged, stale or malformed; other
//! traffic is not an attempt; events carry the time given; alarms and
//! expiry renew the challenge exactly when they should.

use crate::{AnyFrame, Cursor};
use embedded_can::Frame as _;
use monitor::acknowledge::{AckEvent, AckRejected, AckResult};
use monitor::protocol::auth::{
    acknowledge_frame, AckKey, Challenges, CHALLENGE_LIFETIME_MS, KEY_LEN,
};
use monitor::protocol::command::MIN_CHECK_INTERVAL_MS;
use monitor::protocol::e2e;
use monitor::protocol::gate::{AckGate, GateOutcome};
use monitor::protocol::{CanFrame, MessageKind};

const KEY_BYTES: [u8; KEY_LEN] = *b"fuzz-install-key";

/// Who made a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Origin {
    /// The controller, with the key.
    Controller,
    /// Someone with another key.
    OtherKey,
    /// Made without any key (or replayed).
    NoKey,
}

/// The gate and what the harness knows about it.
struct Harness {
    key: AckKey,
    gate: AckGate,
    now: u64,
    /// When the current challenge was issued.
    issued: u64,
    raised: u32,
    /// Last time a frame's tag was checked.
    last_check: Option<u64>,
    history: Vec<AnyFrame>,
    stats: Stats,
}

/// How an input's frames fared (for the replay test: the seeds must reach
/// acceptance).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted frames.
    pub accepted: u32,
    /// Rejected acknowledge attempts.
    pub rejected: u32,
}

fn any(f: &CanFrame) -> AnyFrame {
    let mut data = [0u8; 8];
    data[..f.data().len()].copy_from_slice(f.data());
    AnyFrame {
        id: embedded_can::Id::Standard(embedded_can::StandardId::new(f.id()).expect("11 bits")),
        remote: false,
        len: f.data().len() as u8,
        data,
    }
}

impl Harness {
    /// The answer with the key to `challenge`, with `f`'s counter.
    fn is_answer(&self, f: &AnyFrame, challenge: u32) -> bool {
        let counter = f.data.get(1).map_or(0, |b| b & 0x0F);
        let right = acknowledge_frame(&self.key, challenge, counter);
        f.standard_id() == Some(MessageKind::Command.id()) && !f.remote && f.data() == right.data()
    }

    fn renewed(&mut self, before: Challenges) {
        let after = self.gate.challenges();
        assert_ne!(after.current, before.current, "challenge not renewed");
        assert_eq!(after.previous, Some(before.current));
        self.issued = self.now;
    }

    fn receive(&mut self, f: AnyFrame, t: u64, origin: Origin) {
        self.history.push(f);
        let before = self.gate.challenges();
        let out = self.gate.receive(&f, self.now, t);
        let is_command = f.standard_id() == Some(MessageKind::Command.id()) && !f.remote;
        let checked = |h: &mut Self| {
            if let Some(last) = h.last_check {
                assert!(
                    h.now.wrapping_sub(last) >= MIN_CHECK_INTERVAL_MS,
                    "a tag checked {} ms after the last",
                    h.now.wrapping_sub(last)
                );
            }
            h.last_check = Some(h.now);
        };
        match out {
            GateOutcome::NotACommand => {
                assert!(!is_command, "a command frame taken as other traffic");
                assert_eq!(self.gate.challenges(), before);
            }
            GateOutcome::Authentic(a) => {
                assert!(is_command);
                assert_ne!(origin, Origin::OtherKey, "accepted with another key");
                assert!(
                    self.is_answer(&f, before.current),
                    "accepted without the key: {f:02X?}"
                );
                assert_eq!(a.challenge, before.current);
                assert_eq!(a.counter, f.data[1] & 0x0F);
                checked(self);
                self.renewed(before);
                self.stats.accepted += 1;
            }
            GateOutcome::Rejected(AckEvent {
                t_ms,
                outcome: AckResult::Rejected(reason),
            }) => {
                assert!(is_command, "other traffic rejected as a command");
                assert_eq!(t_ms, t);
                self.stats.rejected += 1;
                if origin == Origin::Controller {
                    assert!(
                        !matches!(
                            reason,
                            AckRejected::BadMac
                                | AckRejected::StaleChallenge
                                | AckRejected::Malformed
                        ),
                        "the controller's answer refused: {reason:?}"
                    );
                }
                match reason {
                    AckRejected::Repeated | AckRejected::ChannelInvalid => {
                        assert_ne!(origin, Origin::OtherKey);
                        assert!(self.is_answer(&f, before.current), "{reason:?}");
                        checked(self);
                        self.renewed(before);
                    }
                    AckRejected::BadMac | AckRejected::StaleChallenge => {
                        if reason == AckRejected::StaleChallenge {
                            assert!(before.previous.is_some_and(|p| self.is_answer(&f, p)));
                        }
                        checked(self);
                        assert_eq!(self.gate.challenges(), before);
                    }
                    AckRejected::Busy => {
                        let last = self.last_check.expect("busy before any check");
                        assert!(self.now.wrapping_sub(last) < MIN_CHECK_INTERVAL_MS);
                        assert_eq!(self.gate.challenges(), before);
                    }
                    AckRejected::Malformed => assert_eq!(self.gate.challenges(), before),
                    AckRejected::NothingLatched
                    | AckRejected::HoldOff
                    | AckRejected::RateLimited
                    | AckRejected::EvidencePending => panic!("a policy reason from the gate"),
                }
            }
            GateOutcome::Rejected(e) => panic!("an accepted event from the gate: {e:?}"),
        }
    }
}

/// Operations, one byte each (then their operands): the low 3 bits pick
/// it, bit 7 makes the clock jump to an arbitrary u64 instead of moving
/// on by a u16 (ms). Every frame is received at that time, with the event
/// time an arbitrary u32.
pub fn run(data: &[u8]) {
    run_counting(data);
}

/// [`run`], counting outcomes.
pub fn run_counting(data: &[u8]) -> Stats {
    let mut c = Cursor::new(data);
    let seed = c.u64();
    let key = AckKey::installation(KEY_BYTES);
    let mut h = Harness {
        key,
        gate: AckGate::new(&key, seed, 0),
        now: 0,
        issued: 0,
        raised: 0,
        last_check: None,
        history: Vec::new(),
        stats: Stats::default(),
    };
    while !c.is_empty() {
        let op = c.u8();
        h.now = if op & 0x80 != 0 {
            c.u64()
        } else {
            h.now.wrapping_add(u64::from(c.u16()))
        };
        let t = u64::from(c.u32());
        match op & 7 {
            // The controller answers the current challenge.
            0 => {
                let f = acknowledge_frame(&key, h.gate.challenges().current, c.u8() % 15);
                h.receive(any(&f), t, Origin::Controller);
            }
            // Any 8 bytes on the command identifier, the CRC made right
            // if the mode byte says so.
            1 => {
                let mode = c.u8();
                let mut d: [u8; 8] = c.bytes();
                if mode & 1 != 0 {
                    let counter = (d[1] & 0x0F) % 15;
                    e2e::protect(MessageKind::Command.id(), &mut d, counter);
                }
                let f = CanFrame::new(MessageKind::Command.id(), &d).expect("8 bytes");
                h.receive(any(&f), t, Origin::NoKey);
            }
            // Another key answers the current (or previous) challenge.
            2 => {
                let mut other: [u8; KEY_LEN] = c.bytes();
                if other == KEY_BYTES {
                    other[0] ^= 1;
                }
                let ch = h.gate.challenges();
                let challenge = match c.u8() {
                    0..=127 => ch.current,
                    _ => ch.previous.unwrap_or(ch.current),
                };
                let f = acknowledge_frame(&AckKey::installation(other), challenge, c.u8() % 15);
                h.receive(any(&f), t, Origin::OtherKey);
            }
            // A frame seen before, again.
            3 => {
                if h.history.is_empty() {
                    continue;
                }
                let f = h.history[c.u16() as usize % h.history.len()];
                h.receive(f, t, Origin::NoKey);
            }
            // The count of raised alarms.
            4 => {
                let count = u32::from(c.u8());
                let before = h.gate.challenges();
                let changed = h.gate.alarms_raised(count, h.now);
                assert_eq!(changed, count != h.raised);
                if changed {
                    h.raised = count;
                    h.renewed(before);
                } else {
                    assert_eq!(h.gate.challenges(), before);
                }
            }
            // Time passes.
            5 => {
                let before = h.gate.challenges();
                let expired = h.now.saturating_sub(h.issued) >= CHALLENGE_LIFETIME_MS;
                assert_eq!(h.gate.tick(h.now), expired);
                if expired {
                    h.renewed(before);
                } else {
                    assert_eq!(h.gate.challenges(), before);
                }
            }
            // Any frame at all.
            6 => {
                let f = AnyFrame::read(&mut c);
                h.receive(f, t, Origin::NoKey);
            }
            // The command layout with a right CRC and a guessed tag.
            _ => {
                let counter = c.u8() % 15;
                let tag: [u8; 6] = c.bytes();
                let mut d = [0, 0x10, tag[0], tag[1], tag[2], tag[3], tag[4], tag[5]];
                e2e::protect(MessageKind::Command.id(), &mut d, counter);
                let f = CanFrame::new(MessageKind::Command.id(), &d).expect("8 bytes");
                h.receive(any(&f), t, Origin::NoKey);
            }
        }
        let published = h.gate.frame(None, 0);
        assert_eq!(published.challenge, h.gate.challenges().current);
    }
    h.stats
}
