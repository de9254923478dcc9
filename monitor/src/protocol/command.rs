//! Command frame `LM_Command` (0x310, received): the only thing the
//! monitor accepts from the bus is an acknowledgement of a latched alarm.
//! Nothing on the bus can change a parameter.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | Command | 1 = acknowledge and clear the latched leak alarm |
//! | 2–7 | | (reserved) | must be 0 |
//!
//! The firmware acts on a command only if its CRC is right, the reserved
//! bytes are zero and its counter differs from the previous command's (a
//! repeated frame is not acted on twice).

use super::signal::SignalList;
use super::{DecodeError, Decoder, FieldError, Message, MessageKind, Received, Sequence, Signals};

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
}

impl CommandFrame {
    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.command as u8) << 4;
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        if let Some(i) = (2..8).find(|&i| d[i] != 0) {
            return Err(FieldError {
                field: "Reserved",
                raw: d[i] as u32,
            });
        }
        match d[1] >> 4 {
            1 => Ok(Self {
                command: Command::AcknowledgeAlarm,
            }),
            code => Err(FieldError {
                field: "Command",
                raw: code as u32,
            }),
        }
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("Command", self.command as u8, self.command.name());
        s.done()
    }
}

/// Why a received frame is not acted on as a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandRejected {
    /// Not the command frame (other traffic).
    NotACommand,
    /// CRC, counter range, length or a field is wrong.
    Invalid(DecodeError),
    /// Same counter as the previous command: a repeated frame.
    Repeated {
        /// The counter.
        counter: u8,
    },
}

/// The firmware's gate for commands: a command is acted on only when its
/// E2E protection is intact, its reserved bytes are zero and its counter
/// differs from the previous command's.
#[derive(Clone, Debug, Default)]
pub struct CommandReceiver {
    decoder: Decoder,
}

impl CommandReceiver {
    /// A receiver that has seen no command yet.
    pub const fn new() -> Self {
        Self {
            decoder: Decoder::new(),
        }
    }

    /// The command in `frame`, if it is one to act on.
    pub fn receive(
        &mut self,
        frame: &impl embedded_can::Frame,
    ) -> Result<Command, CommandRejected> {
        let is_command = matches!(frame.id(), embedded_can::Id::Standard(id) if id.as_raw() == MessageKind::Command.id());
        if !is_command {
            return Err(CommandRejected::NotACommand);
        }
        match self.decoder.decode(frame) {
            Ok(Received {
                sequence: Sequence::Repeated,
                counter,
                ..
            }) => Err(CommandRejected::Repeated { counter }),
            Ok(Received {
                message: Message::Command(c),
                ..
            }) => Ok(c.command),
            // The identifier is the command's, so the message is too.
            Ok(_) => Err(CommandRejected::NotACommand),
            Err(e) => Err(CommandRejected::Invalid(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{e2e, CanFrame, Encoder};

    fn ack() -> Message {
        Message::Command(CommandFrame {
            command: Command::AcknowledgeAlarm,
        })
    }

    #[test]
    fn acts_once_per_new_counter() {
        let mut enc = Encoder::new();
        let mut rx = CommandReceiver::new();
        let first = enc.encode(&ack());
        assert_eq!(rx.receive(&first), Ok(Command::AcknowledgeAlarm));
        assert_eq!(
            rx.receive(&first),
            Err(CommandRejected::Repeated { counter: 0 })
        );
        let _lost = enc.encode(&ack());
        // A later command, even after a lost one, is acted on.
        assert_eq!(
            rx.receive(&enc.encode(&ack())),
            Ok(Command::AcknowledgeAlarm)
        );
    }

    #[test]
    fn rejects_corrupted_malformed_and_foreign_frames() {
        let mut enc = Encoder::new();
        let mut rx = CommandReceiver::new();
        let f = enc.encode(&ack());
        let mut bad = [0u8; 8];
        bad.copy_from_slice(f.data());
        bad[1] ^= 0x20;
        assert!(matches!(
            rx.receive(&CanFrame::new(f.id(), &bad).unwrap()),
            Err(CommandRejected::Invalid(DecodeError::E2e { .. }))
        ));
        let mut reserved = [0u8, 0x10, 0, 0, 0, 0, 0, 0x01];
        e2e::protect(MessageKind::Command.id(), &mut reserved, 3);
        assert!(matches!(
            rx.receive(&CanFrame::new(MessageKind::Command.id(), &reserved).unwrap()),
            Err(CommandRejected::Invalid(DecodeError::Field { .. }))
        ));
        let status = CanFrame::new(MessageKind::Status.id(), &[0; 8]).unwrap();
        assert_eq!(rx.receive(&status), Err(CommandRejected::NotACommand));
        // Nothing above counted as a command: the next good one is acted on.
        assert_eq!(rx.receive(&f), Ok(Command::AcknowledgeAlarm));
    }
}
