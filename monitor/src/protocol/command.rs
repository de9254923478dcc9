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
use super::{FieldError, Signals};

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
