//! A message as a list of named signals with physical values: what
//! `host-sim decode` prints and what the DBC check compares with
//! `cantools`. Names, units and scaling are the DBC file's.

use core::fmt;

/// Signals of one message (the largest has 9 including CRC and counter).
pub type Signals = heapless::Vec<Signal, 12>;

/// One signal.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Signal {
    /// Name as in the DBC file.
    pub name: &'static str,
    /// Value.
    pub value: SignalValue,
}

/// A signal's value.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SignalValue {
    /// A physical quantity: `value` in `unit` (the DBC unit), a multiple
    /// of the DBC factor 10^-`decimals`.
    Quantity {
        /// Physical value.
        value: f64,
        /// Decimal places of the DBC factor.
        decimals: u8,
        /// Unit.
        unit: &'static str,
    },
    /// An enumerated value: raw code and its name (DBC value table).
    Enum {
        /// Raw code.
        code: u8,
        /// Name of the code.
        name: &'static str,
    },
    /// An integer (count, bit mask, identifier, tag), unit-less or in
    /// `unit`. At most 48 bits are used, so the physical value (f64) is
    /// exact.
    Integer {
        /// Value.
        value: u64,
        /// Unit (may be empty).
        unit: &'static str,
    },
    /// A checksum or identity (e.g. a parameter set's CRC-32): an integer
    /// that is compared, not measured, shown in hexadecimal (8 digits).
    Checksum(u32),
    /// A one-bit flag.
    Flag(bool),
    /// The sender has no value (the DBC's `not_available` raw code).
    NotAvailable,
}

impl SignalValue {
    /// The physical value as the DBC defines it (raw × factor + offset),
    /// `None` for not available.
    pub fn physical(&self) -> Option<f64> {
        match *self {
            Self::Quantity { value, .. } => Some(value),
            Self::Enum { code, .. } => Some(code as f64),
            Self::Integer { value, .. } => Some(value as f64),
            Self::Checksum(value) => Some(f64::from(value)),
            Self::Flag(b) => Some(b as u8 as f64),
            Self::NotAvailable => None,
        }
    }
}

impl fmt::Display for Signal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}=", self.name)?;
        let unit = match self.value {
            SignalValue::Quantity {
                value,
                decimals,
                unit,
            } => {
                write!(f, "{value:.*}", decimals as usize)?;
                unit
            }
            SignalValue::Integer { value, unit } => {
                write!(f, "{value}")?;
                unit
            }
            SignalValue::Checksum(value) => return write!(f, "{value:08x}"),
            SignalValue::Enum { name, .. } => return write!(f, "{name}"),
            SignalValue::Flag(b) => return write!(f, "{}", b as u8),
            SignalValue::NotAvailable => return write!(f, "n/a"),
        };
        if unit.is_empty() {
            Ok(())
        } else {
            write!(f, " {unit}")
        }
    }
}

/// Builds a [`Signals`] list.
pub(crate) struct SignalList(Signals);

impl SignalList {
    /// An empty list.
    pub fn new() -> Self {
        Self(Signals::new())
    }

    fn push(&mut self, name: &'static str, value: SignalValue) {
        // Capacity exceeds the largest message: a failed push is a bug
        // caught by the tests (every signal is compared with the DBC).
        let _ = self.0.push(Signal { name, value });
    }

    /// A quantity `raw × 10^-decimals` in `unit`, or not available.
    pub fn quantity(
        &mut self,
        name: &'static str,
        raw: Option<i32>,
        decimals: u8,
        unit: &'static str,
    ) {
        match raw {
            Some(r) => self.push(
                name,
                SignalValue::Quantity {
                    // Division by the power of ten gives the double
                    // nearest to the decimal value.
                    value: r as f64 / libm::pow(10.0, decimals as f64),
                    decimals,
                    unit,
                },
            ),
            None => self.push(name, SignalValue::NotAvailable),
        }
    }

    /// An enumerated value.
    pub fn enumerated(&mut self, name: &'static str, code: u8, label: &'static str) {
        self.push(name, SignalValue::Enum { code, name: label });
    }

    /// An integer.
    pub fn integer(&mut self, name: &'static str, value: impl Into<u64>, unit: &'static str) {
        self.push(
            name,
            SignalValue::Integer {
                value: value.into(),
                unit,
            },
        );
    }

    /// A checksum or identity.
    pub fn checksum(&mut self, name: &'static str, value: u32) {
        self.push(name, SignalValue::Checksum(value));
    }

    /// A flag.
    pub fn flag(&mut self, name: &'static str, on: bool) {
        self.push(name, SignalValue::Flag(on));
    }

    /// The list.
    pub fn done(self) -> Signals {
        self.0
    }
}
