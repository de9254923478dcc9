//! `NAME.input.bin`: the samples of a golden case as exact bit patterns.
//!
//! Layout (little-endian):
//!
//! | field | type |
//! |---|---|
//! | magic `LKGI` | 4 bytes |
//! | version (1) | u16 |
//! | samples | u32 |
//! | sample period, s | f64 bits |
//! | filter warm-up, s | f64 bits |
//! | input hash ([`crate::canon::sample`] chain over all samples) | u64 |
//! | source length, source (the recording it was cut from, UTF-8) | u16, bytes |
//! | samples | see below |
//!
//! Each sample: a presence mask (bit `Channel as u8` set when the reading
//! is present), then the time as the zigzag varint of the second
//! difference of its `f64` bit pattern (uniform sampling makes it ≈ 0),
//! then each present channel as the zigzag varint of the difference of its
//! `f32` bit pattern from that channel's previous present value. Lossless
//! for any bit pattern: decoding is integer addition only.

use crate::fnv::Fnv64;
use crate::reader::{unzigzag, Reader};
use crate::{canon, FormatError};
use monitor::Sample;

/// Magic bytes of an input file.
pub const MAGIC: [u8; 4] = *b"LKGI";
/// Format version written and accepted.
pub const VERSION: u16 = 1;

/// A parsed input file (header; samples decoded on demand).
#[derive(Clone, Debug)]
pub struct Input<'a> {
    /// Number of samples.
    pub samples: u32,
    /// Sample period of the run, s.
    pub sample_period_s: f64,
    /// Filter warm-up of the run, s.
    pub warm_up_s: f64,
    /// Hash of all samples (see [`sample_hash`]).
    pub input_hash: u64,
    /// The recording the samples were cut from (repository-relative path).
    pub source: &'a str,
    body: &'a [u8],
}

/// Why an input file does not hold what its header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    /// Malformed file.
    Format(FormatError),
    /// The decoded samples do not hash to the header's input hash.
    Hash {
        /// From the header.
        expected: u64,
        /// Of the decoded samples.
        decoded: u64,
    },
}

impl From<FormatError> for InputError {
    fn from(e: FormatError) -> Self {
        Self::Format(e)
    }
}

impl core::fmt::Display for InputError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Format(e) => write!(f, "{e}"),
            Self::Hash { expected, decoded } => write!(
                f,
                "decoded samples hash to {decoded:016x}, the file says {expected:016x}"
            ),
        }
    }
}

impl core::error::Error for InputError {}

impl<'a> Input<'a> {
    /// Parse the header of `bytes`.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let mut r = Reader::new(bytes);
        r.header(MAGIC, VERSION)?;
        let samples = r.u32()?;
        let sample_period_s = f64::from_bits(r.u64()?);
        let warm_up_s = f64::from_bits(r.u64()?);
        let input_hash = r.u64()?;
        let n = r.u16()? as usize;
        let source = core::str::from_utf8(r.bytes(n)?).map_err(|_| FormatError::BadText)?;
        let body = r.bytes(r.remaining())?;
        Ok(Self {
            samples,
            sample_period_s,
            warm_up_s,
            input_hash,
            source,
            body,
        })
    }

    /// The samples, decoded one by one.
    pub fn iter(&self) -> Samples<'a> {
        Samples {
            r: Reader::new(self.body),
            left: self.samples,
            t_bits: 0,
            dt: 0,
            ch: [0; 7],
        }
    }

    /// Decode every sample and check the count, that nothing trails, and
    /// the input hash: the samples are exactly what the host replayed.
    pub fn verify(&self) -> Result<(), InputError> {
        let mut h = Fnv64::new();
        let mut it = self.iter();
        for s in &mut it {
            canon::sample(&mut h, &s?);
        }
        if it.r.remaining() != 0 {
            return Err(FormatError::TrailingBytes.into());
        }
        if h.value() != self.input_hash {
            return Err(InputError::Hash {
                expected: self.input_hash,
                decoded: h.value(),
            });
        }
        Ok(())
    }
}

/// The hash of a sample sequence stored in the header.
pub fn sample_hash<'s>(samples: impl IntoIterator<Item = &'s Sample>) -> u64 {
    let mut h = Fnv64::new();
    for s in samples {
        canon::sample(&mut h, s);
    }
    h.value()
}

/// Decoding iterator over an input file's samples.
#[derive(Clone, Debug)]
pub struct Samples<'a> {
    r: Reader<'a>,
    left: u32,
    t_bits: u64,
    dt: i64,
    ch: [u32; 7],
}

impl Samples<'_> {
    fn decode(&mut self) -> Result<Sample, FormatError> {
        let mask = self.r.u8()?;
        self.dt = self.dt.wrapping_add(unzigzag(self.r.varint()?));
        self.t_bits = self.t_bits.wrapping_add(self.dt as u64);
        let mut v = [None; 7];
        for (i, slot) in v.iter_mut().enumerate() {
            if mask & (1 << i) != 0 {
                let d = unzigzag(self.r.varint()?);
                if d < i32::MIN as i64 || d > i32::MAX as i64 {
                    return Err(FormatError::BadVarint);
                }
                self.ch[i] = self.ch[i].wrapping_add(d as i32 as u32);
                *slot = Some(f32::from_bits(self.ch[i]));
            }
        }
        Ok(Sample {
            t_s: f64::from_bits(self.t_bits),
            p_supply_bar: v[0],
            p_piston_bar: v[1],
            p_rod_bar: v[2],
            p_tank_bar: v[3],
            x_piston_m: v[4],
            u_valve: v[5],
            temp_oil_c: v[6],
        })
    }
}

impl Iterator for Samples<'_> {
    type Item = Result<Sample, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let s = self.decode();
        if s.is_err() {
            self.left = 0;
        }
        Some(s)
    }
}

/// Encoding (host side).
#[cfg(any(feature = "alloc", test))]
pub fn encode(
    samples: &[Sample],
    sample_period_s: f64,
    warm_up_s: f64,
    source: &str,
) -> alloc::vec::Vec<u8> {
    use crate::reader::{write, zigzag};
    let mut out = alloc::vec::Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(samples.len() as u32).to_le_bytes());
    out.extend_from_slice(&sample_period_s.to_bits().to_le_bytes());
    out.extend_from_slice(&warm_up_s.to_bits().to_le_bytes());
    out.extend_from_slice(&sample_hash(samples).to_le_bytes());
    let name = &source.as_bytes()[..source.len().min(u16::MAX as usize)];
    out.extend_from_slice(&(name.len() as u16).to_le_bytes());
    out.extend_from_slice(name);
    let (mut t_bits, mut dt, mut ch) = (0u64, 0i64, [0u32; 7]);
    for s in samples {
        let v = s.readings();
        let mask = v
            .iter()
            .enumerate()
            .fold(0u8, |m, (i, x)| m | ((x.is_some() as u8) << i));
        out.push(mask);
        let bits = s.t_s.to_bits();
        let d = bits.wrapping_sub(t_bits) as i64;
        write::varint(&mut out, zigzag(d.wrapping_sub(dt)));
        dt = d;
        t_bits = bits;
        for (i, x) in v.iter().enumerate() {
            if let Some(x) = x {
                let d = x.to_bits().wrapping_sub(ch[i]) as i32;
                write::varint(&mut out, zigzag(d as i64));
                ch[i] = x.to_bits();
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    /// Awkward bit patterns: noise, gaps in time, missing readings, ±0,
    /// extremes, a channel that appears part-way.
    fn samples() -> Vec<Sample> {
        let mut v = Vec::new();
        let mut noise = 0x1234_5678u32;
        for k in 0..300u32 {
            noise = noise.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let t = k as f64 * 1e-3 + if k > 200 { 0.5 } else { 0.0 };
            let x = k as f32 * 0.37;
            v.push(Sample {
                t_s: t,
                p_supply_bar: Some(50.0 + (noise >> 8) as f32 * 1e-7),
                p_piston_bar: if k % 17 == 3 { None } else { Some(-x) },
                p_rod_bar: Some(f32::from_bits(noise)),
                p_tank_bar: Some(0.0),
                x_piston_m: Some(if k % 2 == 0 { -0.0 } else { 0.0 }),
                u_valve: Some(f32::MAX),
                temp_oil_c: (k > 100).then_some(25.0 + x),
            });
        }
        v
    }

    fn same(a: &Sample, b: &Sample) -> bool {
        let bits = |s: &Sample| s.readings().map(|v| v.map(f32::to_bits));
        a.t_s.to_bits() == b.t_s.to_bits() && bits(a) == bits(b)
    }

    #[test]
    fn any_bit_pattern_round_trips_exactly() {
        let s = samples();
        let bytes = encode(&s, 1e-3, 1.0, "examples/x.csv.gz");
        let input = Input::parse(&bytes).unwrap();
        assert_eq!(input.samples, 300);
        assert_eq!(input.source, "examples/x.csv.gz");
        assert_eq!(input.warm_up_s, 1.0);
        input.verify().unwrap();
        let back: Vec<Sample> = input.iter().map(Result::unwrap).collect();
        assert_eq!(back.len(), s.len());
        for (a, b) in s.iter().zip(&back) {
            assert!(same(a, b), "{a:?} != {b:?}");
        }
    }

    #[test]
    fn corruption_is_detected() {
        let s = samples();
        let bytes = encode(&s, 1e-3, 1.0, "x");
        let mut bad = bytes.clone();
        let last = bad.len() - 1;
        bad[last] ^= 0x01;
        assert!(Input::parse(&bad).unwrap().verify().is_err());
        assert_eq!(
            Input::parse(&bytes[..bytes.len() - 1]).unwrap().verify(),
            Err(InputError::Format(FormatError::Truncated))
        );
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(
            Input::parse(&long).unwrap().verify(),
            Err(InputError::Format(FormatError::TrailingBytes))
        );
        let mut magic = bytes;
        magic[0] = b'X';
        assert_eq!(Input::parse(&magic).unwrap_err(), FormatError::BadMagic);
    }
}
