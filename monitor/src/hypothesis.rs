//! The four leak hypotheses of the filter bank.

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

    /// Does it contain the internal leak?
    pub const fn has_internal(self) -> bool {
        matches!(self, Self::Internal | Self::Both)
    }

    /// Does it contain the external leak?
    pub const fn has_external(self) -> bool {
        matches!(self, Self::External | Self::Both)
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
