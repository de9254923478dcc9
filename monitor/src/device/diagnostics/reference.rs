//! The ADC reference check: the front end converts codes to volts assuming
//! VDDA = 3.3 V. The STM32's internal reference VREFINT (1.21 V typical,
//! 1.18–1.24 V over temperature, datasheet DS8626) is converted
//! periodically (by the supervisor, every 100 ms, between the scans of the
//! inputs); the VDDA it implies must stay within the analogue supply's
//! tolerance, or every analogue reading is scaled wrongly — a device
//! fault, never a leak.

/// VREFINT, typical, V.
pub const VREFINT_TYPICAL_V: f32 = 1.21;

/// Limits of the reference check.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReferenceConfig {
    /// The VDDA the front end assumes, V.
    pub vdda_nominal_v: f32,
    /// Largest accepted deviation of the implied VDDA, as a fraction. It
    /// covers VREFINT's own spread (±2.5 %) plus the supply regulator's.
    pub tolerance: f32,
    /// ADC full scale, counts.
    pub full_scale_counts: f32,
    /// Consecutive out-of-range readings before it is a fault (a single
    /// disturbed conversion is not).
    pub debounce: u16,
}

impl ReferenceConfig {
    /// 3.3 V ± 5 %, 12-bit ADC, 10 readings (1 s at one per 100 ms).
    pub const DEFAULT: Self = Self {
        vdda_nominal_v: 3.3,
        tolerance: 0.05,
        full_scale_counts: 4095.0,
        debounce: 10,
    };
}

/// The reference check, fed one VREFINT code per reading.
#[derive(Clone, Debug)]
pub struct ReferenceCheck {
    cfg: ReferenceConfig,
    bad: u16,
}

impl ReferenceCheck {
    /// A check with no reading yet.
    pub const fn new(cfg: ReferenceConfig) -> Self {
        Self { cfg, bad: 0 }
    }

    /// VDDA implied by a VREFINT code, V (infinite for code 0).
    pub fn implied_vdda_v(&self, code: u16) -> f32 {
        VREFINT_TYPICAL_V * self.cfg.full_scale_counts / code as f32
    }

    /// Feed one VREFINT code; true once the reference has been out of
    /// range for the debounce count.
    pub fn check(&mut self, code: u16) -> bool {
        let v = self.implied_vdda_v(code);
        let dev = (v - self.cfg.vdda_nominal_v).abs() / self.cfg.vdda_nominal_v;
        // `!(dev <= tol)` also catches NaN.
        if !(dev <= self.cfg.tolerance) {
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

    fn code_at(vdda: f32) -> u16 {
        (VREFINT_TYPICAL_V / vdda * 4095.0).round() as u16
    }

    #[test]
    fn nominal_supply_passes_a_drifted_one_is_a_fault_after_debounce() {
        let mut c = ReferenceCheck::new(ReferenceConfig::DEFAULT);
        for _ in 0..100 {
            assert!(!c.check(code_at(3.3)));
            assert!(!c.check(code_at(3.2)));
        }
        for k in 1..=10 {
            assert_eq!(c.check(code_at(2.9)), k == 10, "reading {k}");
        }
        let mut c = ReferenceCheck::new(ReferenceConfig::DEFAULT);
        for _ in 0..9 {
            assert!(
                !c.check(0),
                "a code of 0 (VREFINT not converted) counts as bad"
            );
        }
        assert!(!c.check(code_at(3.3)), "one good reading resets the count");
        for _ in 0..10 {
            c.check(4095);
        }
        assert!(c.check(4095));
    }
}
