//! Framing: `COBS(seq ‖ message ‖ crc32) ‖ 0x00`.
//!
//! - `seq`: u16, little-endian. A host numbers its commands; the device
//!   echoes the number in the reply. Stream blocks carry the low 16 bits of
//!   their block sequence (the full 32-bit one is in the block).
//! - `message`: the postcard encoding of a [`Message`]; its first byte is
//!   the message type (the variant index).
//! - `crc32`: CRC-32/ISO-HDLC (the Ethernet/zip one) of `seq ‖ message`,
//!   little-endian.
//!
//! COBS removes every zero byte, so `0x00` only ever ends a frame: a
//! receiver that loses bytes, or starts in the middle of a stream, is back
//! in step at the next zero. A frame that fails COBS, CRC, length or
//! decoding is dropped whole and counted; nothing of it is used.

use crate::message::Message;

/// Largest decoded frame (`seq ‖ message ‖ crc32`), bytes.
pub const MAX_FRAME: usize = 512;
/// Largest encoded frame on the wire, delimiter included.
pub const MAX_WIRE: usize = MAX_FRAME + MAX_FRAME / 254 + 2;

/// The CRC of frames and parameter sets.
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// A message that does not fit in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooBig;

/// Encode `msg` with sequence number `seq` into `out` (at least
/// [`MAX_WIRE`] bytes for any message); returns the bytes to send,
/// delimiter included.
pub fn encode(seq: u16, msg: &Message<'_>, out: &mut [u8]) -> Result<usize, TooBig> {
    let mut raw = [0u8; MAX_FRAME];
    raw[..2].copy_from_slice(&seq.to_le_bytes());
    let n = postcard::to_slice(msg, &mut raw[2..MAX_FRAME - 4])
        .map_err(|_| TooBig)?
        .len();
    let crc = CRC32.checksum(&raw[..2 + n]);
    raw[2 + n..2 + n + 4].copy_from_slice(&crc.to_le_bytes());
    let len = cobs::try_encode(&raw[..n + 6], out).map_err(|_| TooBig)?;
    *out.get_mut(len).ok_or(TooBig)? = 0;
    Ok(len + 1)
}

/// A received frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame<'a> {
    /// Its sequence number.
    pub seq: u16,
    /// Its message.
    pub msg: Message<'a>,
}

/// Why bytes between two delimiters were dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Longer than [`MAX_WIRE`].
    TooLong,
    /// Not valid COBS, or shorter than a header and CRC.
    Malformed,
    /// CRC mismatch.
    Crc,
    /// CRC right but not a message of this protocol version.
    Undecodable,
}

/// Counters of a [`Decoder`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Frames accepted.
    pub frames: u32,
    /// Frames dropped, per [`FrameError`]: too long, malformed, CRC,
    /// undecodable.
    pub too_long: u32,
    /// See `too_long`.
    pub malformed: u32,
    /// See `too_long`.
    pub crc: u32,
    /// See `too_long`.
    pub undecodable: u32,
}

impl DecoderStats {
    /// All frames dropped.
    pub fn dropped(&self) -> u32 {
        self.too_long + self.malformed + self.crc + self.undecodable
    }
}

/// Splits a byte stream into frames. No allocation; never panics on any
/// input.
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_WIRE],
    len: usize,
    overflow: bool,
    /// What it has seen.
    pub stats: DecoderStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder waiting for the first delimiter-terminated frame.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_WIRE],
            len: 0,
            overflow: false,
            stats: DecoderStats {
                frames: 0,
                too_long: 0,
                malformed: 0,
                crc: 0,
                undecodable: 0,
            },
        }
    }

    /// Forget a partly received frame.
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflow = false;
    }

    /// Feed one byte: at a delimiter, the frame it ends (or why it was
    /// dropped). Empty frames (two delimiters in a row) are ignored.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame<'_>, FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflow) {
            self.stats.too_long += 1;
            return Some(Err(FrameError::TooLong));
        }
        if len == 0 {
            return None;
        }
        let n = match cobs::decode_in_place(&mut self.buf[..len]) {
            Ok(n) if (2 + 1 + 4..=MAX_FRAME).contains(&n) => n,
            _ => {
                self.stats.malformed += 1;
                return Some(Err(FrameError::Malformed));
            }
        };
        let (body, crc) = self.buf[..n].split_at(n - 4);
        let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if CRC32.checksum(body) != crc {
            self.stats.crc += 1;
            return Some(Err(FrameError::Crc));
        }
        let seq = u16::from_le_bytes([body[0], body[1]]);
        match postcard::take_from_bytes::<Message<'_>>(&body[2..]) {
            // Canonical: the message must use every byte before the CRC.
            Ok((msg, [])) => {
                self.stats.frames += 1;
                Some(Ok(Frame { seq, msg }))
            }
            _ => {
                self.stats.undecodable += 1;
                Some(Err(FrameError::Undecodable))
            }
        }
    }
}
