//! The leak vocabulary, used by the whole crate: the two leaks a cylinder
//! can have ([`Leak`]), a set of them ([`LeakSet`]: what is latched, what a
//! hypothesis contains, what a verdict names) and one value per leak
//! ([`PerLeak`]: flows, thresholds, CUSUMs). Everything that used to be
//! "index 0 is internal, 1 is external" is a `PerLeak` indexed by a `Leak`.

use core::ops::{Index, IndexMut};

/// One of the two leaks the monitor tells apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Leak {
    /// Across the piston seal, piston chamber → rod chamber.
    Internal = 0,
    /// From the rod-side line to tank (e.g. across the valve).
    External = 1,
}

impl Leak {
    /// Both leaks, internal first.
    pub const ALL: [Leak; 2] = [Self::Internal, Self::External];

    /// The other leak.
    pub const fn other(self) -> Leak {
        match self {
            Self::Internal => Self::External,
            Self::External => Self::Internal,
        }
    }

    /// The set holding just this leak.
    pub const fn set(self) -> LeakSet {
        match self {
            Self::Internal => LeakSet::INTERNAL,
            Self::External => LeakSet::EXTERNAL,
        }
    }
}

/// A set of leaks. Its code (bit 0 internal, bit 1 external) is the wire
/// code of the CAN alarm frame's `LatchedLeak` and equals the code of the
/// [`Verdict`](crate::Verdict) and [`Hypothesis`](crate::Hypothesis) with
/// the same leaks.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct LeakSet(u8);

/// Shown by name (`internal`), as in logs and the DBC.
impl core::fmt::Debug for LeakSet {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for LeakSet {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=str}", self.name())
    }
}

impl LeakSet {
    /// No leak.
    pub const NONE: Self = Self(0);
    /// The internal leak only.
    pub const INTERNAL: Self = Self(1);
    /// The external leak only.
    pub const EXTERNAL: Self = Self(2);
    /// Both leaks.
    pub const BOTH: Self = Self(3);
    /// Every set, in wire-code order.
    pub const ALL: [LeakSet; 4] = [Self::NONE, Self::INTERNAL, Self::EXTERNAL, Self::BOTH];

    /// The set with the given leaks.
    pub const fn of(internal: bool, external: bool) -> Self {
        Self(internal as u8 | (external as u8) << 1)
    }

    /// The set of the low two bits of `bits` (bit 0 internal, bit 1
    /// external): for the types that share its codes.
    pub(crate) const fn from_bits(bits: u8) -> Self {
        Self(bits & 3)
    }

    /// Wire code, 0..=3.
    pub const fn code(self) -> u8 {
        self.0
    }

    /// The set of a wire code, if valid.
    pub const fn from_code(code: u8) -> Option<Self> {
        if code <= 3 {
            Some(Self(code))
        } else {
            None
        }
    }

    /// Lower-case name (logs, `host-sim decode`, the DBC value table).
    pub const fn name(self) -> &'static str {
        match self.0 {
            0 => "none",
            1 => "internal",
            2 => "external",
            _ => "both",
        }
    }

    /// Does it hold `leak`?
    pub const fn contains(self, leak: Leak) -> bool {
        self.0 & leak.set().0 != 0
    }

    /// No leak in it?
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Every leak of `self` and `other`.
    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// How many leaks it holds.
    pub const fn len(self) -> u8 {
        (self.0 & 1) + (self.0 >> 1)
    }
}

/// One value per leak, indexed by [`Leak`] (stored as a two-element
/// array, so indexing costs what `[T; 2]` indexing did).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PerLeak<T>([T; 2]);

impl<T> PerLeak<T> {
    /// `internal`, `external`.
    pub const fn new(internal: T, external: T) -> Self {
        Self([internal, external])
    }

    /// The same value for both leaks.
    pub const fn splat(v: T) -> Self
    where
        T: Copy,
    {
        Self([v, v])
    }

    /// The internal leak's value.
    pub fn internal(self) -> T
    where
        T: Copy,
    {
        self.0[0]
    }

    /// The external leak's value.
    pub fn external(self) -> T
    where
        T: Copy,
    {
        self.0[1]
    }

    /// `f` applied to each value.
    pub fn map<U>(self, f: impl FnMut(T) -> U) -> PerLeak<U> {
        PerLeak(self.0.map(f))
    }

    /// `f` applied to each leak.
    pub fn from_fn(mut f: impl FnMut(Leak) -> T) -> Self {
        Self([f(Leak::Internal), f(Leak::External)])
    }
}

impl PerLeak<bool> {
    /// The leaks whose value is true.
    pub const fn set(self) -> LeakSet {
        LeakSet::of(self.0[0], self.0[1])
    }
}

impl<T> Index<Leak> for PerLeak<T> {
    type Output = T;
    #[inline(always)]
    fn index(&self, leak: Leak) -> &T {
        &self.0[leak as usize]
    }
}

impl<T> IndexMut<Leak> for PerLeak<T> {
    #[inline(always)]
    fn index_mut(&mut self, leak: Leak) -> &mut T {
        &mut self.0[leak as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leak_set_codes_names_and_union() {
        for s in LeakSet::ALL {
            assert_eq!(LeakSet::from_code(s.code()), Some(s));
        }
        assert_eq!(LeakSet::from_code(4), None);
        assert_eq!(LeakSet::INTERNAL.union(LeakSet::EXTERNAL), LeakSet::BOTH);
        assert_eq!(LeakSet::BOTH.union(LeakSet::NONE), LeakSet::BOTH);
        assert!(
            LeakSet::BOTH.contains(Leak::External) && !LeakSet::INTERNAL.contains(Leak::External)
        );
        assert_eq!(LeakSet::of(false, true), LeakSet::EXTERNAL);
        assert_eq!(
            LeakSet::ALL.map(LeakSet::name),
            ["none", "internal", "external", "both"]
        );
        assert_eq!(LeakSet::ALL.map(LeakSet::len), [0, 1, 1, 2]);
    }

    #[test]
    fn per_leak_is_indexed_by_leak() {
        let mut p = PerLeak::new(1, 2);
        p[Leak::External] += 10;
        assert_eq!((p[Leak::Internal], p.external()), (1, 12));
        assert_eq!(
            PerLeak::from_fn(|l| l == Leak::External).set(),
            LeakSet::EXTERNAL
        );
    }
}
