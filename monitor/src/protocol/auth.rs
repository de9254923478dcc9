//! Authentication of the acknowledge command: a truncated HMAC-SHA256 over
//! the device's current challenge (challenge–response).
//!
//! - **Key**: 128 bits per installation ([`AckKey`]), compiled into the
//!   firmware (`LEAK_MONITOR_ACK_KEY`, see `firmware/build.rs`) and held
//!   by the machine controller. Without one the firmware uses the
//!   well-known [`DEVELOPMENT_KEY`] and says so on the bus
//!   ([`KeyKind::Development`] in the challenge frame).
//! - **Challenge**: a 32-bit value the device publishes in its challenge
//!   frame (`LM_Challenge`). [`Challenger`] derives each one from a
//!   per-boot seed (the caller's: the STM32's RNG on the board, a counter
//!   in tests) and a running number through the keyed PRF, so the values
//!   cannot be predicted without the key and a reboot does not repeat
//!   them (given a fresh seed). Its owner (the firmware's CAN receive
//!   task) rotates it after every authentic acknowledge frame, accepted by
//!   the acknowledge policy or not (an answer is good once: a frame the
//!   policy refused, e.g. during the hold-off, cannot be played again
//!   later), when an alarm is raised, and at the latest after
//!   [`CHALLENGE_LIFETIME_MS`].
//! - **Tag**: the first [`MAC_LEN`] bytes (48 bits) of
//!   HMAC-SHA256(key, "LM" ‖ 1 ‖ data ID ‖ command ‖ counter ‖ challenge)
//!   ([`mac_message`]), carried in bytes 2..8 of the command frame. It
//!   binds the command to this frame identifier, the E2E counter it is
//!   sent with and the challenge it answers: a recorded frame answers a
//!   challenge that is no longer current, and a frame without the key is
//!   a 2⁻⁴⁸ guess.
//!
//! The comparison is constant-time (`Mac::verify_truncated_left`).
//! [`acknowledge_frame`] builds a valid frame from key, challenge and
//! counter (what a controller does; used by the CAN vectors and tests).

use core::fmt;

use hmac::{Hmac, KeyInit, Mac};
use sha2::Sha256;

use super::command::{Command, CommandFrame};
use super::{e2e, CanFrame, MessageKind, Node, FRAME_LEN};

/// Key length, bytes (128 bits).
pub const KEY_LEN: usize = 16;
/// Length of the truncated tag in the command frame, bytes (48 bits).
pub const MAC_LEN: usize = 6;
/// Version of the MAC input layout (changes if [`mac_message`] does).
pub const MAC_VERSION: u8 = 1;
/// A challenge is replaced at the latest after this long, ms: a response
/// a controller computed (or an attacker withheld from the bus) goes stale
/// within this time even when nothing else happens. Five minutes: long
/// enough that an operator's acknowledge never races a rotation in
/// practice (the controller re-reads the challenge every second), short
/// enough that a withheld frame is useless after a coffee break.
pub const CHALLENGE_LIFETIME_MS: u64 = 300_000;

/// The development key: public (it is in this source file). A firmware
/// built without `LEAK_MONITOR_ACK_KEY` uses it and reports
/// [`KeyKind::Development`]; anyone on the bus can then acknowledge.
pub const DEVELOPMENT_KEY: [u8; KEY_LEN] = *b"LM-dev-key-NOT-4";

/// Where the key came from (reported in the challenge frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KeyKind {
    /// The installation's own key.
    Installation = 0,
    /// The public development key: acknowledgement is not protected.
    Development = 1,
}

impl KeyKind {
    /// Every kind, in wire-code order.
    pub const ALL: [KeyKind; 2] = [Self::Installation, Self::Development];

    /// Lower-case name (DBC value table).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Installation => "installation",
            Self::Development => "development",
        }
    }
}

/// An acknowledge key.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct AckKey {
    bytes: [u8; KEY_LEN],
    kind: KeyKind,
}

impl fmt::Debug for AckKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Never print the key itself.
        write!(f, "AckKey({})", self.kind.name())
    }
}

/// A key that cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KeyError {
    /// Not 32 hexadecimal digits.
    Format,
    /// All bytes equal (e.g. all zero): a placeholder, not a key.
    Trivial,
}

impl fmt::Display for KeyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Format => "the key must be 32 hexadecimal digits (128 bits)",
            Self::Trivial => "the key has all bytes equal: a placeholder, not a key",
        })
    }
}

impl AckKey {
    /// An installation's key. The development key's bytes give a
    /// development key.
    pub const fn installation(bytes: [u8; KEY_LEN]) -> Self {
        let mut same = true;
        let mut i = 0;
        while i < KEY_LEN {
            same &= bytes[i] == DEVELOPMENT_KEY[i];
            i += 1;
        }
        Self {
            bytes,
            kind: if same {
                KeyKind::Development
            } else {
                KeyKind::Installation
            },
        }
    }

    /// The public development key.
    pub const fn development() -> Self {
        Self {
            bytes: DEVELOPMENT_KEY,
            kind: KeyKind::Development,
        }
    }

    /// Parse 32 hexadecimal digits (`LEAK_MONITOR_ACK_KEY`).
    pub fn parse_hex(s: &str) -> Result<[u8; KEY_LEN], KeyError> {
        let s = s.trim().as_bytes();
        if s.len() != 2 * KEY_LEN {
            return Err(KeyError::Format);
        }
        let digit = |c: u8| match c {
            b'0'..=b'9' => Ok(c - b'0'),
            b'a'..=b'f' => Ok(c - b'a' + 10),
            b'A'..=b'F' => Ok(c - b'A' + 10),
            _ => Err(KeyError::Format),
        };
        let mut out = [0u8; KEY_LEN];
        for (i, b) in out.iter_mut().enumerate() {
            *b = digit(s[2 * i])? << 4 | digit(s[2 * i + 1])?;
        }
        if out.iter().all(|&b| b == out[0]) {
            return Err(KeyError::Trivial);
        }
        Ok(out)
    }

    /// Where the key came from.
    pub const fn kind(&self) -> KeyKind {
        self.kind
    }
}

/// The bytes the tag is computed over: "LM", [`MAC_VERSION`], the data ID
/// (the command frame's identifier, little-endian), the command code, the
/// E2E counter and the challenge (little-endian).
pub fn mac_message(command: Command, counter: u8, challenge: u32) -> [u8; 11] {
    mac_message_for(MessageKind::Command.id(), command, counter, challenge)
}

/// [`mac_message`] for the command frame with identifier `data_id` (a
/// node's, see [`Node`](super::Node)).
pub fn mac_message_for(data_id: u16, command: Command, counter: u8, challenge: u32) -> [u8; 11] {
    let id = data_id.to_le_bytes();
    let c = challenge.to_le_bytes();
    [
        b'L',
        b'M',
        MAC_VERSION,
        id[0],
        id[1],
        command as u8,
        counter,
        c[0],
        c[1],
        c[2],
        c[3],
    ]
}

/// HMAC-SHA256 keyed once (the key's pads are hashed at construction; a
/// tag then costs two SHA-256 blocks).
#[derive(Clone)]
pub struct Authenticator {
    mac: Hmac<Sha256>,
    kind: KeyKind,
    /// The command frame's identifier (the node's), in every MAC input.
    data_id: u16,
}

impl fmt::Debug for Authenticator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Authenticator({})", self.kind.name())
    }
}

impl Authenticator {
    /// An authenticator for `key`, for node 0's command frame.
    pub fn new(key: &AckKey) -> Self {
        Self::for_node(key, Node::DEFAULT)
    }

    /// An authenticator for `key`, for `node`'s command frame.
    pub fn for_node(key: &AckKey, node: Node) -> Self {
        Self {
            // HMAC takes keys of any length: this cannot fail.
            mac: <Hmac<Sha256> as KeyInit>::new_from_slice(&key.bytes)
                .unwrap_or_else(|_| unreachable!()),
            kind: key.kind,
            data_id: MessageKind::Command.id_at(node),
        }
    }

    /// The command frame's identifier this authenticator is for.
    pub const fn data_id(&self) -> u16 {
        self.data_id
    }

    /// Where the key came from.
    pub const fn key_kind(&self) -> KeyKind {
        self.kind
    }

    /// The tag of `command` sent with E2E `counter` answering `challenge`.
    pub fn tag(&self, command: Command, counter: u8, challenge: u32) -> [u8; MAC_LEN] {
        let full = self
            .mac
            .clone()
            .chain_update(mac_message_for(self.data_id, command, counter, challenge))
            .finalize()
            .into_bytes();
        let mut t = [0u8; MAC_LEN];
        t.copy_from_slice(&full[..MAC_LEN]);
        t
    }

    /// Is `tag` right for `command`, `counter` and `challenge`?
    /// Constant-time in the tag.
    pub fn verify(&self, command: Command, counter: u8, challenge: u32, tag: &[u8]) -> bool {
        tag.len() == MAC_LEN
            && self
                .mac
                .clone()
                .chain_update(mac_message_for(self.data_id, command, counter, challenge))
                .verify_truncated_left(tag)
                .is_ok()
    }

    /// The keyed PRF for challenges: the first 4 bytes of
    /// HMAC(key, "LC" ‖ 1 ‖ seed ‖ n).
    fn challenge(&self, seed: u64, n: u32) -> u32 {
        let mut msg = [0u8; 15];
        msg[..3].copy_from_slice(&[b'L', b'C', MAC_VERSION]);
        msg[3..11].copy_from_slice(&seed.to_le_bytes());
        msg[11..].copy_from_slice(&n.to_le_bytes());
        let full = self.mac.clone().chain_update(msg).finalize().into_bytes();
        u32::from_le_bytes([full[0], full[1], full[2], full[3]])
    }
}

/// The challenges a response may answer, as the challenge's owner
/// publishes them to the receiver: the current one (accepted) and the
/// previous one (recognised as stale, for the event).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Challenges {
    /// The challenge to answer.
    pub current: u32,
    /// The one before, if any.
    pub previous: Option<u32>,
}

impl Authenticator {
    /// Check a received command's tag against `challenges`.
    pub fn check(
        &self,
        command: Command,
        counter: u8,
        tag: &[u8],
        challenges: Challenges,
    ) -> Result<(), AuthError> {
        if self.verify(command, counter, challenges.current, tag) {
            Ok(())
        } else if challenges
            .previous
            .is_some_and(|p| self.verify(command, counter, p, tag))
        {
            Err(AuthError::StaleChallenge)
        } else {
            Err(AuthError::BadMac)
        }
    }
}

/// Why an acknowledge frame's tag is not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AuthError {
    /// Right for the previous challenge: a recorded frame played again
    /// (or a controller that answered just before a rotation).
    StaleChallenge,
    /// Right for no recent challenge: forged, corrupted, or answering a
    /// challenge older than the previous one.
    BadMac,
}

/// The device's challenges and the check of a response.
#[derive(Clone, Debug)]
pub struct Challenger {
    auth: Authenticator,
    seed: u64,
    n: u32,
    current: u32,
    previous: Option<u32>,
    issued_ms: u64,
}

impl Challenger {
    /// The first challenge of this boot, issued at `t_ms`. `seed` must
    /// differ at every boot (hardware RNG): with a repeated seed the
    /// challenges repeat, and a frame recorded in an earlier boot could
    /// answer one again.
    pub fn new(key: &AckKey, seed: u64, t_ms: u64) -> Self {
        let auth = Authenticator::new(key);
        let current = auth.challenge(seed, 0);
        Self {
            auth,
            seed,
            n: 0,
            current,
            previous: None,
            issued_ms: t_ms,
        }
    }

    /// The challenge to publish.
    pub const fn current(&self) -> u32 {
        self.current
    }

    /// Where the key came from.
    pub const fn key_kind(&self) -> KeyKind {
        self.auth.key_kind()
    }

    /// Challenges issued since boot, less one.
    pub const fn rotations(&self) -> u32 {
        self.n
    }

    /// Issue a new challenge at `t_ms` (after an authentic acknowledge, a
    /// raised alarm, or expiry). Responses to the old one are refused from
    /// now on. The new value always differs from the last two.
    pub fn rotate(&mut self, t_ms: u64) {
        let old = self.current;
        loop {
            self.n = self.n.wrapping_add(1);
            let next = self.auth.challenge(self.seed, self.n);
            if next != old && Some(next) != self.previous {
                self.previous = Some(old);
                self.current = next;
                break;
            }
        }
        self.issued_ms = t_ms;
    }

    /// Rotate if the challenge is older than [`CHALLENGE_LIFETIME_MS`] at
    /// `t_ms`; returns whether it did.
    pub fn rotate_if_expired(&mut self, t_ms: u64) -> bool {
        let expired = t_ms.saturating_sub(self.issued_ms) >= CHALLENGE_LIFETIME_MS;
        if expired {
            self.rotate(t_ms);
        }
        expired
    }

    /// The current and the previous challenge (for the receiver).
    pub const fn challenges(&self) -> Challenges {
        Challenges {
            current: self.current,
            previous: self.previous,
        }
    }

    /// Check the tag of a received command against the current challenge.
    pub fn verify(&self, command: Command, counter: u8, tag: &[u8]) -> Result<(), AuthError> {
        self.auth.check(command, counter, tag, self.challenges())
    }
}

/// The E2E-protected acknowledge frame a controller holding `key` sends to
/// answer `challenge`, with E2E `counter` (0..=14).
pub fn acknowledge_frame(key: &AckKey, challenge: u32, counter: u8) -> CanFrame {
    acknowledge_frame_for(Node::DEFAULT, key, challenge, counter)
}

/// [`acknowledge_frame`] for the monitor at `node`.
pub fn acknowledge_frame_for(node: Node, key: &AckKey, challenge: u32, counter: u8) -> CanFrame {
    let command = Command::AcknowledgeAlarm;
    let counter = counter.min(e2e::COUNTER_MAX);
    let frame = CommandFrame {
        command,
        mac: Authenticator::for_node(key, node).tag(command, counter, challenge),
    };
    let mut data = [0u8; FRAME_LEN];
    frame.write(&mut data);
    let id = MessageKind::Command.id_at(node);
    e2e::protect(id, &mut data, counter);
    CanFrame::new(id, &data).unwrap_or_else(|| unreachable!())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> AckKey {
        AckKey::installation(AckKey::parse_hex("000102030405060708090a0b0c0d0e0f").unwrap())
    }

    #[test]
    fn hmac_sha256_matches_rfc_4231() {
        // RFC 4231 test case 2 (key "Jefe"), and its 128-bit truncation
        // (test case 5 style: leftmost bytes).
        let mac = <Hmac<Sha256> as KeyInit>::new_from_slice(b"Jefe")
            .unwrap()
            .chain_update(b"what do ya want for nothing?");
        let want = [
            0x5b, 0xdc, 0xc1, 0x46, 0xbf, 0x60, 0x75, 0x4e, 0x6a, 0x04, 0x24, 0x26, 0x08, 0x95,
            0x75, 0xc7, 0x5a, 0x00, 0x3f, 0x08, 0x9d, 0x27, 0x39, 0x83, 0x9d, 0xec, 0x58, 0xb9,
            0x64, 0xec, 0x38, 0x43,
        ];
        assert_eq!(mac.clone().finalize().into_bytes().as_slice(), &want);
        assert!(mac.verify_truncated_left(&want[..MAC_LEN]).is_ok());
    }

    #[test]
    fn the_tag_is_hmac_over_the_documented_message() {
        let k = key();
        let a = Authenticator::new(&k);
        let msg = mac_message(Command::AcknowledgeAlarm, 7, 0x1234_5678);
        assert_eq!(
            msg,
            [b'L', b'M', 1, 0x10, 0x03, 1, 7, 0x78, 0x56, 0x34, 0x12]
        );
        let full = <Hmac<Sha256> as KeyInit>::new_from_slice(&k.bytes)
            .unwrap()
            .chain_update(msg)
            .finalize()
            .into_bytes();
        assert_eq!(
            a.tag(Command::AcknowledgeAlarm, 7, 0x1234_5678),
            full[..MAC_LEN]
        );
    }

    #[test]
    fn the_tag_binds_counter_challenge_and_key() {
        let a = Authenticator::new(&key());
        let t = a.tag(Command::AcknowledgeAlarm, 3, 42);
        assert!(a.verify(Command::AcknowledgeAlarm, 3, 42, &t));
        assert!(!a.verify(Command::AcknowledgeAlarm, 4, 42, &t));
        assert!(!a.verify(Command::AcknowledgeAlarm, 3, 43, &t));
        assert!(!a.verify(Command::AcknowledgeAlarm, 3, 42, &t[..5]));
        let other = Authenticator::new(&AckKey::development());
        assert!(!other.verify(Command::AcknowledgeAlarm, 3, 42, &t));
        for byte in 0..MAC_LEN {
            for bit in 0..8 {
                let mut bad = t;
                bad[byte] ^= 1 << bit;
                assert!(!a.verify(Command::AcknowledgeAlarm, 3, 42, &bad));
            }
        }
    }

    #[test]
    fn keys_parse_and_placeholders_are_refused() {
        assert_eq!(
            AckKey::parse_hex(" 000102030405060708090A0B0C0D0E0F\n").unwrap()[10],
            10
        );
        assert_eq!(AckKey::parse_hex("00"), Err(KeyError::Format));
        assert_eq!(
            AckKey::parse_hex("000102030405060708090a0b0c0d0e0g"),
            Err(KeyError::Format)
        );
        assert_eq!(
            AckKey::parse_hex("00000000000000000000000000000000"),
            Err(KeyError::Trivial)
        );
        assert_eq!(key().kind(), KeyKind::Installation);
        assert_eq!(
            AckKey::installation(DEVELOPMENT_KEY).kind(),
            KeyKind::Development
        );
        assert_eq!(AckKey::development().kind(), KeyKind::Development);
        // Debug never shows the key.
        let mut shown: heapless::String<64> = heapless::String::new();
        use core::fmt::Write as _;
        write!(shown, "{:?} {:?}", key(), Authenticator::new(&key())).unwrap();
        assert_eq!(shown, "AckKey(installation) Authenticator(installation)");
    }

    #[test]
    fn challenges_differ_per_seed_and_rotation_and_go_stale() {
        let k = key();
        let mut c = Challenger::new(&k, 1, 0);
        let first = c.current();
        assert_ne!(first, Challenger::new(&k, 2, 0).current());
        assert_eq!(first, Challenger::new(&k, 1, 0).current(), "deterministic");
        // Another key, another sequence: unpredictable without the key.
        assert_ne!(
            first,
            Challenger::new(&AckKey::development(), 1, 0).current()
        );
        let mut seen: heapless::Vec<u32, 1024> = heapless::Vec::new();
        seen.push(first).unwrap();
        for i in 0..1000 {
            c.rotate(i);
            seen.push(c.current()).unwrap();
        }
        assert_eq!(c.rotations(), 1000);
        seen.sort_unstable();
        assert!(
            seen.windows(2).all(|w| w[0] != w[1]),
            "a challenge repeated"
        );
        // Expiry.
        let mut c = Challenger::new(&k, 1, 1000);
        assert!(!c.rotate_if_expired(1000 + CHALLENGE_LIFETIME_MS - 1));
        assert!(c.rotate_if_expired(1000 + CHALLENGE_LIFETIME_MS));
        assert_ne!(c.current(), first);
    }

    #[test]
    fn responses_to_the_current_challenge_only() {
        let k = key();
        let mut c = Challenger::new(&k, 9, 0);
        let a = Authenticator::new(&k);
        let cmd = Command::AcknowledgeAlarm;
        let t0 = a.tag(cmd, 0, c.current());
        assert_eq!(c.verify(cmd, 0, &t0), Ok(()));
        c.rotate(1);
        assert_eq!(c.verify(cmd, 0, &t0), Err(AuthError::StaleChallenge));
        let t1 = a.tag(cmd, 1, c.current());
        c.rotate(2);
        assert_eq!(c.verify(cmd, 0, &t0), Err(AuthError::BadMac));
        assert_eq!(c.verify(cmd, 1, &t1), Err(AuthError::StaleChallenge));
        assert_eq!(c.verify(cmd, 1, &[0; MAC_LEN]), Err(AuthError::BadMac));
    }

    #[test]
    fn acknowledge_frame_carries_a_valid_tag() {
        let k = key();
        let f = acknowledge_frame(&k, 0xCAFE_F00D, 5);
        assert_eq!(f.id(), 0x310);
        let d = f.data();
        assert_eq!(e2e::check(0x310, d), Ok(5));
        assert_eq!(d[1] >> 4, Command::AcknowledgeAlarm as u8);
        let a = Authenticator::new(&k);
        assert!(a.verify(Command::AcknowledgeAlarm, 5, 0xCAFE_F00D, &d[2..8]));
    }
}
