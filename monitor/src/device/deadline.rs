//! Deadline bookkeeping of the 1 kHz estimator: the sample clock (which
//! sample a block of ADC data is, across overruns), missed samples, and
//! the estimator's CPU load measured in cycles (DWT cycle counter on the
//! STM32).
//!
//! A sample is *missed* when its processing took longer than the sample
//! period, or when it was lost (the ADC ring buffer overran before it was
//! read).

/// Which sample a block of ADC data is; sample times for the monitor.
#[derive(Clone, Debug)]
pub(crate) struct SampleClock {
    period_us: u32,
    next: u64,
}

impl SampleClock {
    /// A clock for samples every `period_us` µs (> 0), starting at 0.
    pub const fn new(period_us: u32) -> Self {
        Self {
            period_us: if period_us == 0 { 1 } else { period_us },
            next: 0,
        }
    }

    /// Index of the next sample in sequence (0, 1, 2, …); advances.
    pub fn next_index(&mut self) -> u64 {
        let i = self.next;
        self.next += 1;
        i
    }

    /// After an overrun: the sample now arriving was taken `elapsed_us`
    /// after sample 0. Sets the clock so that [`next_index`] returns it
    /// and returns how many samples were lost in between.
    ///
    /// [`next_index`]: Self::next_index
    pub fn resync(&mut self, elapsed_us: u64) -> u32 {
        let p = self.period_us as u64;
        let now = (elapsed_us + p / 2) / p;
        let lost = now.saturating_sub(self.next);
        self.next = self.next.max(now);
        lost.min(u32::MAX as u64) as u32
    }

    /// Time of sample `index`, s.
    pub fn t_s(&self, index: u64) -> f64 {
        index as f64 * self.period_us as f64 * 1e-6
    }

    /// Time of sample `index`, ms.
    pub fn t_ms(&self, index: u64) -> u64 {
        index * self.period_us as u64 / 1000
    }
}

/// Load and deadline figures over one report period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadReport {
    /// Samples processed.
    pub processed: u32,
    /// Samples missed (late or lost).
    pub missed: u32,
    /// ADC overruns.
    pub overruns: u32,
    /// Estimator busy time over the period, % (rounded, saturating at 255).
    pub load_pct: u8,
    /// Longest single step, % of the sample period (saturating at 255).
    pub peak_pct: u8,
}

#[derive(Clone, Copy, Debug, Default)]
struct Window {
    busy_cycles: u64,
    peak_cycles: u32,
    processed: u32,
    lost: u32,
    missed: u32,
    overruns: u32,
}

/// Counts missed samples and measures the estimator's load.
#[derive(Clone, Debug)]
pub(crate) struct DeadlineMonitor {
    cycles_per_sample: u32,
    window: Window,
    processed_total: u32,
    missed_total: u32,
    overruns_total: u32,
}

fn pct(num: u64, den: u64) -> u8 {
    if den == 0 {
        return 0;
    }
    ((num * 100 + den / 2) / den).min(u8::MAX as u64) as u8
}

impl DeadlineMonitor {
    /// A monitor for a budget of `cycles_per_sample` CPU cycles per
    /// sample (168 000 at 168 MHz and 1 kHz).
    pub const fn new(cycles_per_sample: u32) -> Self {
        Self {
            cycles_per_sample,
            window: Window {
                busy_cycles: 0,
                peak_cycles: 0,
                processed: 0,
                lost: 0,
                missed: 0,
                overruns: 0,
            },
            processed_total: 0,
            missed_total: 0,
            overruns_total: 0,
        }
    }

    /// One sample was processed in `busy_cycles`; returns true if that
    /// missed the deadline.
    pub fn processed(&mut self, busy_cycles: u32) -> bool {
        let w = &mut self.window;
        w.busy_cycles += busy_cycles as u64;
        w.peak_cycles = w.peak_cycles.max(busy_cycles);
        w.processed += 1;
        self.processed_total = self.processed_total.wrapping_add(1);
        let late = busy_cycles > self.cycles_per_sample;
        if late {
            w.missed += 1;
            self.missed_total = self.missed_total.wrapping_add(1);
        }
        late
    }

    /// An ADC overrun lost `lost` samples.
    pub fn overrun(&mut self, lost: u32) {
        let w = &mut self.window;
        w.overruns += 1;
        w.lost = w.lost.saturating_add(lost);
        w.missed = w.missed.saturating_add(lost);
        self.overruns_total = self.overruns_total.wrapping_add(1);
        self.missed_total = self.missed_total.wrapping_add(lost);
    }

    /// The figures since the previous report; starts a new period.
    pub fn take_report(&mut self) -> LoadReport {
        let w = core::mem::take(&mut self.window);
        let elapsed = (w.processed as u64 + w.lost as u64) * self.cycles_per_sample as u64;
        LoadReport {
            processed: w.processed,
            missed: w.missed,
            overruns: w.overruns,
            load_pct: pct(w.busy_cycles, elapsed),
            peak_pct: pct(w.peak_cycles as u64, self.cycles_per_sample as u64),
        }
    }

    /// Samples processed since start (wrapping).
    pub fn processed_total(&self) -> u32 {
        self.processed_total
    }

    /// Samples missed since start (wrapping).
    pub fn missed_total(&self) -> u32 {
        self.missed_total
    }

    /// ADC overruns since start (wrapping).
    #[cfg(test)]
    pub fn overruns_total(&self) -> u32 {
        self.overruns_total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_counts_samples_and_resyncs_after_an_overrun() {
        let mut c = SampleClock::new(1000);
        assert_eq!(c.next_index(), 0);
        assert_eq!(c.next_index(), 1);
        // Sample 2 was expected; the block now arriving was taken 5.02 ms
        // after sample 0: samples 2, 3, 4 were lost.
        assert_eq!(c.resync(5_020), 3);
        assert_eq!(c.next_index(), 5);
        assert_eq!(c.t_s(5), 0.005);
        assert_eq!(c.t_ms(1_234), 1_234u64);
        // A resync that finds nothing lost never goes back in time.
        assert_eq!(c.resync(1_000), 0);
        assert_eq!(c.next_index(), 6);
    }

    #[test]
    fn load_peak_and_missed_samples() {
        let mut d = DeadlineMonitor::new(168_000);
        for _ in 0..998 {
            assert!(!d.processed(42_000));
        }
        assert!(d.processed(252_000), "1.5 ms step misses its deadline");
        assert!(!d.processed(168_000), "exactly the budget is on time");
        let r = d.take_report();
        assert_eq!(r.processed, 1000);
        assert_eq!(r.missed, 1);
        assert_eq!(r.peak_pct, 150);
        // (998·42 000 + 252 000 + 168 000) / (1000·168 000) = 25.2 %
        assert_eq!(r.load_pct, 25);
        assert_eq!(d.take_report(), LoadReport::default());
    }

    #[test]
    fn lost_samples_are_missed_and_count_as_elapsed_time() {
        let mut d = DeadlineMonitor::new(1000);
        for _ in 0..90 {
            d.processed(500);
        }
        d.overrun(10);
        let r = d.take_report();
        assert_eq!((r.processed, r.missed, r.overruns), (90, 10, 1));
        assert_eq!(r.load_pct, 45);
        assert_eq!(
            (d.missed_total(), d.overruns_total(), d.processed_total()),
            (10, 1, 90)
        );
    }

    #[test]
    fn percentages_saturate() {
        let mut d = DeadlineMonitor::new(100);
        d.processed(u32::MAX);
        let r = d.take_report();
        assert_eq!((r.load_pct, r.peak_pct), (255, 255));
    }
}
