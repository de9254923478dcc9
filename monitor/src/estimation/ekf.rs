//! A fixed-size extended Kalman filter core on nalgebra static matrices.
//!
//! The model supplies the covariance prediction (the bank exploits the
//! sparsity of its transition Jacobian, see `bank::Transition`);
//! measurements are direct readings of single states (H rows are unit
//! vectors), processed one scalar at a time. For independent measurement
//! noise this is exactly the batch update, needs no matrix inverse, and
//! makes the innovation covariance a scalar whose failure is easy to
//! detect. The covariance is updated in Joseph form,
//! P ← (I − k·hᵀ)·P·(I − k·hᵀ)ᵀ + k·r·kᵀ, which is the exact covariance of
//! the estimator for any gain k (the bank scales gains by learning
//! weights) and is written symmetrically, so P stays exactly symmetric.
//!
//! Within a filter step, after the prediction, P is read by its upper
//! triangle only (a ≤ b, and the diagonal): the prediction
//! (`bank::Transition::predict_covariance`) and every update but the
//! step's last write only that triangle, and the last update mirrors it,
//! so P is exactly symmetric again between steps
//! ([`Ekf::update_state_weighted`]'s `MIRROR`). A step that fails before
//! its last update leaves the lower triangle stale, but the monitor then
//! restarts that filter (`Monitor::step`), so it is never read.
//!
//! Finiteness is checked once per filter step ([`Ekf::check_finite`]), on
//! the state and the diagonal of P only: see there why that suffices.

use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// Why a filter step failed. The caller re-initialises that filter and
/// flags it; nothing panics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EkfError {
    /// The innovation variance of measurement `index` was not a positive
    /// finite number.
    InnovationCovariance {
        /// Which measurement of the update (0-based).
        index: u8,
    },
    /// The state or covariance became NaN or infinite.
    NonFinite,
}

/// State estimate and covariance of one filter.
#[derive(Clone, Debug, PartialEq)]
pub struct Ekf<T: Real, const N: usize> {
    /// State estimate.
    pub x: SVector<T, N>,
    /// Its covariance (kept exactly symmetric).
    pub p: SMatrix<T, N, N>,
}

/// The outcome of one scalar measurement update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScalarUpdate<T> {
    /// Innovation ν = z − x_j.
    pub innovation: T,
    /// Innovation variance s = P_jj + r.
    pub variance: T,
}

impl<T: Real, const N: usize> Ekf<T, N> {
    /// A filter at `x` with diagonal covariance `p_diag`.
    pub fn new(x: SVector<T, N>, p_diag: &SVector<T, N>) -> Self {
        Self {
            x,
            p: SMatrix::from_diagonal(p_diag),
        }
    }

    /// Update with a direct reading `z` of state `J` with noise variance
    /// `r`, in Joseph form, P left symmetric. `index` names the
    /// measurement in errors.
    #[cfg(test)]
    pub fn update_state<const J: usize>(
        &mut self,
        z: T,
        r: T,
        index: u8,
    ) -> Result<ScalarUpdate<T>, EkfError> {
        self.update_state_weighted::<J, true>(z, r, index, &[T::ONE; N])
    }

    /// As [`Self::update_state`], with the gain of each state scaled by its
    /// `weights` entry ∈ [0, 1] (conditional adaptation: slowly varying
    /// parameters do not learn from samples the model is known to describe
    /// poorly). The Joseph form gives the exact covariance of the estimator
    /// for any gain, so P stays consistent with what the filter does.
    ///
    /// Reads only P's upper triangle (a ≤ b) and writes it; with `MIRROR`
    /// also the lower one, so that P is exactly symmetric afterwards.
    /// Without, the lower triangle is left stale: for an update followed
    /// in the same filter step by one that mirrors (one store less per
    /// off-diagonal entry). The measured state `J` is a constant so that
    /// the entries of its column (read from row J below the diagonal) are
    /// at fixed offsets.
    ///
    /// Fails only on the innovation variance; a non-finite state or
    /// covariance is left for [`Self::check_finite`] at the end of the
    /// filter step (a non-finite P_jj is reported as
    /// [`EkfError::NonFinite`] here already, being the cause).
    #[inline(never)]
    pub fn update_state_weighted<const J: usize, const MIRROR: bool>(
        &mut self,
        z: T,
        r: T,
        index: u8,
        weights: &[T; N],
    ) -> Result<ScalarUpdate<T>, EkfError> {
        const { assert!(J < N) };
        let s = self.p[(J, J)] + r;
        if !(s > T::ZERO && finite(s)) {
            return Err(if self.p[(J, J)].is_finite() {
                EkfError::InnovationCovariance { index }
            } else {
                EkfError::NonFinite
            });
        }
        let nu = z - self.x[J];
        let inv_s = T::ONE / s;
        // Column J of P before the update (= P·h), from the upper triangle,
        // and the weighted gain.
        let pj: [T; N] = core::array::from_fn(|i| upper(&self.p, i, J));
        let k: [T; N] = core::array::from_fn(|i| pj[i] * inv_s * weights[i]);
        for (xi, ki) in self.x.iter_mut().zip(&k) {
            *xi += *ki * nu;
        }
        joseph_update::<T, N, MIRROR>(&mut self.p, &pj, &k, s);
        Ok(ScalarUpdate {
            innovation: nu,
            variance: s,
        })
    }

    /// The state and the covariance are finite.
    ///
    /// Only x and the diagonal of P are scanned, once per filter step
    /// after its updates: a non-finite off-diagonal P_ab reaches the
    /// diagonal or the state within one step. The prediction forms every
    /// diagonal entry of a plant row from all the covariances of that
    /// row's non-zero columns, and the p4 row of Φ reaches every state but
    /// ẋ_v (so any pair without ẋ_v hits P_p4p4); a non-finite P(ẋ_v, b)
    /// moves into the p4 column in the prediction, which the p4 reading's
    /// update then spreads into the gain, the state and the diagonal. A
    /// non-finite Φ entry or noise lands on the diagonal directly.
    pub fn check_finite(&self) -> Result<(), EkfError> {
        if all_finite(
            (0..N)
                .map(|i| self.x[i])
                .chain((0..N).map(|i| self.p[(i, i)])),
        ) {
            Ok(())
        } else {
            Err(EkfError::NonFinite)
        }
    }
}

/// P[a, b] from the upper triangle (P[b, a] below the diagonal).
#[inline(always)]
pub(crate) fn upper<T: Real, const N: usize>(p: &SMatrix<T, N, N>, a: usize, b: usize) -> T {
    if a <= b {
        p[(a, b)]
    } else {
        p[(b, a)]
    }
}

/// Joseph-form covariance update for a reading of state j (h = e_j), gain
/// `k`, innovation variance `s` = P_jj + r and `pj` = P·e_j before the
/// update. Elementwise, valid for any gain:
/// (I − k·hᵀ)·P·(I − k·hᵀ)ᵀ + k·r·kᵀ = P − k·pjᵀ − pj·kᵀ + s·k·kᵀ
///                                  = P − k·pjᵀ − t·kᵀ,  t = pj − s·k,
/// two multiply-adds per entry. (t is what the gain leaves of P·h: zero
/// for a state that learns fully, (1 − w)·pj for one whose gain is
/// weighted by w.) Only the upper triangle is computed; `MIRROR` copies
/// it into the lower one, so P is exactly symmetric.
#[inline(always)]
fn joseph_update<T: Real, const N: usize, const MIRROR: bool>(
    p: &mut SMatrix<T, N, N>,
    pj: &[T; N],
    k: &[T; N],
    s: T,
) {
    let t: [T; N] = core::array::from_fn(|a| pj[a] - s * k[a]);
    for a in 0..N {
        for b in a..N {
            let v = p[(a, b)] - k[a] * pj[b] - t[a] * k[b];
            p[(a, b)] = v;
            if MIRROR {
                p[(b, a)] = v;
            }
        }
    }
}

/// Every value is finite: v·0 is ±0 for a finite v and NaN for ±∞ or
/// NaN, and a sum of zeros stays zero while any NaN makes it NaN.
/// Branch-free, two FPU operations per value, exact (no overflow can fake
/// a failure).
#[inline(always)]
fn all_finite<T: Real>(values: impl Iterator<Item = T>) -> bool {
    values.fold(T::ZERO, |acc, v| acc + v * T::ZERO) == T::ZERO
}

/// `v` is finite, tested on the FPU (v·0 is ±0 unless v is ±∞ or NaN):
/// `is_finite` compiles to a dozen integer instructions on the Cortex-M4F.
#[inline(always)]
fn finite<T: Real>(v: T) -> bool {
    v * T::ZERO == T::ZERO
}

/// The dense reference the optimised code is tested against: the plain
/// covariance prediction P ← Φ·P·Φᵀ + diag(q), then re-symmetrised.
#[cfg(test)]
pub(crate) fn predict_covariance_dense<T: Real, const N: usize>(
    p: &mut SMatrix<T, N, N>,
    phi: &SMatrix<T, N, N>,
    q_diag: &[T; N],
) {
    let mut next = phi * *p * phi.transpose();
    for i in 0..N {
        next[(i, i)] += q_diag[i];
    }
    let half = T::c(0.5);
    for a in 0..N {
        for b in a + 1..N {
            let v = (next[(a, b)] + next[(b, a)]) * half;
            next[(a, b)] = v;
            next[(b, a)] = v;
        }
    }
    *p = next;
}

/// The dense reference of the weighted Joseph update: the matrix products
/// (I − k·hᵀ)·P·(I − k·hᵀ)ᵀ + k·r·kᵀ written out with nalgebra.
#[cfg(test)]
pub(crate) fn joseph_update_dense<T: Real, const N: usize>(
    f: &mut Ekf<T, N>,
    j: usize,
    z: T,
    r: T,
    weights: &[T; N],
) {
    let s = f.p[(j, j)] + r;
    let mut k: SVector<T, N> = f.p.column(j) / s;
    for i in 0..N {
        k[i] *= weights[i];
    }
    let mut h = SVector::<T, N>::zeros();
    h[j] = T::ONE;
    let a = SMatrix::<T, N, N>::identity() - k * h.transpose();
    f.x += k * (z - f.x[j]);
    f.p = a * f.p * a.transpose() + k * k.transpose() * r;
}

/// A small deterministic generator for the tests (xorshift64), values in
/// [−0.5, 0.5).
#[cfg(test)]
pub(crate) struct TestRng(pub u64);

#[cfg(test)]
impl TestRng {
    pub(crate) fn next(&mut self) -> f64 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        (*s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    /// A random symmetric positive definite matrix A·Aᵀ + 0.01·I with
    /// entries of mixed scale (states of different units), rounded to T.
    pub(crate) fn spd<T: Real, const N: usize>(&mut self) -> SMatrix<T, N, N> {
        let scale: [f64; N] = core::array::from_fn(|_| libm::exp(4.0 * self.next()));
        let a = SMatrix::<f64, N, N>::from_fn(|i, _| self.next() * scale[i]);
        let p = a * a.transpose() + SMatrix::<f64, N, N>::identity() * 0.01;
        p.map(T::c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn scalar_updates_equal_the_batch_update() {
        // Two independent measurements of a correlated 2-state filter.
        let x0 = Vector2::new(1.0f64, -0.5);
        let p0 = Matrix2::new(2.0, 0.6, 0.6, 1.0);
        let r = [0.3, 0.2];
        let z = [1.4, -0.1];
        let mut f = Ekf { x: x0, p: p0 };
        f.update_state::<0>(z[0], r[0], 0).unwrap();
        f.update_state::<1>(z[1], r[1], 1).unwrap();
        // Batch: K = P Hᵀ (H P Hᵀ + R)⁻¹ with H = I.
        let s = p0 + Matrix2::new(r[0], 0.0, 0.0, r[1]);
        let k = p0 * s.try_inverse().unwrap();
        let xb = x0 + k * (Vector2::new(z[0], z[1]) - x0);
        let pb = (Matrix2::identity() - k) * p0;
        assert!((f.x - xb).norm() < 1e-12);
        assert!((f.p - pb).norm() < 1e-12);
    }

    #[test]
    fn weighted_gain_keeps_the_exact_covariance_of_the_estimator() {
        // With state 1's gain zeroed, its estimate must not move and the
        // Joseph covariance must equal the Monte-Carlo-free closed form
        // (I − K H) P (I − K H)ᵀ + K R Kᵀ.
        let p0 = Matrix2::new(2.0f64, 0.6, 0.6, 1.0);
        let mut f = Ekf {
            x: Vector2::new(0.0, 0.0),
            p: p0,
        };
        f.update_state_weighted::<0, true>(1.0, 0.5, 0, &[1.0, 0.0])
            .unwrap();
        assert_eq!(f.x[1], 0.0);
        let k = Vector2::new(2.0 / 2.5, 0.0);
        let h = Vector2::new(1.0, 0.0);
        let a = Matrix2::identity() - k * h.transpose();
        let want = a * p0 * a.transpose() + k * 0.5 * k.transpose();
        assert!((f.p - want).norm() < 1e-12);
        // Its variance is unchanged but the cross term is not.
        assert!((f.p[(1, 1)] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_innovation_covariance_is_an_error_not_a_panic() {
        let mut f = Ekf::<f32, 2>::new(Vector2::new(0.0, 0.0), &Vector2::new(1.0, 1.0));
        assert_eq!(
            f.update_state::<0>(1.0, -2.0, 0),
            Err(EkfError::InnovationCovariance { index: 0 })
        );
        assert_eq!(
            f.update_state::<1>(1.0, f32::NAN, 1),
            Err(EkfError::InnovationCovariance { index: 1 })
        );
        // An infinite reading makes the state non-finite: the step's check
        // reports it.
        assert!(f.update_state::<0>(f32::INFINITY, 1.0, 2).is_ok());
        assert_eq!(f.check_finite(), Err(EkfError::NonFinite));
        // A covariance that is already non-finite is the cause, and named so.
        let mut g = Ekf::<f32, 2>::new(Vector2::new(0.0, 0.0), &Vector2::new(f32::NAN, 1.0));
        assert_eq!(g.update_state::<0>(1.0, 1.0, 0), Err(EkfError::NonFinite));
    }

    #[test]
    fn the_finiteness_tests_agree_with_is_finite() {
        for v in [
            0.0f32,
            -0.0,
            1.0,
            -3.5e-40,
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ] {
            assert_eq!(finite(v), v.is_finite(), "{v}");
            assert_eq!(finite(v as f64), v.is_finite(), "{v}");
            assert_eq!(all_finite([1.0, v, 2.0].into_iter()), v.is_finite(), "{v}");
        }
    }

    #[test]
    fn the_finiteness_check_sees_the_state_and_the_diagonal() {
        let ok = Ekf::<f32, 3>::new(Vector2::new(0.0, 0.0).push(1.0), &SVector::repeat(2.0));
        assert_eq!(ok.check_finite(), Ok(()));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for i in 0..3 {
                let mut f = ok.clone();
                f.x[i] = bad;
                assert_eq!(f.check_finite(), Err(EkfError::NonFinite));
                let mut f = ok.clone();
                f.p[(i, i)] = bad;
                assert_eq!(f.check_finite(), Err(EkfError::NonFinite));
            }
        }
        // Huge but finite values are not failures (no overflow in the test).
        let mut f = ok.clone();
        f.x[0] = f32::MAX;
        f.x[1] = f32::MAX;
        f.p[(2, 2)] = f32::MAX;
        assert_eq!(f.check_finite(), Ok(()));
    }

    /// The optimised update against the matrix form, on random SPD
    /// covariances, partial weights and each measured state.
    fn joseph_update_matches_the_dense_matrix_form<T: Real>(tol: f64) {
        let mut rng = TestRng(0x2545_f491_4f6c_dd1d);
        for trial in 0..200 {
            let p = rng.spd::<T, 11>();
            let x = SVector::<T, 11>::from_fn(|_, _| T::c(rng.next()));
            let w: [T; 11] =
                core::array::from_fn(|i| T::c(if i < 6 { 1.0 } else { rng.next() + 0.5 }));
            let j = [0, 4, 5][trial % 3];
            let (z, r) = (T::c(rng.next()), T::c(1e-4 + rng.next().abs()));
            let mut fast = Ekf { x, p };
            let mut slow = fast.clone();
            match j {
                0 => fast.update_state_weighted::<0, true>(z, r, 0, &w),
                4 => fast.update_state_weighted::<4, true>(z, r, 0, &w),
                _ => fast.update_state_weighted::<5, true>(z, r, 0, &w),
            }
            .unwrap();
            joseph_update_dense(&mut slow, j, z, r, &w);
            let scale = p.iter().fold(0.0f64, |m, v| m.max(v.abs().to_f64()));
            for i in 0..11 {
                let d = (fast.x[i] - slow.x[i]).abs().to_f64();
                assert!(d <= tol * (1.0 + slow.x[i].abs().to_f64()), "x[{i}]");
                for k in 0..11 {
                    let d = (fast.p[(i, k)] - slow.p[(i, k)]).abs().to_f64();
                    assert!(d <= tol * scale, "P[{i}, {k}]: {d:e}");
                }
            }
            assert_eq!(fast.p, fast.p.transpose());
        }
    }

    #[test]
    fn updates_of_the_upper_triangle_then_a_mirror_equal_mirrored_updates() {
        // The bank's sequence (x_p, p3, p4; the last one mirrors) leaves
        // exactly the bits of three mirrored updates, whatever the lower
        // triangle held before it.
        let mut rng = TestRng(0x9e37_79b9_7f4a_7c15);
        for _ in 0..50 {
            let p = rng.spd::<f32, 11>();
            let x = SVector::<f32, 11>::from_fn(|_, _| rng.next() as f32);
            let w: [f32; 11] = core::array::from_fn(|i| if i < 6 { 1.0 } else { 0.3 });
            let z: [f32; 3] = core::array::from_fn(|_| rng.next() as f32);
            let mut mirrored = Ekf { x, p };
            let mut upper_only = mirrored.clone();
            mirrored
                .update_state_weighted::<0, true>(z[0], 1e-3, 0, &w)
                .unwrap();
            mirrored
                .update_state_weighted::<4, true>(z[1], 1e-3, 1, &w)
                .unwrap();
            mirrored
                .update_state_weighted::<5, true>(z[2], 1e-3, 2, &w)
                .unwrap();
            for a in 0..11 {
                for b in 0..a {
                    upper_only.p[(a, b)] = f32::NAN;
                }
            }
            upper_only
                .update_state_weighted::<0, false>(z[0], 1e-3, 0, &w)
                .unwrap();
            upper_only
                .update_state_weighted::<4, false>(z[1], 1e-3, 1, &w)
                .unwrap();
            upper_only
                .update_state_weighted::<5, true>(z[2], 1e-3, 2, &w)
                .unwrap();
            for (a, b) in upper_only.x.iter().zip(&mirrored.x) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
            for (a, b) in upper_only.p.iter().zip(&mirrored.p) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
    }

    #[test]
    fn joseph_update_equals_the_dense_matrix_form() {
        joseph_update_matches_the_dense_matrix_form::<f64>(1e-13);
        joseph_update_matches_the_dense_matrix_form::<f32>(4e-6);
    }

    #[test]
    fn joseph_form_keeps_covariance_psd_with_tiny_noise() {
        // A nearly noiseless measurement of a strongly correlated state pair
        // in f32: the naive (I − KH)P form loses symmetry/positivity here.
        let mut f = Ekf::<f32, 2> {
            x: Vector2::new(0.0, 0.0),
            p: Matrix2::new(1.0, 0.999_99, 0.999_99, 1.0),
        };
        for _ in 0..1000 {
            f.update_state::<0>(0.0, 1e-9, 0).unwrap();
            predict_covariance_dense(&mut f.p, &Matrix2::new(1.0, 1e-3, 0.0, 1.0), &[1e-9, 1e-9]);
        }
        assert_eq!(f.p[(0, 1)], f.p[(1, 0)]);
        assert!(f.p[(0, 0)] >= 0.0 && f.p[(1, 1)] >= 0.0);
        assert!(f.p[(0, 0)] * f.p[(1, 1)] - f.p[(0, 1)] * f.p[(0, 1)] >= -1e-12);
    }
}
