//! Command frame `LM_Command` (0x310, received): the only thing the
//! monitor accepts from the bus is an acknowledgement of a latched alarm,
//! and only an authenticated one. Nothing on the bus can change a
//! parameter.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | Command | 1 = acknowledge and clear the latched leak alarm |
//! | 2–7 | | Mac | first 48 bits of HMAC-SHA256 over data ID, command, counter and the device's current challenge ([`auth`](super::auth)), byte 2 first |
//!
//! The CRC covers the tag, so the tag is computed first. The device
//! publishes its challenge in `LM_Challenge` (0x304, [`challenge`](super::challenge)).
//!
//! [`CommandReceiver`] acts on a command only when, in this order: the
//! frame has 8 bytes, its CRC and counter range are right and its command
//! code is known (else `Malformed`); fewer than one frame per
//! [`MIN_CHECK_INTERVAL_MS`] was checked (else `Busy`: a flood cannot
//! make the receiver spend its time on SHA-256); its tag answers the
//! current challenge (else `BadMac`, or `StaleChallenge` for the previous
//! challenge); its E2E counter is not the previous authentic command's
//! (else `Repeated`); and the E2E state machine of the channel is not
//! INVALID (else `ChannelInvalid`). The E2E receiver state (counter,
//! window) only learns from frames that passed the tag check: a forged
//! frame can neither consume the controller's next counter nor make a
//! genuine frame look repeated. Frames that fail a check count as ERROR
//! in the window.

use super::auth::{AuthError, Authenticator, Challenges, MAC_LEN};
use super::e2e::{self, E2eError};
use super::p01_receiver::{CheckStatus, P01Config, Receiver, SmConfig, SmState};
use super::signal::SignalList;
use super::{DecodeError, FieldError, MessageKind, Signals, FRAME_LEN};
use crate::decision::acknowledge::AckRejected;

/// A command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Acknowledge and clear the latched leak alarm.
    AcknowledgeAlarm = 1,
}

impl Command {
    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::AcknowledgeAlarm => "acknowledge_alarm",
        }
    }
}

/// The command frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommandFrame {
    /// The command.
    pub command: Command,
    /// The truncated tag (bytes 2..8).
    pub mac: [u8; MAC_LEN],
}

impl CommandFrame {
    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.command as u8) << 4;
        d[2..8].copy_from_slice(&self.mac);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let mut mac = [0u8; MAC_LEN];
        mac.copy_from_slice(&d[2..8]);
        match d[1] >> 4 {
            1 => Ok(Self {
                command: Command::AcknowledgeAlarm,
                mac,
            }),
            code => Err(FieldError {
                field: "Command",
                raw: code as u32,
            }),
        }
    }

    /// The tag as the DBC's 48-bit little-endian signal.
    pub fn mac_value(&self) -> u64 {
        let mut b = [0u8; 8];
        b[..MAC_LEN].copy_from_slice(&self.mac);
        u64::from_le_bytes(b)
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("Command", self.command as u8, self.command.name());
        s.integer("Mac", self.mac_value(), "");
        s.done()
    }
}

/// At most one command frame per this many ms has its tag checked; the
/// rest are dropped as `Busy`. 20 ms: 50 checks per second, a few per
/// cent of the CPU at the worst, while an operator's acknowledge (one
/// frame, or a few repeats) always gets through on a quiet bus.
pub const MIN_CHECK_INTERVAL_MS: u64 = 20;

/// The P01 check of node 0's command frame (another node's has its own
/// identifier as Data ID: [`CommandReceiver::new`]). Commands are sporadic (one frame
/// per operator action), so a gap in the counter says little: a wrong
/// sequence is acted on, a repeated counter is not. `MaxDeltaCounterInit`
/// 1 keeps the status informative (OK for the usual next counter).
pub const COMMAND_P01: P01Config = P01Config {
    data_id: MessageKind::Command.id(),
    data_len: FRAME_LEN as u8,
    max_delta_counter_init: 1,
    max_no_new_or_repeated_data: 14,
    sync_counter_init: 0,
};

/// The command channel's state machine: the first authentic command
/// after boot is acted on (INIT); two bad frames among the last four
/// make the channel INVALID, and it is VALID again once the window of
/// four holds no bad frame (at least two authentic ones).
pub const COMMAND_SM: SmConfig = SmConfig {
    window_size: 4,
    min_ok_state_init: 1,
    max_error_state_init: 1,
    min_ok_state_valid: 1,
    max_error_state_valid: 1,
    min_ok_state_invalid: 2,
    max_error_state_invalid: 0,
};

/// Why a received frame is not acted on as a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandRejected {
    /// Not the command frame (other traffic): not an acknowledge attempt.
    NotACommand,
    /// Length, CRC, counter range or command code is wrong.
    Invalid(DecodeError),
    /// Dropped unchecked: another frame was checked less than
    /// [`MIN_CHECK_INTERVAL_MS`] ago.
    Busy,
    /// The tag does not answer the current challenge.
    Auth(AuthError),
    /// Same counter as the previous authentic command: a repeated frame.
    Repeated {
        /// The counter.
        counter: u8,
    },
    /// The command channel's E2E state machine is INVALID.
    ChannelInvalid,
}

impl CommandRejected {
    /// Was the frame's tag right (rejected after the tag check)? Its
    /// challenge is then used up.
    pub const fn tag_was_right(self) -> bool {
        matches!(self, Self::Repeated { .. } | Self::ChannelInvalid)
    }

    /// The acknowledge event's reason (`None`: not a command at all).
    pub const fn reason(self) -> Option<AckRejected> {
        Some(match self {
            Self::NotACommand => return None,
            Self::Invalid(_) => AckRejected::Malformed,
            Self::Busy => AckRejected::Busy,
            Self::Auth(AuthError::BadMac) => AckRejected::BadMac,
            Self::Auth(AuthError::StaleChallenge) => AckRejected::StaleChallenge,
            Self::Repeated { .. } => AckRejected::Repeated,
            Self::ChannelInvalid => AckRejected::ChannelInvalid,
        })
    }
}

/// A command that passed every check of the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Authentic {
    /// The command.
    pub command: Command,
    /// The challenge it answered: the challenge's owner acts on it only if
    /// that is still the current one.
    pub challenge: u32,
    /// Its E2E counter.
    pub counter: u8,
}

/// The firmware's gate for commands (see the module documentation).
#[derive(Clone, Debug)]
pub struct CommandReceiver {
    auth: Authenticator,
    e2e: Receiver,
    last_check_ms: Option<u64>,
}

impl CommandReceiver {
    /// A receiver for commands authenticated with `auth`'s key, on the
    /// command frame `auth` is for (its node's), that has seen no frame
    /// yet.
    pub const fn new(auth: Authenticator) -> Self {
        let p01 = P01Config {
            data_id: auth.data_id(),
            ..COMMAND_P01
        };
        Self {
            auth,
            e2e: Receiver::new(p01, COMMAND_SM),
            last_check_ms: None,
        }
    }

    /// The command channel's E2E state.
    pub const fn channel(&self) -> SmState {
        self.e2e.state()
    }

    /// The command in `frame`, received at `now_ms` (any monotonic ms
    /// clock), if it is one to act on; `challenges` as the challenge's
    /// owner publishes them.
    pub fn receive(
        &mut self,
        frame: &impl embedded_can::Frame,
        now_ms: u64,
        challenges: Challenges,
    ) -> Result<Authentic, CommandRejected> {
        let kind = MessageKind::Command;
        let data_id = self.auth.data_id();
        let is_command = !frame.is_remote_frame()
            && matches!(frame.id(), embedded_can::Id::Standard(id) if id.as_raw() == data_id);
        if !is_command {
            return Err(CommandRejected::NotACommand);
        }
        let invalid = |e| CommandRejected::Invalid(e);
        let Ok(data) = <&[u8; FRAME_LEN]>::try_from(frame.data()) else {
            self.e2e.reject();
            return Err(invalid(DecodeError::Length {
                kind,
                len: frame.data().len() as u8,
            }));
        };
        let counter = match e2e::check(data_id, data) {
            Ok(c) => c,
            Err(error) => {
                // The P01 check classifies it (WRONGCRC → ERROR) without
                // touching its counter state.
                self.e2e.check(Some(data));
                return Err(invalid(DecodeError::E2e { kind, error }));
            }
        };
        let cmd = match CommandFrame::read(data) {
            Ok(c) => c,
            Err(error) => {
                self.e2e.reject();
                return Err(invalid(DecodeError::Field { kind, error }));
            }
        };
        if self
            .last_check_ms
            .is_some_and(|t| now_ms.wrapping_sub(t) < MIN_CHECK_INTERVAL_MS)
        {
            return Err(CommandRejected::Busy);
        }
        self.last_check_ms = Some(now_ms);
        if let Err(e) = self.auth.check(cmd.command, counter, &cmd.mac, challenges) {
            self.e2e.reject();
            return Err(CommandRejected::Auth(e));
        }
        let checked = self.e2e.check(Some(data));
        match checked.status {
            CheckStatus::Repeated => Err(CommandRejected::Repeated { counter }),
            // A CRC error was returned above; no new data cannot happen.
            CheckStatus::Error | CheckStatus::NoNewData => Err(invalid(DecodeError::E2e {
                kind,
                error: E2eError::TooShort,
            })),
            CheckStatus::Ok | CheckStatus::WrongSequence if checked.state == SmState::Invalid => {
                Err(CommandRejected::ChannelInvalid)
            }
            CheckStatus::Ok | CheckStatus::WrongSequence => Ok(Authentic {
                command: cmd.command,
                challenge: challenges.current,
                counter,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::auth::{acknowledge_frame, AckKey, Challenger};
    use crate::protocol::{CanFrame, Decoder, Message};

    fn key() -> AckKey {
        AckKey::installation(*b"0123456789abcdef")
    }

    fn receiver() -> CommandReceiver {
        CommandReceiver::new(Authenticator::new(&key()))
    }

    fn ack(challenge: u32, counter: u8) -> CanFrame {
        acknowledge_frame(&key(), challenge, counter)
    }

    fn only(current: u32) -> Challenges {
        Challenges {
            current,
            previous: None,
        }
    }

    /// 8 bytes with a right CRC and counter, any other content.
    fn protected(mut d: [u8; 8], counter: u8) -> CanFrame {
        e2e::protect(0x310, &mut d, counter);
        CanFrame::new(0x310, &d).unwrap()
    }

    #[test]
    fn layout_and_signals() {
        let f = ack(7, 3);
        let mut d = [0u8; 8];
        d.copy_from_slice(f.data());
        let c = CommandFrame::read(&d).unwrap();
        assert_eq!(c.command, Command::AcknowledgeAlarm);
        assert_eq!(&c.mac[..], &d[2..8]);
        let mut back = [0u8; 8];
        c.write(&mut back);
        assert_eq!(back[2..], d[2..]);
        assert_eq!(back[1] >> 4, 1);
        let s = c.signals();
        assert_eq!(s[0].name, "Command");
        assert_eq!(s[1].name, "Mac");
        assert_eq!(
            s[1].value.physical(),
            Some(u64::from_le_bytes([d[2], d[3], d[4], d[5], d[6], d[7], 0, 0]) as f64)
        );
        // The generic decoder reads it (without checking the tag).
        let r = Decoder::new().decode(&f).unwrap();
        assert_eq!(r.message, Message::Command(c));
    }

    #[test]
    fn an_authentic_answer_to_the_current_challenge_is_acted_on() {
        let mut rx = receiver();
        let got = rx.receive(&ack(42, 0), 0, only(42)).unwrap();
        assert_eq!(
            got,
            Authentic {
                command: Command::AcknowledgeAlarm,
                challenge: 42,
                counter: 0
            }
        );
        assert_eq!(rx.channel(), SmState::Init);
    }

    #[test]
    fn the_same_frame_twice_is_repeated_and_a_new_counter_is_not() {
        let mut rx = receiver();
        assert!(rx.receive(&ack(42, 0), 0, only(42)).is_ok());
        assert_eq!(
            rx.receive(&ack(42, 0), 100, only(42)),
            Err(CommandRejected::Repeated { counter: 0 })
        );
        assert!(rx.receive(&ack(42, 1), 200, only(42)).is_ok());
    }

    #[test]
    fn a_captured_frame_does_not_answer_the_next_challenge() {
        let mut rx = receiver();
        let mut ch = Challenger::new(&key(), 5, 0);
        let a = ack(ch.current(), 0);
        assert!(rx.receive(&a, 0, ch.challenges()).is_ok());
        ch.rotate(1);
        let b = ack(ch.current(), 1);
        assert!(rx.receive(&b, 100, ch.challenges()).is_ok());
        ch.rotate(2);
        assert_eq!(
            rx.receive(&b, 200, ch.challenges()),
            Err(CommandRejected::Auth(AuthError::StaleChallenge))
        );
        assert_eq!(
            rx.receive(&a, 300, ch.challenges()),
            Err(CommandRejected::Auth(AuthError::BadMac))
        );
    }

    #[test]
    fn malformed_frames_are_rejected_before_the_tag() {
        let mut rx = receiver();
        let f = ack(1, 2);
        let mut d = [0u8; 8];
        d.copy_from_slice(f.data());
        let mut bad_crc = d;
        bad_crc[5] ^= 1;
        assert!(matches!(
            rx.receive(&CanFrame::new(0x310, &bad_crc).unwrap(), 0, only(1)),
            Err(CommandRejected::Invalid(DecodeError::E2e { .. }))
        ));
        let mut code = d;
        code[1] = 0x20 | (code[1] & 0x0F);
        assert!(matches!(
            rx.receive(&protected(code, 2), 0, only(1)),
            Err(CommandRejected::Invalid(DecodeError::Field { .. }))
        ));
        assert!(matches!(
            rx.receive(&CanFrame::new(0x310, &d[..7]).unwrap(), 0, only(1)),
            Err(CommandRejected::Invalid(DecodeError::Length { len: 7, .. }))
        ));
        let status = CanFrame::new(MessageKind::Status.id(), &[0; 8]).unwrap();
        assert_eq!(
            rx.receive(&status, 0, only(1)),
            Err(CommandRejected::NotACommand)
        );
        assert_eq!(CommandRejected::NotACommand.reason(), None);
    }

    #[test]
    fn forged_frames_neither_pass_nor_consume_the_counter() {
        let mut rx = receiver();
        // The attacker knows the layout and the CRC, picks the counter the
        // controller will use next, and guesses the tag.
        let forged = protected([0, 0x10, 1, 2, 3, 4, 5, 6], 0);
        assert_eq!(
            rx.receive(&forged, 0, only(9)),
            Err(CommandRejected::Auth(AuthError::BadMac))
        );
        // The genuine frame with that counter is not "repeated" …
        assert!(rx.receive(&ack(9, 0), 100, only(9)).is_ok());
    }

    #[test]
    fn a_flood_is_checked_at_a_bounded_rate() {
        let mut rx = receiver();
        let forged = protected([0, 0x10, 1, 2, 3, 4, 5, 6], 0);
        let mut checked = 0;
        for t in 0..1000u64 {
            if rx.receive(&forged, t, only(9)) != Err(CommandRejected::Busy) {
                checked += 1;
            }
        }
        assert_eq!(checked, 1000 / MIN_CHECK_INTERVAL_MS as usize);
    }

    #[test]
    fn bad_frames_make_the_channel_invalid_until_two_clean_ones() {
        let mut rx = receiver();
        assert!(rx.receive(&ack(9, 0), 0, only(9)).is_ok());
        assert!(rx.receive(&ack(9, 1), 100, only(9)).is_ok());
        assert_eq!(rx.channel(), SmState::Valid);
        let forged = protected([0, 0x10, 1, 2, 3, 4, 5, 6], 5);
        for t in [200, 300] {
            let _ = rx.receive(&forged, t, only(9));
        }
        assert_eq!(rx.channel(), SmState::Invalid);
        // Authentic frames are refused until the window of four holds no
        // bad frame: the fourth one after the attack.
        assert_eq!(
            rx.receive(&ack(9, 2), 400, only(9)),
            Err(CommandRejected::ChannelInvalid)
        );
        assert_eq!(
            rx.receive(&ack(9, 3), 500, only(9)),
            Err(CommandRejected::ChannelInvalid)
        );
        assert_eq!(
            rx.receive(&ack(9, 4), 600, only(9)),
            Err(CommandRejected::ChannelInvalid)
        );
        assert!(rx.receive(&ack(9, 5), 700, only(9)).is_ok());
        assert_eq!(rx.channel(), SmState::Valid);
    }

    #[test]
    fn every_rejection_has_an_acknowledge_reason() {
        use crate::decision::acknowledge::AckRejected as R;
        let kind = MessageKind::Command;
        let cases = [
            (
                CommandRejected::Invalid(DecodeError::Length { kind, len: 3 }),
                R::Malformed,
            ),
            (CommandRejected::Busy, R::Busy),
            (CommandRejected::Auth(AuthError::BadMac), R::BadMac),
            (
                CommandRejected::Auth(AuthError::StaleChallenge),
                R::StaleChallenge,
            ),
            (CommandRejected::Repeated { counter: 1 }, R::Repeated),
            (CommandRejected::ChannelInvalid, R::ChannelInvalid),
        ];
        for (c, r) in cases {
            assert_eq!(c.reason(), Some(r));
        }
    }
}
