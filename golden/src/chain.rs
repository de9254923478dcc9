//! The two running hash chains over a replay: one over every `Status`, one
//! over the filter bank's state after every sample. Each chain never
//! restarts, so once host and target diverge every later value differs
//! too, and the first differing per-sample value is the first differing
//! sample (up to a 2⁻¹⁶ chance per sample that the fold hides it for one
//! sample; the final 64-bit values catch any divergence).

use crate::canon;
use crate::fnv::Fnv64;
use monitor::{Monitor, Status};

/// The per-sample record: 16-bit folds of both chains after a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fold {
    /// Status chain.
    pub status: u16,
    /// Filter-bank chain.
    pub bank: u16,
}

/// Both chains.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Chains {
    /// Over every `Status`.
    pub status: Fnv64,
    /// Over every filter's state and covariance after each sample.
    pub bank: Fnv64,
}

impl Chains {
    /// Empty chains.
    pub const fn new() -> Self {
        Self {
            status: Fnv64::new(),
            bank: Fnv64::new(),
        }
    }

    /// Add one sample's outcome: the status `monitor.step` returned and
    /// the monitor after that step.
    pub fn push(&mut self, status: &Status, monitor: &Monitor<f32>) -> Fold {
        canon::status(&mut self.status, status);
        canon::bank(&mut self.bank, monitor);
        Fold {
            status: self.status.fold16(),
            bank: self.bank.fold16(),
        }
    }
}
