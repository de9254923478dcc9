//! Sensor noise from the recording itself.
//!
//! The white-noise σ of each channel comes from the second difference
//! `d[k] = y[k] − 2·y[k−1] + y[k−2]`: a signal that is smooth at the sample
//! rate (a pressure or a position under hydraulic dynamics) all but cancels
//! in it, while white noise of σ gives `d` a σ of √6·σ. Its spread is taken
//! robustly, as the median absolute deviation × 1.4826, over holds and slow
//! moves only, so that valve steps and pressure transients (a few per cent
//! of the samples at most) do not count.
//!
//! Noise that is not white (pump ripple, mains pickup on long cables) is
//! largely invisible to the second difference at low frequencies; it shows
//! in the residual around a 21-sample (≈ 20 ms) moving average, whose σ
//! exceeds the white σ by the coloured part: `coloured² = σ_res² −
//! σ_white²·(1 − 1/21)`.
//!
//! A reading quantised with step q has at least q/√12 of noise however
//! clean the transmitter is: the step is the smallest non-zero change
//! between consecutive readings, and the estimate never goes below q/√12.

use monitor::Sample;

/// The channels whose noise is estimated.
pub const CHANNELS: [(&str, &str); 5] = [
    ("p_supply", "bar"),
    ("p_piston", "bar"),
    ("p_rod", "bar"),
    ("p_tank", "bar"),
    ("x_piston", "m"),
];

/// Half-width of the moving average for the coloured part, samples.
const RIPPLE_HALF_WINDOW: usize = 10;
/// Holds and slow moves: smoothed piston speed below this, m/s. The thesis
/// profile's slow ramps are 10–25 mm/s, its fast ramps ≈ 43 mm/s.
const SLOW_SPEED_M_S: f64 = 0.03;
/// MAD of a normal distribution × this = its σ.
const MAD_TO_SIGMA: f64 = 1.482_6;

/// One channel's noise figures, in the channel's unit.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelNoise {
    /// Channel name, as in the recording.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// White-noise σ (second-difference estimate).
    pub white: f64,
    /// σ of the residual around a 20 ms moving average.
    pub residual: f64,
    /// Coloured (ripple) part: what the residual has beyond white noise.
    pub coloured: f64,
    /// Quantisation step found in the data (0 if none).
    pub step: f64,
    /// Samples the estimate used.
    pub samples: usize,
}

impl ChannelNoise {
    /// The white σ, never below the quantisation noise q/√12.
    pub fn floored(&self) -> f64 {
        self.white.max(self.step / 12f64.sqrt())
    }
}

fn channel(s: &Sample, i: usize) -> Option<f32> {
    match i {
        0 => s.p_supply_bar,
        1 => s.p_piston_bar,
        2 => s.p_rod_bar,
        3 => s.p_tank_bar,
        _ => s.x_piston_m,
    }
}

/// Median of `v` (reorders it); NaN if empty.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Robust σ: MAD × 1.4826 (reorders `v`).
fn robust_sigma(v: &mut [f64]) -> f64 {
    let m = median(v);
    for x in v.iter_mut() {
        *x = (*x - m).abs();
    }
    MAD_TO_SIGMA * median(v)
}

/// Smallest non-zero change between consecutive readings: the quantisation
/// step (or something far below the noise if the data are not quantised).
fn quantisation_step(y: &[f64]) -> f64 {
    let mut step = f64::INFINITY;
    for w in y.windows(2) {
        let d = (w[1] - w[0]).abs();
        // f32 storage: ignore rounding differences of the value itself.
        if d > 1e-6 * w[1].abs().max(1e-3) && d < step {
            step = d;
        }
    }
    if step.is_finite() {
        step
    } else {
        0.0
    }
}

/// Samples at holds and slow moves (smoothed piston speed below
/// `SLOW_SPEED_M_S`), by index.
fn slow_mask(samples: &[Sample]) -> Vec<bool> {
    let n = samples.len();
    let h = 10;
    let mut mask = vec![false; n];
    for i in h..n.saturating_sub(h) {
        let (a, b) = (&samples[i - h], &samples[i + h]);
        if let (Some(xa), Some(xb)) = (a.x_piston_m, b.x_piston_m) {
            let dt = b.t_s - a.t_s;
            mask[i] = dt > 0.0 && ((xb - xa) as f64 / dt).abs() < SLOW_SPEED_M_S;
        }
    }
    mask
}

/// Estimate every channel's noise from the recording.
pub fn estimate(samples: &[Sample]) -> Vec<ChannelNoise> {
    let slow = slow_mask(samples);
    let h = RIPPLE_HALF_WINDOW;
    let width = (2 * h + 1) as f64;
    CHANNELS
        .iter()
        .enumerate()
        .map(|(c, &(name, unit))| {
            let y: Vec<f64> = samples
                .iter()
                .map(|s| channel(s, c).map_or(f64::NAN, f64::from))
                .collect();
            let step = quantisation_step(&y);
            let mut d2 = Vec::with_capacity(y.len());
            let mut res = Vec::with_capacity(y.len());
            let mut sum = 0.0;
            let mut finite_run = 0usize;
            for k in 0..y.len() {
                // Running sum of the last 2h+1 readings (all finite).
                if y[k].is_finite() {
                    sum += y[k];
                    finite_run += 1;
                } else {
                    sum = 0.0;
                    finite_run = 0;
                }
                if finite_run > 2 * h + 1 {
                    sum -= y[k - 2 * h - 1];
                }
                if finite_run > 2 * h && slow[k - h] {
                    res.push(y[k - h] - sum / width);
                }
                if finite_run >= 3 && slow[k] {
                    d2.push(y[k] - 2.0 * y[k - 1] + y[k - 2]);
                }
            }
            let samples_used = d2.len();
            let white = robust_sigma(&mut d2) / 6f64.sqrt();
            let residual = robust_sigma(&mut res);
            let coloured = (residual * residual - white * white * (1.0 - 1.0 / width))
                .max(0.0)
                .sqrt();
            ChannelNoise {
                name,
                unit,
                white,
                residual,
                coloured,
                step,
                samples: samples_used,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    fn recording(f: impl Fn(f64, f64) -> f64, sigma: f64) -> Vec<Sample> {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        (0..20_000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let n: f64 = rng.sample(StandardNormal);
                let p = f(t, sigma * n) as f32;
                Sample {
                    t_s: t,
                    p_supply_bar: Some(p),
                    p_piston_bar: Some(p),
                    p_rod_bar: Some(p),
                    p_tank_bar: Some(p),
                    x_piston_m: Some(0.05),
                    u_valve: Some(0.0),
                    temp_oil_c: None,
                }
            })
            .collect()
    }

    #[test]
    fn white_noise_on_a_moving_signal() {
        // A slow swing plus occasional 5 bar steps, 0.2 bar of noise.
        let s = recording(
            |t, n| 30.0 + 3.0 * (2.0 * t).sin() + 5.0 * ((t * 2.0) as i64 % 2) as f64 + n,
            0.2,
        );
        let e = estimate(&s);
        assert!((e[1].white / 0.2 - 1.0).abs() < 0.05, "{e:?}");
        // The steps (4 % of the samples within 10 of one) leak a little
        // into the moving-average residual: < 6 % of the white σ in
        // quadrature.
        assert!(e[1].coloured < 0.35 * 0.2, "{e:?}");
    }

    #[test]
    fn ripple_shows_as_coloured() {
        // 0.05 bar white plus a 0.3 bar amplitude 40 Hz ripple.
        let s = recording(
            |t, n| 30.0 + 0.3 * (2.0 * std::f64::consts::PI * 40.0 * t).sin() + n,
            0.05,
        );
        let e = estimate(&s);
        assert!(e[1].coloured > 0.15, "{e:?}");
    }

    #[test]
    fn quantisation_floor() {
        // Noise well below the step: the reading toggles now and then.
        let s = recording(|_, n| ((30.0 + n) / 0.1).round() * 0.1, 0.03);
        let e = estimate(&s);
        assert!((e[1].step - 0.1).abs() < 1e-4, "{e:?}");
        assert!((e[1].floored() - 0.1 / 12f64.sqrt()).abs() < 1e-4, "{e:?}");
    }
}
