//! The four leak hypotheses of the filter bank: one filter per
//! [`LeakSet`], named after the leaks its model contains.

use crate::leak::{Leak, LeakSet};

/// Which leaks a hypothesis (and its filter) contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Hypothesis {
    /// No leak beyond the installation's healthy leakage.
    Healthy = 0,
    /// Leak across the piston seal, piston chamber → rod chamber.
    Internal = 1,
    /// Leak from the rod-side line to tank (e.g. across the valve).
    External = 2,
    /// Both leaks at once.
    Both = 3,
}

impl Hypothesis {
    /// All hypotheses, in bank order.
    pub const ALL: [Hypothesis; 4] = [Self::Healthy, Self::Internal, Self::External, Self::Both];

    /// The leaks its model contains (same code as the hypothesis).
    pub const fn leaks(self) -> LeakSet {
        LeakSet::from_bits(self as u8)
    }

    /// The hypothesis of `leak` alone.
    pub const fn single(leak: Leak) -> Self {
        match leak {
            Leak::Internal => Self::Internal,
            Leak::External => Self::External,
        }
    }

    /// Lower-case name, as in the replay JSON.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Healthy => "healthy",
            Self::Internal => "internal",
            Self::External => "external",
            Self::Both => "both",
        }
    }
}
