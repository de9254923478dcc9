//! A timer's prescaler and auto-reload for an update rate (any STM32
//! general-purpose 16-bit timer).

/// Prescaler and auto-reload register values (PSC, ARR) that make a 16-bit
/// timer clocked at `timer_hz` update at `rate_hz`, or at the nearest rate
/// above it when `timer_hz / rate_hz` does not factor exactly; `None` when
/// no setting reaches it (a rate of 0, or above half the timer clock).
///
/// Written here rather than through embassy's `Timer::set_frequency`,
/// whose `unwrap`s link `core::fmt` (≈ 1.4 KB) into the image.
pub const fn timer_period(timer_hz: u32, rate_hz: u32) -> Option<(u16, u16)> {
    if rate_hz == 0 || timer_hz / rate_hz < 2 {
        return None;
    }
    let clocks = timer_hz / rate_hz;
    // The smallest prescaler that lets ARR fit in 16 bits: finest steps.
    let psc = (clocks - 1) / 65_536;
    if psc > u16::MAX as u32 {
        return None;
    }
    let arr = clocks / (psc + 1) - 1;
    Some((psc as u16, arr as u16))
}

/// Timer clock ticks per update of a timer set to `(psc, arr)`:
/// (PSC + 1) × (ARR + 1). The true period of what the timer paces, on its
/// own clock (e.g. the ADC trigger's scan period).
pub const fn period_ticks(psc: u16, arr: u16) -> u64 {
    (psc as u64 + 1) * (arr as u64 + 1)
}

#[cfg(test)]
mod tests {
    use super::{period_ticks, timer_period};

    fn rate(timer_hz: u32, (psc, arr): (u16, u16)) -> f64 {
        timer_hz as f64 / ((psc as f64 + 1.0) * (arr as f64 + 1.0))
    }

    #[test]
    fn the_adc_trigger_is_exact_at_84_mhz() {
        // TIM3 on APB1 ×2 = 84 MHz, 4 scans per 1 ms sample.
        assert_eq!(timer_period(84_000_000, 4_000), Some((0, 20_999)));
    }

    #[test]
    fn slow_rates_use_the_prescaler_and_never_run_slow() {
        for (timer_hz, rate_hz) in [
            (84_000_000, 1),
            (84_000_000, 7),
            (168_000_000, 3),
            (1_000_000, 999),
        ] {
            let Some(p) = timer_period(timer_hz, rate_hz) else {
                panic!("{timer_hz} / {rate_hz}");
            };
            let got = rate(timer_hz, p);
            assert!(
                got >= rate_hz as f64 && got < rate_hz as f64 * 1.001,
                "{got}"
            );
        }
    }

    #[test]
    fn period_ticks_are_the_timers_true_period() {
        assert_eq!(period_ticks(0, 20_999), 21_000);
        assert_eq!(period_ticks(u16::MAX, u16::MAX), 1 << 32);
        for (timer_hz, rate_hz) in [(84_000_000, 4_000), (84_000_000, 7), (1_000_000, 999)] {
            let Some((psc, arr)) = timer_period(timer_hz, rate_hz) else {
                panic!("{timer_hz} / {rate_hz}");
            };
            let ticks = period_ticks(psc, arr);
            assert!(
                ticks <= u64::from(timer_hz / rate_hz),
                "never slower than asked"
            );
            assert_eq!(rate(timer_hz, (psc, arr)), timer_hz as f64 / ticks as f64);
        }
    }

    #[test]
    fn unreachable_rates_are_refused() {
        assert_eq!(timer_period(84_000_000, 0), None);
        assert_eq!(timer_period(84_000_000, 50_000_000), None);
        assert_eq!(timer_period(4_000_000_000, 0), None);
    }
}
