//! The controller's side of the acknowledge (`docs/acknowledge.md`): the
//! frame that answers the monitor's current challenge, for a future
//! `host-sim ack` subcommand and for bench tests with `cansend`.

use anyhow::{Context, Result};
use monitor::protocol::auth::{acknowledge_frame, AckKey};
use monitor::protocol::CanFrame;

/// The acknowledge frame for `key_hex` (32 hexadecimal digits, the
/// installation's key) answering `challenge` (as read from
/// `LM_Challenge`), with E2E `counter` (0..=14; the controller's own,
/// incremented per frame).
pub fn frame(key_hex: &str, challenge: u32, counter: u8) -> Result<CanFrame> {
    let key = AckKey::parse_hex(key_hex)
        .map_err(anyhow::Error::msg)
        .context("acknowledge key")?;
    anyhow::ensure!(counter <= 14, "E2E counter {counter} is not 0..=14");
    Ok(acknowledge_frame(
        &AckKey::installation(key),
        challenge,
        counter,
    ))
}

/// `frame` as a `cansend` argument: `310#` and 16 hexadecimal digits.
pub fn cansend(frame: &CanFrame) -> String {
    let data: String = frame.data().iter().map(|b| format!("{b:02X}")).collect();
    format!("{:03X}#{data}", frame.id())
}

#[cfg(test)]
mod tests {
    use super::*;
    use monitor::protocol::auth::{Authenticator, Challenger};
    use monitor::protocol::Command;

    #[test]
    fn the_frame_answers_the_challenge_and_prints_for_cansend() {
        let hex = "00112233445566778899aabbccddeeff";
        let f = frame(hex, 0x0BAD_CAFE, 3).unwrap();
        let key = AckKey::installation(AckKey::parse_hex(hex).unwrap());
        let a = Authenticator::new(&key);
        assert!(a.verify(Command::AcknowledgeAlarm, 3, 0x0BAD_CAFE, &f.data()[2..]));
        let s = cansend(&f);
        assert!(s.starts_with("310#") && s.len() == 4 + 16, "{s}");
        // The monitor's own check accepts it for its current challenge.
        let c = Challenger::new(&key, 7, 0);
        let f = frame(hex, c.current(), 0).unwrap();
        assert_eq!(
            c.verify(Command::AcknowledgeAlarm, 0, &f.data()[2..]),
            Ok(())
        );
        assert!(frame("00", 1, 0).is_err());
        assert!(frame(hex, 1, 15).is_err());
    }
}
