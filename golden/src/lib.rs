//! Golden recordings for the leak monitor.
//!
//! A golden *case* is two small binary files written by `host-sim golden`
//! and compiled into the flash image of the QEMU tests:
//!
//! - `NAME.input.bin` ([`input`]): a cut of a recording as the exact
//!   `f64`/`f32` bit patterns the host's CSV reader produced (nothing is
//!   re-parsed on the target), delta-coded, plus the two parameters that
//!   differ from `Params::nominal()` ([`params`]).
//! - `NAME.expected.bin` ([`expected`]): what the monitor produced on the
//!   host for that input: per sample, 16 bits of two running hash chains
//!   (one over every field of the [`monitor::Status`], one over every
//!   filter's state and covariance), the final 64-bit chains, the final
//!   verdict and the events.
//!
//! [`chain::Chains`] is the single definition of the hashes, used by the
//! writer on the host and by the checker on the target, so "the same code
//! gives the same answer" is checked bit for bit on both machines.
#![no_std]
#![deny(missing_docs)]

#[cfg(any(feature = "alloc", test))]
extern crate alloc;

pub mod canon;
pub mod chain;
pub mod describe;
pub mod expected;
pub mod fnv;
pub mod input;
pub mod params;
pub mod reader;

/// A golden file that cannot be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatError {
    /// The file does not start with the expected magic bytes.
    BadMagic,
    /// A version this code does not know.
    BadVersion(u16),
    /// The file ends before its contents do.
    Truncated,
    /// A varint longer than its type.
    BadVarint,
    /// The source name is not UTF-8.
    BadText,
    /// Bytes left over after the last sample.
    TrailingBytes,
}

impl core::fmt::Display for FormatError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BadMagic => f.write_str("not a golden file (bad magic)"),
            Self::BadVersion(v) => write!(f, "unknown golden format version {v}"),
            Self::Truncated => f.write_str("golden file truncated"),
            Self::BadVarint => f.write_str("malformed varint in golden file"),
            Self::BadText => f.write_str("golden source name is not UTF-8"),
            Self::TrailingBytes => f.write_str("bytes after the last sample"),
        }
    }
}

impl core::error::Error for FormatError {}
