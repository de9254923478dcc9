//! The protocol decoder (`monitor::protocol::Decoder::decode`) on a
//! sequence of arbitrary frames (any identifier, extended or standard,
//! data or remote, 0..=8 bytes), one decoder for the whole sequence.
//!
//! Each frame is 15 input bytes: [`AnyFrame::read`], then a mode byte
//! whose bit 0 puts a right E2E CRC into byte 0 (so that the fuzzer
//! reaches the fields without solving the CRC).
//!
//! Properties: no panic; the error is the first check that fails, in the
//! documented order (not a data frame, unknown identifier, length, E2E,
//! field); a decoded frame is ours, its counter is the one in byte 1, its
//! sequence follows the counter of the last frame of its kind that
//! decoded (frames that fail leave it alone), its signals format; and it
//! re-encodes to the same bytes (except bits the decoder ignores, listed
//! in [`IGNORED`]), which decode to the same message.

use crate::{AnyFrame, Cursor};
use monitor::protocol::{e2e, CanFrame, DecodeError, Decoder, Encoder, MessageKind, Sequence};

/// Bits of the data bytes that `decode` ignores and `encode` writes as 0:
/// the reserved bits 6–7 of byte 1 of `LM_Detail` (`Leading` is two
/// bits), the reserved high nibble of byte 1 and bytes 6–7 of
/// `LM_Version`, and the reserved high nibble of byte 1 and byte 7 of
/// `LM_Sensitivity`.
const IGNORED: [(MessageKind, [u8; 8]); 3] = [
    (MessageKind::Detail, [0, 0xC0, 0, 0, 0, 0, 0, 0]),
    (MessageKind::Version, [0, 0xF0, 0, 0, 0, 0, 0xFF, 0xFF]),
    (MessageKind::Sensitivity, [0, 0xF0, 0, 0, 0, 0, 0, 0xFF]),
];

fn ignored(kind: MessageKind) -> [u8; 8] {
    IGNORED
        .iter()
        .find(|(k, _)| *k == kind)
        .map_or([0; 8], |(_, m)| *m)
}

pub fn run(data: &[u8]) {
    let mut c = Cursor::new(data);
    let mut decoder = Decoder::new();
    // The counter of the last frame of each kind that decoded.
    let mut last: [Option<u8>; MessageKind::COUNT] = [None; MessageKind::COUNT];
    while !c.is_empty() {
        let mut f = AnyFrame::read(&mut c);
        let mode = c.u8();
        if let (Some(id), 1, false) = (f.standard_id(), mode & 1, f.remote) {
            if f.len >= 2 {
                let n = f.len as usize;
                f.data[0] = e2e::crc(id, &f.data[..n]);
            }
        }
        let result = decoder.decode(&f);
        // The checks, in their order.
        let Some(id) = f.standard_id().filter(|_| !f.remote) else {
            assert_eq!(result, Err(DecodeError::NotADataFrame));
            continue;
        };
        let Some(kind) = MessageKind::from_id(id) else {
            assert_eq!(result, Err(DecodeError::UnknownId(id)));
            continue;
        };
        if f.len != 8 {
            assert_eq!(result, Err(DecodeError::Length { kind, len: f.len }));
            continue;
        }
        let d = f.data;
        let counter = match e2e::check(id, &d) {
            Ok(counter) => counter,
            Err(error) => {
                assert_eq!(result, Err(DecodeError::E2e { kind, error }));
                continue;
            }
        };
        let r = match result {
            Ok(r) => r,
            Err(e) => {
                assert!(
                    matches!(e, DecodeError::Field { kind: k, .. } if k == kind),
                    "{e:?}"
                );
                continue;
            }
        };
        assert_eq!(r.message.kind(), kind);
        assert_eq!(r.counter, counter);
        assert!(counter <= e2e::COUNTER_MAX);
        let want = match last[kind as usize] {
            None => Sequence::First,
            Some(prev) => match (counter + 15 - prev) % 15 {
                0 => Sequence::Repeated,
                1 => Sequence::InOrder,
                n => Sequence::Lost(n - 1),
            },
        };
        assert_eq!(r.sequence, want);
        last[kind as usize] = Some(counter);
        for s in r.message.signals().iter() {
            let _ = s.to_string();
        }
        // Re-encode with the same counter: the encoder's counter of this
        // kind runs 0, 1, … from a fresh encoder.
        let mut enc = Encoder::new();
        let mut again = enc.encode(&r.message);
        for _ in 0..counter {
            again = enc.encode(&r.message);
        }
        assert_eq!(again.id(), id);
        let mut mask = ignored(kind);
        if (0..8).any(|i| d[i] & mask[i] != 0) {
            // The CRC covers the ignored bits that were set.
            mask[0] = 0xFF;
        }
        for (i, &m) in mask.iter().enumerate() {
            assert_eq!(
                again.data()[i] & !m,
                d[i] & !m,
                "byte {i} of {kind:?} does not re-encode: {d:02X?} → {:02X?}",
                again.data()
            );
        }
        let back = Decoder::new()
            .decode(&again)
            .expect("a re-encoded frame decodes");
        assert_eq!(back.message, r.message);
        assert_eq!(back.counter, counter);
        let _ = CanFrame::new(id, &d).expect("ours");
    }
}
