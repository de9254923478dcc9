//! `NAME.expected.bin`: what the monitor produced on the host for a golden
//! input, and the checker that compares a run against it.
//!
//! Layout (little-endian):
//!
//! | field | type |
//! |---|---|
//! | magic `LKGE` | 4 bytes |
//! | version (1) | u16 |
//! | samples | u32 |
//! | input hash (ties it to its input file) | u64 |
//! | final status chain, final bank chain | u64, u64 |
//! | final verdict (`Verdict as u8`) | u8 |
//! | event count, then per event: sample index, [`canon::event_code`] | u32, (u32, u16)… |
//! | per sample: status fold, bank fold ([`Fold`]) | (u16, u16)… |

use crate::chain::{Chains, Fold};
use crate::reader::Reader;
use crate::{canon, FormatError};
use monitor::{Event, Monitor, Status, Verdict};

/// Magic bytes of an expected-output file.
pub const MAGIC: [u8; 4] = *b"LKGE";
/// Format version written and accepted.
pub const VERSION: u16 = 1;

/// A parsed expected-output file.
#[derive(Clone, Debug)]
pub struct Expected<'a> {
    /// Number of samples.
    pub samples: u32,
    /// Hash of the input it belongs to.
    pub input_hash: u64,
    /// Final value of the status chain.
    pub status_chain: u64,
    /// Final value of the filter-bank chain.
    pub bank_chain: u64,
    /// Verdict after the last sample (`Verdict as u8`).
    pub final_verdict: u8,
    events: &'a [u8],
    folds: &'a [u8],
}

impl<'a> Expected<'a> {
    /// Parse `bytes`.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let mut r = Reader::new(bytes);
        r.header(MAGIC, VERSION)?;
        let samples = r.u32()?;
        let input_hash = r.u64()?;
        let status_chain = r.u64()?;
        let bank_chain = r.u64()?;
        let final_verdict = r.u8()?;
        let n_events = r.u32()? as usize;
        let events = r.bytes(n_events.checked_mul(6).ok_or(FormatError::Truncated)?)?;
        let folds = r.bytes(samples as usize * 4)?;
        if r.remaining() != 0 {
            return Err(FormatError::TrailingBytes);
        }
        Ok(Self {
            samples,
            input_hash,
            status_chain,
            bank_chain,
            final_verdict,
            events,
            folds,
        })
    }

    /// The per-sample record of sample `i`.
    pub fn fold(&self, i: u32) -> Option<Fold> {
        let b = self.folds.get(i as usize * 4..i as usize * 4 + 4)?;
        Some(Fold {
            status: u16::from_le_bytes([b[0], b[1]]),
            bank: u16::from_le_bytes([b[2], b[3]]),
        })
    }

    /// The expected events: (sample index, event code).
    pub fn events(&self) -> impl Iterator<Item = (u32, u16)> + 'a {
        self.events.chunks_exact(6).map(|c| {
            (
                u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                u16::from_le_bytes([c[4], c[5]]),
            )
        })
    }
}

/// Where a run first left the golden path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Divergence {
    /// Index of the first sample whose record differs.
    pub sample: u32,
    /// The status chain differs there.
    pub status: bool,
    /// The filter-bank chain differs there.
    pub bank: bool,
}

/// The result of a whole run against an expected file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outcome {
    /// Samples checked.
    pub samples: u32,
    /// First divergence, if any.
    pub divergence: Option<Divergence>,
    /// Final status chain equals the expected one.
    pub status_chain_ok: bool,
    /// Final bank chain equals the expected one.
    pub bank_chain_ok: bool,
    /// Final verdict equals the expected one.
    pub verdict_ok: bool,
    /// The run had exactly the expected number of samples.
    pub count_ok: bool,
}

impl Outcome {
    /// Bit-identical from first to last sample.
    pub fn passed(&self) -> bool {
        self.divergence.is_none()
            && self.status_chain_ok
            && self.bank_chain_ok
            && self.verdict_ok
            && self.count_ok
    }
}

/// Compares a run, sample by sample, with an expected file.
#[derive(Clone, Debug)]
pub struct Checker<'e, 'a> {
    expected: &'e Expected<'a>,
    chains: Chains,
    index: u32,
    verdict: Option<Verdict>,
    divergence: Option<Divergence>,
}

impl<'e, 'a> Checker<'e, 'a> {
    /// Start checking against `expected`.
    pub fn new(expected: &'e Expected<'a>) -> Self {
        Self {
            expected,
            chains: Chains::new(),
            index: 0,
            verdict: None,
            divergence: None,
        }
    }

    /// Take the status of the next sample and the monitor after it.
    /// Returns the divergence the first time one is found.
    pub fn push(&mut self, status: &Status, monitor: &Monitor<f32>) -> Option<Divergence> {
        let got = self.chains.push(status, monitor);
        let i = self.index;
        self.index += 1;
        self.verdict = Some(status.verdict);
        if self.divergence.is_some() {
            return None;
        }
        let want = self.expected.fold(i);
        let d = Divergence {
            sample: i,
            status: want.is_none_or(|w| w.status != got.status),
            bank: want.is_none_or(|w| w.bank != got.bank),
        };
        if d.status || d.bank {
            self.divergence = Some(d);
            return Some(d);
        }
        None
    }

    /// The expected events at sample `i` (for reports).
    pub fn expected_events_at(&self, i: u32) -> impl Iterator<Item = Option<Event>> + 'a {
        self.expected
            .events()
            .filter(move |(k, _)| *k == i)
            .map(|(_, c)| canon::event_from_code(c))
    }

    /// Finish the run.
    pub fn finish(self) -> Outcome {
        Outcome {
            samples: self.index,
            divergence: self.divergence,
            status_chain_ok: self.chains.status.value() == self.expected.status_chain,
            bank_chain_ok: self.chains.bank.value() == self.expected.bank_chain,
            verdict_ok: self.verdict.map(|v| v as u8) == Some(self.expected.final_verdict),
            count_ok: self.index == self.expected.samples,
        }
    }
}

/// Builds an expected file from a run (host side).
#[cfg(any(feature = "alloc", test))]
#[derive(Clone, Debug, Default)]
pub struct Writer {
    chains: Chains,
    folds: alloc::vec::Vec<Fold>,
    events: alloc::vec::Vec<(u32, u16)>,
    verdict: u8,
}

#[cfg(any(feature = "alloc", test))]
impl Writer {
    /// An empty run.
    pub fn new() -> Self {
        Self::default()
    }

    /// Take the status of the next sample and the monitor after it.
    pub fn push(&mut self, status: &Status, monitor: &Monitor<f32>) {
        let i = self.folds.len() as u32;
        self.folds.push(self.chains.push(status, monitor));
        for e in &status.events {
            self.events.push((i, canon::event_code(e)));
        }
        self.verdict = status.verdict as u8;
    }

    /// The file, for the input whose hash is `input_hash`.
    pub fn finish(self, input_hash: u64) -> alloc::vec::Vec<u8> {
        let mut out = alloc::vec::Vec::new();
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(self.folds.len() as u32).to_le_bytes());
        out.extend_from_slice(&input_hash.to_le_bytes());
        out.extend_from_slice(&self.chains.status.value().to_le_bytes());
        out.extend_from_slice(&self.chains.bank.value().to_le_bytes());
        out.push(self.verdict);
        out.extend_from_slice(&(self.events.len() as u32).to_le_bytes());
        for (i, c) in &self.events {
            out.extend_from_slice(&i.to_le_bytes());
            out.extend_from_slice(&c.to_le_bytes());
        }
        for f in &self.folds {
            out.extend_from_slice(&f.status.to_le_bytes());
            out.extend_from_slice(&f.bank.to_le_bytes());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use monitor::{Params, Sample};

    fn run(n: u32, nudge_at: Option<u32>) -> alloc::vec::Vec<(Status, Monitor<f32>)> {
        let mut m = Monitor::<f32>::new(&Params::nominal()).unwrap();
        let mut out = alloc::vec::Vec::new();
        for k in 0..n {
            let mut p_rod = 25.0 + (k % 7) as f32 * 0.01;
            if nudge_at == Some(k) {
                // One count of a 16-bit ADC over 0–250 bar would be 4 mbar;
                // 1 mbar is far below any sensor's resolution. (A 1-ulp
                // change of 25 bar can vanish in the scaling to filter
                // units, which is rounding, not a missed divergence.)
                p_rod += 0.001;
            }
            let s = Sample {
                t_s: k as f64 * 1e-3,
                p_supply_bar: Some(50.0),
                p_piston_bar: Some(27.0),
                p_rod_bar: Some(p_rod),
                p_tank_bar: Some(0.6),
                x_piston_m: Some(0.04),
                u_valve: Some(0.0),
                temp_oil_c: None,
            };
            let st = m.step(&s);
            out.push((st, m.clone()));
        }
        out
    }

    #[test]
    fn a_run_matches_itself_and_a_tiny_input_change_is_caught_where_it_happens() {
        let golden = run(60, None);
        let mut w = Writer::new();
        for (s, m) in &golden {
            w.push(s, m);
        }
        let bytes = w.finish(42);
        let exp = Expected::parse(&bytes).unwrap();
        assert_eq!(exp.samples, 60);
        assert_eq!(exp.input_hash, 42);

        let mut c = Checker::new(&exp);
        for (s, m) in &golden {
            assert_eq!(c.push(s, m), None);
        }
        assert!(c.finish().passed());

        let nudged = run(60, Some(40));
        let mut c = Checker::new(&exp);
        let mut first = None;
        for (s, m) in &nudged {
            if let Some(d) = c.push(s, m) {
                first.get_or_insert(d);
            }
        }
        let d = first.expect("a 1 mbar change of one reading must be detected");
        assert_eq!(d.sample, 40);
        assert!(d.bank, "the measurement moves the filter states");
        let o = c.finish();
        assert!(!o.passed() && !o.bank_chain_ok);

        // A run cut short fails too.
        let mut c = Checker::new(&exp);
        for (s, m) in &golden[..59] {
            c.push(s, m);
        }
        assert!(!c.finish().count_ok);
    }
}
