//! Challenge frame `LM_Challenge` (0x304, sent at once when it changes and
//! every second): the challenge an acknowledge must answer, which key the
//! device holds, and what came of the last acknowledge attempt.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | AckKey | 0 installation key, 1 development key (public: acknowledge unprotected) |
//! | 2–5 | | Challenge | u32, the value the next acknowledge's tag must cover |
//! | 6 | | AckResult | outcome of the last acknowledge attempt, 0 = none since boot (see [`AckResult`]) |
//! | 7 | | AckAttempts | acknowledge attempts since boot, wrapping |
//!
//! A controller reads the challenge, sends `LM_Command` with the tag over
//! it ([`auth::acknowledge_frame`](super::auth::acknowledge_frame)), and
//! sees the answer here: `AckAttempts` counts on and `AckResult` says
//! accepted or why not; after an accepted one the challenge changes.

use super::auth::KeyKind;
use super::bytes::{get_u16, put_u16};
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::decision::acknowledge::AckResult;

/// The challenge frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChallengeFrame {
    /// Which key the device authenticates with.
    pub key: KeyKind,
    /// The current challenge.
    pub challenge: u32,
    /// The last acknowledge attempt's outcome (`None`: none since boot).
    pub last_ack: Option<AckResult>,
    /// Acknowledge attempts since boot (wrapping).
    pub ack_attempts: u8,
}

impl ChallengeFrame {
    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.key as u8) << 4;
        put_u16(d, 2, self.challenge as u16);
        put_u16(d, 4, (self.challenge >> 16) as u16);
        d[6] = self.last_ack.map_or(0, AckResult::code);
        d[7] = self.ack_attempts;
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let key = *KeyKind::ALL.get((d[1] >> 4) as usize).ok_or(FieldError {
            field: "AckKey",
            raw: (d[1] >> 4) as u32,
        })?;
        let last_ack = match d[6] {
            0 => None,
            code => Some(AckResult::from_code(code).ok_or(FieldError {
                field: "AckResult",
                raw: code as u32,
            })?),
        };
        Ok(Self {
            key,
            challenge: get_u16(d, 2) as u32 | (get_u16(d, 4) as u32) << 16,
            last_ack,
            ack_attempts: d[7],
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("AckKey", self.key as u8, self.key.name());
        s.integer("Challenge", self.challenge, "");
        match self.last_ack {
            Some(o) => s.enumerated("AckResult", o.code(), o.name()),
            None => s.enumerated("AckResult", 0, "none"),
        }
        s.integer("AckAttempts", self.ack_attempts, "");
        s.done()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decision::acknowledge::AckRejected;

    #[test]
    fn round_trip_and_layout() {
        let f = ChallengeFrame {
            key: KeyKind::Development,
            challenge: 0xA1B2_C3D4,
            last_ack: Some(AckResult::Rejected(AckRejected::HoldOff)),
            ack_attempts: 200,
        };
        let mut d = [0u8; 8];
        f.write(&mut d);
        assert_eq!(d[1], 0x10);
        assert_eq!(d[2..6], [0xD4, 0xC3, 0xB2, 0xA1]);
        assert_eq!(d[6], 3);
        assert_eq!(d[7], 200);
        assert_eq!(ChallengeFrame::read(&d), Ok(f));
        for o in AckResult::ALL.map(Some).into_iter().chain([None]) {
            let g = ChallengeFrame { last_ack: o, ..f };
            g.write(&mut d);
            assert_eq!(ChallengeFrame::read(&d), Ok(g));
        }
        d[6] = 12;
        assert_eq!(ChallengeFrame::read(&d).unwrap_err().field, "AckResult");
        d[6] = 0;
        d[1] = 0x20;
        assert_eq!(ChallengeFrame::read(&d).unwrap_err().field, "AckKey");
    }
}
