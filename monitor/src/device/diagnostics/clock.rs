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

/// The window the LSI counts are normalised to: 1 s of sample-clock time,
/// µs ([`ClockConfig::DEFAULT`]'s limits are per 1 s).
pub const WINDOW_US: u32 = 1_000_000;

/// LSI cycles per window of sample-clock time, from two consecutive input
/// captures of the LSI on a free-running 32-bit timer whose clock is the
/// sample clock's timer clock (the same crystal):
///
/// - `first`, `second`: the captured counter values (timer ticks); the
///   counter may wrap between them (a 32-bit counter at 84 MHz wraps every
///   51 s), so their difference is taken modulo 2³²;
/// - `lsi_cycles`: LSI cycles between the two captures (the capture
///   prescaler: one capture every 8 LSI edges is 8);
/// - `window_ticks`: timer ticks in one window ([`WINDOW_US`]) of sample
///   time, i.e. ticks per sample period × samples per window.
///
/// Rounded to the nearest cycle; `u32::MAX` (an impossible count, so a
/// fault) for two equal captures or a count beyond it.
pub fn lsi_cycles_per_window(first: u32, second: u32, lsi_cycles: u32, window_ticks: u64) -> u32 {
    let ticks = u64::from(second.wrapping_sub(first));
    if ticks == 0 {
        return u32::MAX;
    }
    match u64::from(lsi_cycles)
        .checked_mul(window_ticks)
        .and_then(|n| n.checked_add(ticks / 2))
    {
        Some(n) => u32::try_from(n / ticks).unwrap_or(u32::MAX),
        None => u32::MAX,
    }
}

/// Timer ticks in one window ([`WINDOW_US`]) of sample time, for a sample
/// period of `sample_period_ticks` timer ticks (its true length on the
/// timer clock, e.g. from PSC, ARR and scans per sample of the ADC
/// trigger) and `sample_period_us` µs nominal (> 0); saturating.
pub const fn window_ticks(sample_period_ticks: u64, sample_period_us: u32) -> u64 {
    sample_period_ticks.saturating_mul(WINDOW_US as u64) / sample_period_us as u64
}

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

    /// TIM5 on the APB1 timer clock (84 MHz), TIM3 triggering 4 scans per
    /// 1 ms sample with PSC 0 and ARR 20 999: 84 000 ticks per sample.
    const WINDOW_84MHZ: u64 = window_ticks(4 * 21_000, 1000);

    #[test]
    fn captures_convert_to_lsi_cycles_per_second_of_sample_time() {
        assert_eq!(WINDOW_84MHZ, 84_000_000);
        // 32 kHz LSI, a capture every 8 edges: 250 µs = 21 000 ticks apart.
        assert_eq!(
            lsi_cycles_per_window(1_000, 22_000, 8, WINDOW_84MHZ),
            32_000
        );
        // The datasheet's extremes, 17 and 47 kHz: the capture spacing is
        // quantised to a tick, 70 ppm of the 14 298 ticks at 47 kHz.
        for hz in [17_000u32, 47_000] {
            let ticks = (8 * 84_000_000 + u64::from(hz) / 2) / u64::from(hz);
            let n = lsi_cycles_per_window(0, ticks as u32, 8, WINDOW_84MHZ);
            assert!(n.abs_diff(hz) <= hz / 10_000, "{hz} Hz: {n}");
        }
        // Rounded to the nearest cycle: 21 001 ticks is 31 998.48 → 31 998,
        // 20 999 ticks 32 001.52 → 32 002.
        assert_eq!(lsi_cycles_per_window(0, 21_001, 8, WINDOW_84MHZ), 31_998);
        assert_eq!(lsi_cycles_per_window(0, 20_999, 8, WINDOW_84MHZ), 32_002);
    }

    #[test]
    fn the_counter_may_wrap_between_the_captures() {
        let first = u32::MAX - 5_000;
        let second = first.wrapping_add(21_000);
        assert!(second < first);
        assert_eq!(
            lsi_cycles_per_window(first, second, 8, WINDOW_84MHZ),
            32_000
        );
        assert_eq!(
            lsi_cycles_per_window(u32::MAX, 20_999, 8, WINDOW_84MHZ),
            32_000
        );
    }

    #[test]
    fn a_slower_timer_clock_shows_as_more_lsi_cycles_and_is_caught() {
        // The crystal lost, the core on the 16 MHz HSI: the APB1 timer clock
        // is 8 MHz instead of 84, so 8 LSI cycles span 10.5 times fewer
        // ticks, and a "second" of samples lasts 10.5 s of LSI time.
        let ticks = 21_000 * 8 / 84;
        let n = lsi_cycles_per_window(0, ticks, 8, WINDOW_84MHZ);
        assert_eq!(n, 336_000);
        let mut c = ClockCheck::new(ClockConfig::DEFAULT);
        assert!(!c.check(lsi_cycles_per_window(0, 21_000, 8, WINDOW_84MHZ), false));
        assert!(!c.check(n, false));
        assert!(c.check(n, false));
    }

    #[test]
    fn equal_captures_or_an_overflowing_count_are_impossible_counts() {
        assert_eq!(lsi_cycles_per_window(7, 7, 8, WINDOW_84MHZ), u32::MAX);
        assert_eq!(lsi_cycles_per_window(0, 1, 8, u64::MAX), u32::MAX);
        let mut c = ClockCheck::new(ClockConfig::DEFAULT);
        assert!(c.check(u32::MAX, false), "outside the datasheet range");
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
