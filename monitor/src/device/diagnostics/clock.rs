//! The clock cross-check: the 1 kHz sample clock (from the crystal through
//! the PLL) is compared against the independent internal low-speed
//! oscillator (LSI, ~32 kHz, its own RC). The LSI's absolute frequency is
//! poor (17–47 kHz over parts, datasheet DS8626), but it drifts only a few
//! per cent with temperature and supply, so it is measured once at boot
//! (when the clock security system has just confirmed the crystal) and then
//! every window must agree with that measurement. A crystal or PLL fault
//! that changes the sample rate (the sample period and every time constant
//! of the model with it) is then caught even if the clock security system
//! missed it; a trip of the clock security system is a fault at once.

/// Limits of the clock cross-check.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClockConfig {
    /// LSI cycles per window the datasheet allows, lowest and highest
    /// (17–47 kHz over a 1 s window).
    pub lsi_range: (u32, u32),
    /// Largest accepted change from the boot measurement, as a fraction.
    pub tolerance: f32,
    /// Consecutive windows out of tolerance before it is a fault.
    pub debounce: u8,
}

impl ClockConfig {
    /// 1 s windows, ±15 % (LSI drift is a few %; a PLL or crystal fault is
    /// tens of % or a factor), two windows.
    pub const DEFAULT: Self = Self {
        lsi_range: (17_000, 47_000),
        tolerance: 0.15,
        debounce: 2,
    };
}

/// The clock cross-check, fed the LSI cycles counted over each window of
/// sample-clock time.
#[derive(Clone, Debug)]
pub struct ClockCheck {
    cfg: ClockConfig,
    reference: Option<u32>,
    bad: u8,
}

impl ClockCheck {
    /// A check not yet referenced.
    pub const fn new(cfg: ClockConfig) -> Self {
        Self {
            cfg,
            reference: None,
            bad: 0,
        }
    }

    /// The boot reference, LSI cycles per window, once measured.
    pub const fn reference(&self) -> Option<u32> {
        self.reference
    }

    /// Feed one window's LSI count and whether the clock security system
    /// tripped; true when the clocks are faulty. The first count becomes
    /// the reference (outside the datasheet range it is a fault at once).
    pub fn check(&mut self, lsi_cycles: u32, css_tripped: bool) -> bool {
        if css_tripped {
            return true;
        }
        let Some(r) = self.reference else {
            let (lo, hi) = self.cfg.lsi_range;
            if (lo..=hi).contains(&lsi_cycles) {
                self.reference = Some(lsi_cycles);
                return false;
            }
            return true;
        };
        let dev = (lsi_cycles as f32 - r as f32).abs() / r as f32;
        if dev > self.cfg.tolerance {
            self.bad = self.bad.saturating_add(1);
        } else {
            self.bad = 0;
        }
        self.bad >= self.cfg.debounce
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drift_is_tolerated_a_clock_ratio_off_is_a_fault() {
        let mut c = ClockCheck::new(ClockConfig::DEFAULT);
        assert!(!c.check(31_000, false));
        assert_eq!(c.reference(), Some(31_000));
        for k in 0..100 {
            // ±3 % wander.
            assert!(!c.check(31_000 + (k % 7) * 150 - 450, false));
        }
        // The crystal lost: the PLL runs from the 16 MHz HSI instead of 8 MHz
        // HSE ×21, so a "second" of samples lasts 10.5 s of LSI time.
        assert!(!c.check(325_000, false), "one window is debounced");
        assert!(c.check(325_000, false));
    }

    #[test]
    fn a_css_trip_or_an_impossible_lsi_is_a_fault_at_once() {
        let mut c = ClockCheck::new(ClockConfig::DEFAULT);
        assert!(c.check(32_000, true));
        let mut c = ClockCheck::new(ClockConfig::DEFAULT);
        assert!(c.check(3_000, false), "LSI far outside its datasheet range");
        assert_eq!(c.reference(), None);
    }
}
