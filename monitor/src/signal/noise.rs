//! Each reading's white-noise level, estimated online from the data.
//!
//! The filters' measurement noise must be the noise the installation
//! really has: pump ripple, long cables and a 12-bit ADC on a 250 bar loop
//! give chamber readings with 0.02–0.6 bar of noise, where a configured
//! 0.08 bar made the filters several times overconfident (normalised
//! innovations of 20 instead of 3) and the leak states chased noise.
//!
//! The estimate is model-free: the second difference of consecutive
//! readings, d = y[k] − 2·y[k−1] + y[k−2], removes the signal's level and
//! slope (at 1 kHz a hydraulic signal's curvature is far below its noise),
//! and for white noise of σ has E|d| = √6·√(2/π)·σ. Its running mean is
//! robust: each |d| is clipped at [`CLIP`] times the current mean, so
//! valve steps, spikes and breakaway add almost nothing, while a real
//! rise of the noise is followed within a few time constants.

use crate::real::Real;

/// E|d| / σ for white noise: √6 · √(2/π).
const MEAN_ABS_PER_SIGMA: f32 = 1.954_410_7;
/// A |d| beyond this many times the running mean counts as this much.
const CLIP: f32 = 4.0;

/// The running estimate for one channel.
#[derive(Clone, Debug)]
pub struct NoiseEstimate {
    /// The previous two readings (newest first) and how many are held.
    prev: [f32; 2],
    held: u8,
    /// Running mean of |d|, in the reading's unit.
    mean_abs: f32,
    /// Smallest σ reported, in the reading's unit.
    floor: f32,
    /// Smoothing per sample (sample period / time constant).
    alpha: f32,
}

impl NoiseEstimate {
    /// Start at `initial` σ (the configured or calibrated level), never
    /// reporting below `floor`; the estimate follows the data with time
    /// constant `time_constant_s` at a sample period of `period_s`.
    pub fn new(initial: f32, floor: f32, time_constant_s: f32, period_s: f32) -> Self {
        Self {
            prev: [0.0; 2],
            held: 0,
            mean_abs: initial.max(floor) * MEAN_ABS_PER_SIGMA,
            floor,
            alpha: (period_s / time_constant_s).clamp(1e-6, 1.0),
        }
    }

    /// Take the next reading (every valid sample, in order).
    pub fn update(&mut self, y: f32) {
        if self.held == 2 {
            // `Real::min`/`max` compare and select; core's call fminf.
            let d = (y - 2.0 * self.prev[0] + self.prev[1]).abs();
            let d = Real::min(d, CLIP * self.mean_abs);
            self.mean_abs += self.alpha * (d - self.mean_abs);
            // Never collapse to zero (a quantised, noise-free recording
            // repeats values at every hold): the floor keeps a level.
            self.mean_abs = Real::max(self.mean_abs, self.floor * MEAN_ABS_PER_SIGMA);
        } else {
            self.held += 1;
        }
        self.prev = [y, self.prev[0]];
    }

    /// Forget the previous readings (after a gap or a fault); the level
    /// is kept.
    pub fn break_sequence(&mut self) {
        self.held = 0;
    }

    /// The estimated white-noise σ, in the reading's unit.
    pub fn sigma(&self) -> f32 {
        self.mean_abs / MEAN_ABS_PER_SIGMA
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::Lcg;

    fn run(sigma: f32, signal: impl Fn(f32) -> f32, seconds: f32) -> f32 {
        let mut rng = Lcg::new(7);
        let mut n = NoiseEstimate::new(0.08, 0.001, 2.0, 1e-3);
        let samples = (seconds * 1000.0) as usize;
        for k in 0..samples {
            let t = k as f32 * 1e-3;
            n.update(signal(t) + sigma * rng.gaussian() as f32);
        }
        n.sigma()
    }

    #[test]
    fn finds_the_white_noise_level_from_above_and_below() {
        for sigma in [0.02_f32, 0.08, 0.3, 0.6] {
            let got = run(sigma, |_| 20.0, 20.0);
            assert!((got / sigma - 1.0).abs() < 0.1, "σ {sigma}: {got}");
        }
    }

    #[test]
    fn ramps_and_steps_of_the_signal_are_not_noise() {
        // A 100 bar/s ramp, then a 15 bar step every 2 s.
        let signal = |t: f32| 10.0 + 100.0 * t.min(0.2) + 15.0 * ((t / 2.0).floor() % 2.0);
        let got = run(0.1, signal, 20.0);
        assert!((got / 0.1 - 1.0).abs() < 0.15, "{got}");
    }

    #[test]
    fn a_noise_free_quantised_reading_stays_at_the_floor() {
        let mut n = NoiseEstimate::new(0.08, 0.01, 2.0, 1e-3);
        for _ in 0..20_000 {
            n.update(12.5);
        }
        assert!((n.sigma() - 0.01).abs() < 1e-6, "{}", n.sigma());
    }
}
