//! Keeping the filters consistent with the data they see.
//!
//! The white noise of each reading is estimated model-free
//! (`signal::noise`). What the model cannot explain — coloured noise,
//! pump ripple, a transmitter's lag, the valve's land leakage of another
//! structure, friction of another law — also reaches the innovations. A
//! filter that takes all of it for information is overconfident (mean
//! NIS of 10–25 instead of 3): its leak states chase model error and every
//! hypothesis' likelihood collapses, so the probabilities decide nothing.
//!
//! Covariance matching (Mehra): the innovation ν of reading k has
//! variance E[ν²] = HPHᵀ + R. Averaging ν² and HPHᵀ of the most general
//! filter (`both`) over [`MATCH_TIME_S`] gives the noise the data shows,
//! R = E[ν²] − E[HPHᵀ], used when it exceeds the white noise. It is bounded
//! above ([`MAX_INFLATION`]) so that a model that does not fit at all is
//! reported as a misfit (NIS) rather than absorbed, and each ν² enters
//! clipped ([`CLIP_NIS`]) so that one spike does not inflate it.

use crate::estimation::bank::NZ;
use crate::real::Real;

/// Averaging time of the innovation statistics, s.
pub const MATCH_TIME_S: f64 = 5.0;
/// R is at most this many times the white noise variance.
pub const MAX_INFLATION: f64 = 25.0;
/// A single ν² counts at most this many times its predicted variance.
const CLIP_NIS: f64 = 25.0;

/// Running innovation statistics per reading.
#[derive(Clone, Debug)]
pub struct NoiseMatch<T> {
    nu2: [T; NZ],
    hph: [T; NZ],
    started: bool,
}

impl<T: Real> Default for NoiseMatch<T> {
    fn default() -> Self {
        Self {
            nu2: [T::ZERO; NZ],
            hph: [T::ZERO; NZ],
            started: false,
        }
    }
}

impl<T: Real> NoiseMatch<T> {
    /// Forget the statistics (the filters restarted).
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// Take one step's innovations ν² and state-uncertainty variances HPHᵀ
    /// with the R they were computed with, `dt` seconds long.
    pub fn update(&mut self, nu2: &[T; NZ], hph: &[T; NZ], r: &[T; NZ], dt: T) {
        let a = (dt / T::c(MATCH_TIME_S)).min(T::ONE);
        for k in 0..NZ {
            let s = hph[k] + r[k];
            let v = nu2[k].min(T::c(CLIP_NIS) * s);
            if self.started {
                self.nu2[k] += a * (v - self.nu2[k]);
                self.hph[k] += a * (hph[k] - self.hph[k]);
            } else {
                self.nu2[k] = s;
                self.hph[k] = hph[k];
            }
        }
        self.started = true;
    }

    /// The measurement noise variances to use, given the white noise
    /// variances `white`.
    pub fn matched(&self, white: &[T; NZ]) -> [T; NZ] {
        core::array::from_fn(|k| {
            let seen = self.nu2[k] - self.hph[k];
            seen.clamp_to(white[k], white[k] * T::c(MAX_INFLATION))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn innovations_larger_than_predicted_inflate_r_up_to_a_bound() {
        let mut m = NoiseMatch::<f64>::default();
        let white = [1.0; NZ];
        for _ in 0..20_000 {
            // ν² averages 4 with HPHᵀ 0.5: R should become 3.5.
            m.update(&[4.0, 4.0, 400.0], &[0.5; NZ], &[1.0; NZ], 1e-3);
        }
        let r = m.matched(&white);
        assert!((r[0] - 3.5).abs() < 0.05, "{r:?}");
        assert_eq!(r[2], 25.0);
    }

    #[test]
    fn consistent_innovations_keep_the_white_noise() {
        let mut m = NoiseMatch::<f64>::default();
        for _ in 0..10_000 {
            m.update(&[1.2; NZ], &[0.4; NZ], &[1.0; NZ], 1e-3);
        }
        assert_eq!(m.matched(&[1.0; NZ]), [1.0; NZ]);
    }
}
