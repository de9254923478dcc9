//! The device's own diagnostics, in the spirit of IEC 61508-2 Annex A:
//! each check detects a failure of the hardware the monitor runs on (its
//! flash, RAM, ADC reference, clocks, supply, relay) or of its program flow.
//! Any of them is a [`DeviceFault`]: the relay drops and stays off, and the
//! fault's code goes on CAN and into the log.
//!
//! The checks here are pure logic over values the firmware reads from the
//! hardware (memory contents, ADC codes, timer counts, a pin), so each one
//! is tested on the host with injected faults. The firmware only moves the
//! readings in and acts on the result.

pub mod brownout;
pub mod check;
pub mod clock;
pub mod flash;
pub mod flow;
pub mod ram;
pub mod reference;
pub mod relay;

/// A failure of the device itself. The wire code is what the CAN alarm
/// frame carries (`DeviceFault`, 0 = none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceFault {
    /// The program image in flash does not match its checksum.
    FlashImage = 1,
    /// The stored parameter set does not match its checksum.
    FlashParams = 2,
    /// The RAM test found a cell that does not hold what was written.
    Ram = 3,
    /// The ADC reference (VDDA, measured through VREFINT) is out of range:
    /// every analogue reading would be scaled wrongly.
    AdcReference = 4,
    /// The sample clock disagrees with the independent LSI oscillator, or
    /// the clock security system switched off the crystal.
    Clock = 5,
    /// The brown-out reset level is not programmed as required.
    BrownOut = 6,
    /// The relay's read-back disagrees with what it was driven to.
    RelayReadback = 7,
    /// A task did not pass its program-flow checkpoint in time.
    ProgramFlow = 8,
}

impl DeviceFault {
    /// Every fault, in code order.
    pub const ALL: [DeviceFault; 8] = [
        Self::FlashImage,
        Self::FlashParams,
        Self::Ram,
        Self::AdcReference,
        Self::Clock,
        Self::BrownOut,
        Self::RelayReadback,
        Self::ProgramFlow,
    ];

    /// Wire code (CAN alarm frame), 1..=8.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The fault of a wire code; `None` for 0 (no fault) or an unknown code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|f| f.code() == code)
    }

    /// Lower-case name (logs, `host-sim decode`, the DBC value table).
    pub const fn name(self) -> &'static str {
        match self {
            Self::FlashImage => "flash_image",
            Self::FlashParams => "flash_params",
            Self::Ram => "ram",
            Self::AdcReference => "adc_reference",
            Self::Clock => "clock",
            Self::BrownOut => "brown_out",
            Self::RelayReadback => "relay_readback",
            Self::ProgramFlow => "program_flow",
        }
    }
}

/// The device faults seen since boot. A device fault latches until reset:
/// hardware that failed once is not trusted again without a restart (which
/// repeats the start-up tests).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceFaults {
    bits: u16,
}

impl DeviceFaults {
    /// No fault.
    pub const NONE: Self = Self { bits: 0 };

    /// Record a fault; true if it is new.
    pub fn raise(&mut self, f: DeviceFault) -> bool {
        let bit = 1u16 << f.code();
        let new = self.bits & bit == 0;
        self.bits |= bit;
        new
    }

    /// Is this fault recorded?
    pub const fn contains(self, f: DeviceFault) -> bool {
        self.bits & (1u16 << f.code()) != 0
    }

    /// Any fault at all?
    pub const fn any(self) -> bool {
        self.bits != 0
    }

    /// The fault reported on CAN: the first raised in code order (the
    /// lowest code), or `None`.
    pub fn first(self) -> Option<DeviceFault> {
        DeviceFault::ALL.iter().copied().find(|f| self.contains(*f))
    }

    /// Wire code of [`Self::first`], 0 when there is none.
    pub fn code(self) -> u8 {
        self.first().map_or(0, DeviceFault::code)
    }

    /// All recorded faults as a bit set (bit = fault code).
    pub const fn bits(self) -> u16 {
        self.bits
    }

    /// The bit of one fault in [`Self::bits`].
    pub const fn bit(f: DeviceFault) -> u16 {
        1 << f.code()
    }

    /// Faults from a bit set (unknown bits are ignored).
    pub const fn from_bits(bits: u16) -> Self {
        Self {
            bits: bits & 0b1_1111_1110,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_zero_is_no_fault() {
        for f in DeviceFault::ALL {
            assert_eq!(DeviceFault::from_code(f.code()), Some(f));
        }
        assert_eq!(DeviceFault::from_code(0), None);
        assert_eq!(DeviceFault::from_code(9), None);
    }

    #[test]
    fn faults_latch_and_the_lowest_code_is_reported() {
        let mut d = DeviceFaults::NONE;
        assert!(!d.any());
        assert_eq!(d.code(), 0);
        assert!(d.raise(DeviceFault::RelayReadback));
        assert!(!d.raise(DeviceFault::RelayReadback), "already raised");
        assert!(d.raise(DeviceFault::Ram));
        assert_eq!(d.first(), Some(DeviceFault::Ram));
        assert_eq!(d.code(), 3);
        assert!(d.contains(DeviceFault::RelayReadback));
    }
}
