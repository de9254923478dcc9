//! The servo valve: spool dynamics (eq. 6.3), the opening of the metering
//! edges past the dead zone, and the orifice flow law (eqs. 6.11–6.15) with
//! a laminar region so the Jacobian stays finite at Δp = 0.

use crate::real::Real;

/// Signed square-root flow law g(Δp) = sign(Δp)·√|Δp| for |Δp| ≥ δ, and
/// inside |Δp| < δ the odd cubic √δ·(5r − r³)/4, r = Δp/δ, which matches
/// value and slope at ±δ (laminar region). Returns (g, dg/dΔp).
#[inline]
pub fn orifice<T: Real>(dp: T, delta: T, sqrt_delta: T) -> (T, T) {
    let a = dp.abs();
    if a >= delta {
        let r = a.sqrt();
        let g = if dp >= T::ZERO { r } else { -r };
        (g, T::c(0.5) / r)
    } else {
        let r = dp / delta;
        let r2 = r * r;
        let q = T::c(0.25) * sqrt_delta;
        (
            q * r * (T::c(5.0) - r2),
            q * (T::c(5.0) - T::c(3.0) * r2) / delta,
        )
    }
}

/// Spool position (fraction of travel) that valve command `u` gives a
/// valve whose spool sits at `null_offset` at zero command. The one
/// statement of that convention: the model, the input checks, the
/// operating regions and calibration all place the spool with it.
#[inline(always)]
pub fn spool_at<T: Real>(u: T, null_offset: T) -> T {
    u + null_offset
}

/// The valve command that puts the spool at `spool`: [`spool_at`]'s
/// inverse.
#[inline(always)]
pub fn command_for<T: Real>(spool: T, null_offset: T) -> T {
    spool - null_offset
}

/// Largest |exponent| [`land_growth`] is asked for: valve.edge_leak_spool_gain
/// × valve.dead_zone (validated), an e^8 ≈ 3000-fold land leakage at the
/// edge of the dead zone.
pub const MAX_LAND_EXPONENT: f64 = 8.0;

/// e^y for |y| ≤ [`MAX_LAND_EXPONENT`]: how a covered edge's land leakage
/// grows as the spool uncovers it. (e^(y/32))^32 with the fifth-order
/// Taylor polynomial of e^(y/32): relative error below 2e-5 over the
/// range, exact at 0, about 15 instructions (which keeps `expf` off the
/// 1 ms path).
#[inline]
pub fn land_growth<T: Real>(y: T) -> T {
    let z = y * T::c(1.0 / 32.0);
    let mut e = T::ONE
        + z * (T::ONE
            + z * (T::c(0.5)
                + z * (T::c(1.0 / 6.0) + z * (T::c(1.0 / 24.0) + z * T::c(1.0 / 120.0)))));
    for _ in 0..5 {
        e = e * e;
    }
    e
}

/// Spool travel past the dead zone, fraction of travel, over which a
/// hold's land-leakage model (`valve.hold_edge_leak_scale`) gives way to
/// the metering valve's: half of each at this opening. A metering edge
/// passes tens of times the land leakage there, so the blend only keeps
/// the model continuous.
pub const HOLD_BLEND_TRAVEL: f64 = 0.005;

/// The hold's land leakage calibration sets where no oil temperature is
/// read (`valve.hold_edge_leak_scale`), × the nominal per covered edge,
/// so that the free laminar factor cannot take in a leak the holding
/// loop feeds: the same × 3 as where the temperature holds the factor
/// (× 1 gained less on the development sets, and calibration's choice
/// among × 1–5 by the healthy filter's NIS, mostly × 1, no more). The
/// golden cases use it too.
pub const HOLD_EDGE_LEAK_SCALE: f64 = 3.0;

/// Share of a hold's land-leakage model at spool travel `open` past the
/// dead zone (0 inside it): 1 inside the dead zone, ½ at
/// [`HOLD_BLEND_TRAVEL`], falling as the edges open.
#[inline]
pub fn hold_share<T: Real>(open: T) -> T {
    let b = T::c(HOLD_BLEND_TRAVEL);
    b / (b + open.max(T::ZERO))
}

/// Half-width of the rounded corner of the spool opening, fraction of
/// travel: an edge starts to meter this far before the dead zone ends.
pub const OPENING_ROUNDING: f64 = 0.002;

/// Opening of a metering edge for spool travel `xi` beyond the dead zone:
/// max(xi, 0), rounded over ±`eps` so its slope is continuous. Returns
/// (opening, d opening / d xi).
#[inline]
pub fn opening<T: Real>(xi: T, eps: T) -> (T, T) {
    if xi >= eps {
        (xi, T::ONE)
    } else if xi <= -eps {
        (T::ZERO, T::ZERO)
    } else {
        let s = xi + eps;
        let inv = T::c(0.25) / eps;
        (s * s * inv, T::c(2.0) * s * inv)
    }
}

/// Discrete spool dynamics over one step h: the trapezoidal (Tustin) map of
/// ẍ_v + 2ζω·ẋ_v + ω²·x_v = ω²·u. A-stable, second order, and exact in
/// steady state; its phase error at ωh = 0.44 (h = 0.5 ms) is below 1 %.
/// State `[x_v, ẋ_v/ω]` (both O(1)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpoolStep<T> {
    /// Transition matrix, row-major.
    pub phi: [[T; 2]; 2],
    /// Input gain.
    pub gamma: [T; 2],
}

impl<T: Real> SpoolStep<T> {
    /// The map for natural frequency `omega` (rad/s), damping `zeta` and
    /// step `h` (s).
    pub fn new(omega: f64, zeta: f64, h: f64) -> Self {
        // Scaled state z = [x, v/ω]: ż = ω·[[0, 1], [−1, −2ζ]]·z + ω·[0, 1]·u.
        let a = omega * h * 0.5;
        // M = I − a·A0, N = I + a·A0, A0 = [[0, 1], [−1, −2ζ]].
        let m = [[1.0, -a], [a, 1.0 + 2.0 * zeta * a]];
        let n = [[1.0, a], [-a, 1.0 - 2.0 * zeta * a]];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let inv = [
            [m[1][1] / det, -m[0][1] / det],
            [-m[1][0] / det, m[0][0] / det],
        ];
        let mut phi = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                phi[i][j] = inv[i][0] * n[0][j] + inv[i][1] * n[1][j];
            }
        }
        // Input: M⁻¹·(2a·[0, 1])·u (trapezoid over a held u).
        let gamma = [inv[0][1] * 2.0 * a, inv[1][1] * 2.0 * a];
        Self {
            phi: [
                [T::c(phi[0][0]), T::c(phi[0][1])],
                [T::c(phi[1][0]), T::c(phi[1][1])],
            ],
            gamma: [T::c(gamma[0]), T::c(gamma[1])],
        }
    }

    /// Advance `[x_v, ẋ_v/ω]` by one step with command `u` held.
    #[inline]
    pub fn apply(&self, z: [T; 2], u: T) -> [T; 2] {
        [
            self.phi[0][0] * z[0] + self.phi[0][1] * z[1] + self.gamma[0] * u,
            self.phi[1][0] * z[0] + self.phi[1][1] * z[1] + self.gamma[1] * u,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orifice_is_continuous_and_smooth() {
        let delta = 1e5_f64;
        let sd = delta.sqrt();
        for dp in [-delta, delta] {
            let below = orifice(dp * (1.0 - 1e-9), delta, sd);
            let above = orifice(dp * (1.0 + 1e-9), delta, sd);
            assert!((below.0 - above.0).abs() < 1e-3);
            assert!((below.1 - above.1).abs() < 1e-6 * above.1.abs());
        }
        assert_eq!(orifice(0.0, delta, sd).0, 0.0);
        let (g, dg) = orifice(50e5, delta, sd);
        assert!((g - 50e5_f64.sqrt()).abs() < 1e-9);
        assert!((dg - 0.5 / 50e5_f64.sqrt()).abs() < 1e-12);
        // Slope matches finite differences in both regions.
        for dp in [-3e5, -0.5e5, 0.2e5, 0.9e5, 4e5] {
            let h = 1.0;
            let fd = (orifice(dp + h, delta, sd).0 - orifice(dp - h, delta, sd).0) / (2.0 * h);
            assert!((orifice(dp, delta, sd).1 - fd).abs() < 1e-6 * fd.abs());
        }
    }

    #[test]
    fn opening_is_relu_with_rounded_corner() {
        let eps = 0.002;
        assert_eq!(opening(-0.1, eps), (0.0, 0.0));
        assert_eq!(opening(0.3, eps), (0.3, 1.0));
        let (a, da) = opening(0.0, eps);
        assert!((a - eps / 4.0).abs() < 1e-12 && (da - 0.5).abs() < 1e-12);
        for xi in [-eps, eps] {
            let l = opening(xi - 1e-12, eps);
            let r = opening(xi + 1e-12, eps);
            assert!((l.0 - r.0).abs() < 1e-9 && (l.1 - r.1).abs() < 1e-6);
        }
    }

    #[test]
    fn land_growth_is_the_exponential_within_its_range() {
        assert_eq!(land_growth(0.0_f64), 1.0);
        let n = 400;
        for k in 0..=n {
            let y = MAX_LAND_EXPONENT * (2.0 * k as f64 / n as f64 - 1.0);
            let rel = land_growth(y) / y.exp() - 1.0;
            assert!(rel.abs() < 2e-5, "y = {y}: relative error {rel}");
            let f = land_growth(y as f32) / (y as f32).exp() - 1.0;
            assert!(f.abs() < 5e-5, "f32, y = {y}: relative error {f}");
        }
        // Increasing, so a covered edge leaks more as the spool uncovers it.
        let mut last = 0.0;
        for k in 0..=n {
            let g = land_growth(-8.0 + 16.0 * k as f64 / n as f64);
            assert!(g > last);
            last = g;
        }
    }

    #[test]
    fn spool_step_response_settles_without_overshoot_beyond_thesis_damping() {
        // ζ = 0.92: overshoot ≈ 0.03 %; settles to u. Compare with the exact
        // continuous response at the sample instants.
        let omega = 280.0 * core::f64::consts::PI;
        let zeta = 0.92;
        let h = 0.0005;
        let s = SpoolStep::<f64>::new(omega, zeta, h);
        let mut z = [0.0, 0.0];
        let wd = omega * (1.0 - zeta * zeta).sqrt();
        for k in 1..=40 {
            z = s.apply(z, 1.0);
            let t = k as f64 * h;
            let exact = 1.0
                - (-zeta * omega * t).exp() * ((wd * t).cos() + zeta * omega / wd * (wd * t).sin());
            assert!((z[0] - exact).abs() < 0.02, "t={t}: {} vs {exact}", z[0]);
        }
        assert!((z[0] - 1.0).abs() < 1e-3);
    }
}
