//! End-to-end protection of every frame: AUTOSAR E2E profile 1 (P01).
//!
//! Layout (P01 defaults): byte 0 is the CRC, the low nibble of byte 1 is
//! a rolling counter 0..=14 (15 is invalid), Data ID mode "both": the
//! 16-bit Data ID (here: the CAN identifier) enters the CRC low byte
//! first, then high byte, then bytes 1..8 of the payload.
//!
//! The CRC is the CRC-8 SAE J1850 polynomial (0x1D) as AUTOSAR's
//! `Crc_CalculateCRC8` computes it (init 0xFF, xor-out 0xFF, check value
//! 0x4B). P01 calls that routine in "continue" mode with start value
//! 0xFF and XORs the result with 0xFF once more, which makes the register
//! start at 0x00 and cancels the final XOR: over the whole
//! `[id lo, id hi, bytes 1..8]` it is poly 0x1D, init 0x00, xor-out 0x00
//! (catalogued as CRC-8/GSM-A, check value 0x37). Both facts are tested
//! below, the P01 result against published P01 vectors.

use crc::{Algorithm, Crc, CRC_8_SAE_J1850};

/// The SAE J1850 CRC exactly as AUTOSAR's CRC library defines it
/// (poly 0x1D, init 0xFF, xor-out 0xFF).
pub const SAE_J1850: Crc<u8> = Crc::<u8>::new(&CRC_8_SAE_J1850);

/// The SAE J1850 polynomial run the way E2E profile 1 chains it
/// (effective init 0x00, xor-out 0x00).
const P01_ALGORITHM: Algorithm<u8> = Algorithm {
    width: 8,
    poly: 0x1d,
    init: 0x00,
    refin: false,
    refout: false,
    xorout: 0x00,
    check: 0x37,
    residue: 0x00,
};

const P01: Crc<u8> = Crc::<u8>::new(&P01_ALGORITHM);

/// Largest valid counter value; the counter wraps 14 → 0.
pub const COUNTER_MAX: u8 = 14;

/// Number of distinct counter values (0..=14).
const COUNTER_MODULUS: u8 = COUNTER_MAX + 1;

/// The P01 CRC of a payload: over the Data ID (low byte, high byte) and
/// every byte after the CRC byte.
pub fn crc(data_id: u16, payload: &[u8]) -> u8 {
    let mut digest = P01.digest();
    digest.update(&data_id.to_le_bytes());
    if payload.len() > 1 {
        digest.update(&payload[1..]);
    }
    digest.finalize()
}

/// Write `counter` into the low nibble of byte 1 and the CRC into byte 0.
/// `payload` must be at least 2 bytes (every frame here has 8).
pub fn protect(data_id: u16, payload: &mut [u8], counter: u8) {
    debug_assert!(payload.len() >= 2 && counter <= COUNTER_MAX);
    payload[1] = (payload[1] & 0xF0) | (counter & 0x0F);
    payload[0] = crc(data_id, payload);
}

/// What is wrong with a received frame's protection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum E2eError {
    /// The frame is shorter than the CRC and counter bytes.
    TooShort,
    /// The CRC in byte 0 is not the CRC of the rest.
    Crc {
        /// CRC carried by the frame.
        received: u8,
        /// CRC computed over the frame.
        computed: u8,
    },
    /// The counter is 15, which P01 never sends.
    InvalidCounter,
}

/// Check the CRC and counter range of a received payload; returns the
/// counter.
pub fn check(data_id: u16, payload: &[u8]) -> Result<u8, E2eError> {
    if payload.len() < 2 {
        return Err(E2eError::TooShort);
    }
    let computed = crc(data_id, payload);
    if payload[0] != computed {
        return Err(E2eError::Crc {
            received: payload[0],
            computed,
        });
    }
    let counter = payload[1] & 0x0F;
    if counter > COUNTER_MAX {
        return Err(E2eError::InvalidCounter);
    }
    Ok(counter)
}

/// The sender side of a counter: 0, 1, …, 14, 0, …
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counter(u8);

impl Counter {
    /// A counter whose first value is 0.
    pub const fn new() -> Self {
        Self(0)
    }

    /// The value to send now; advances the counter.
    pub fn next_value(&mut self) -> u8 {
        let v = self.0;
        self.0 = if v >= COUNTER_MAX { 0 } else { v + 1 };
        v
    }
}

/// How a received counter relates to the previous one of the same frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sequence {
    /// First frame seen: nothing to compare with.
    First,
    /// The counter advanced by one.
    InOrder,
    /// The same counter again: a repeated (stale or replayed) frame.
    Repeated,
    /// The counter advanced by more than one: this many frames were lost
    /// (modulo 15: 15 or more lost frames cannot be told apart).
    Lost(u8),
}

impl Sequence {
    /// Is this an error a receiver should flag?
    pub const fn is_error(self) -> bool {
        matches!(self, Self::Repeated | Self::Lost(_))
    }
}

/// The receiver side of a counter: compares each counter with the last.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CounterCheck {
    last: Option<u8>,
}

impl CounterCheck {
    /// A check that has seen no frame yet.
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// Classify `counter` (0..=14) and remember it.
    pub fn check(&mut self, counter: u8) -> Sequence {
        let seq = match self.last {
            None => Sequence::First,
            Some(last) => match (counter + COUNTER_MODULUS - last) % COUNTER_MODULUS {
                0 => Sequence::Repeated,
                1 => Sequence::InOrder,
                d => Sequence::Lost(d - 1),
            },
        };
        self.last = Some(counter);
        seq
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sae_j1850_check_value() {
        assert_eq!(SAE_J1850.checksum(b"123456789"), 0x4B);
    }

    #[test]
    fn p01_crc_is_sae_j1850_chained_as_autosar_does() {
        assert_eq!(P01.checksum(b"123456789"), 0x37);
        // Chaining as E2E_P01 does: Crc_CalculateCRC8(data, start 0xFF,
        // not first call) XORs the start value with 0xFF, runs, XORs
        // the result with 0xFF; P01 then XORs with 0xFF once more.
        let autosar_continue = |data: &[u8], start: u8| -> u8 {
            let mut crc = start ^ 0xFF;
            for &b in data {
                crc ^= b;
                for _ in 0..8 {
                    crc = if crc & 0x80 != 0 {
                        (crc << 1) ^ 0x1D
                    } else {
                        crc << 1
                    };
                }
            }
            crc ^ 0xFF
        };
        let payload = [0u8, 0x35, 0x12, 0x00, 0xFF, 0x80, 0x7F, 0x01];
        let id: u16 = 0x301;
        let mut c = autosar_continue(&id.to_le_bytes()[..1], 0xFF);
        c = autosar_continue(&id.to_le_bytes()[1..], c);
        c = autosar_continue(&payload[1..], c);
        assert_eq!(c ^ 0xFF, crc(id, &payload));
    }

    #[test]
    fn p01_published_vectors() {
        // Data ID 0x123, mode both, 8 bytes, CRC over bytes 1..8
        // (vectors of the `autosar-e2e` Python package).
        let mut data = [0u8; 8];
        data[0] = crc(0x123, &data);
        assert_eq!(data, [0xCC, 0, 0, 0, 0, 0, 0, 0]);
        protect(0x123, &mut data, 1);
        assert_eq!(data, [0x91, 0x01, 0, 0, 0, 0, 0, 0]);
        assert_eq!(check(0x123, &data), Ok(1));
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        let mut data = [0x00, 0x30, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC];
        protect(0x300, &mut data, 7);
        for byte in 0..8 {
            for bit in 0..8 {
                let mut bad = data;
                bad[byte] ^= 1 << bit;
                assert!(check(0x300, &bad).is_err(), "flip {byte}.{bit}");
            }
        }
        // The same payload under another identifier is rejected too.
        assert!(matches!(check(0x301, &data), Err(E2eError::Crc { .. })));
    }

    #[test]
    fn counter_15_and_short_frames_are_rejected() {
        let mut data = [0u8; 8];
        data[1] = 0x0F;
        data[0] = crc(0x300, &data);
        assert_eq!(check(0x300, &data), Err(E2eError::InvalidCounter));
        assert_eq!(check(0x300, &[0x12]), Err(E2eError::TooShort));
    }

    #[test]
    fn counter_wraps_at_14() {
        let mut c = Counter::new();
        let values: heapless::Vec<u8, 32> = (0..17).map(|_| c.next_value()).collect();
        assert_eq!(
            values.as_slice(),
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 0, 1]
        );
    }

    #[test]
    fn counter_check_classifies_order_repeats_and_losses() {
        let mut k = CounterCheck::new();
        assert_eq!(k.check(13), Sequence::First);
        assert_eq!(k.check(14), Sequence::InOrder);
        assert_eq!(k.check(0), Sequence::InOrder);
        assert_eq!(k.check(0), Sequence::Repeated);
        assert_eq!(k.check(3), Sequence::Lost(2));
        assert_eq!(k.check(1), Sequence::Lost(12));
        assert!(!Sequence::InOrder.is_error() && Sequence::Lost(1).is_error());
    }
}
