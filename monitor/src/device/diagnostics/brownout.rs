//! The brown-out reset level: the STM32F405 holds itself in reset below a
//! supply threshold set in its option bytes (FLASH_OPTCR.BOR_LEV). From the
//! factory it is off (reset only at ~1.8 V), where the ADC and the flash
//! are out of specification long before the core stops. The firmware
//! requires level 3 (2.70 V typ.), programs it at boot when it is lower,
//! and checks it on every boot.

/// BOR_LEV field of FLASH_OPTCR: bits 3:2.
const SHIFT: u32 = 2;
const MASK: u32 = 0b11 << SHIFT;

/// A brown-out reset level (RM0090 §3.6.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BorLevel {
    /// Off: only the power-on/power-down reset (~1.8 V).
    Off = 0,
    /// Level 1, 2.1 V typ.
    L1 = 1,
    /// Level 2, 2.4 V typ.
    L2 = 2,
    /// Level 3, 2.7 V typ.
    L3 = 3,
}

/// The level the monitor requires: its analogue front end and ADC are
/// specified on a 3.3 V supply, so it resets at 2.7 V.
pub const REQUIRED: BorLevel = BorLevel::L3;

/// The level an FLASH_OPTCR value programs.
pub const fn level(optcr: u32) -> BorLevel {
    // The field counts down: 00 = level 3 … 11 = off.
    match (optcr & MASK) >> SHIFT {
        0b00 => BorLevel::L3,
        0b01 => BorLevel::L2,
        0b10 => BorLevel::L1,
        _ => BorLevel::Off,
    }
}

/// The FLASH_OPTCR value to program if the level is below
/// [`REQUIRED`], or `None` when it already is at least that.
pub fn required_optcr(optcr: u32) -> Option<u32> {
    if level(optcr) >= REQUIRED {
        None
    } else {
        Some(optcr & !MASK)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factory_default_is_reprogrammed_to_level_3_only() {
        // RM0090: FLASH_OPTCR reset value 0x0FFF_AAED (BOR_LEV = 11, off).
        let factory = 0x0FFF_AAED;
        assert_eq!(level(factory), BorLevel::Off);
        let fixed = required_optcr(factory).expect("needs programming");
        assert_eq!(level(fixed), BorLevel::L3);
        assert_eq!(fixed | MASK, factory, "no other option bit changes");
        assert_eq!(required_optcr(fixed), None);
        assert!(
            required_optcr(factory & !(0b10 << SHIFT)).is_some(),
            "level 2 is not enough"
        );
    }
}
