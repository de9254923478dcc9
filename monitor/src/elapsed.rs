//! The time between two samples, `t − t0` in f64, exactly as IEEE 754
//! subtraction gives it, but without the soft-float `__aeabi_dsub` (≈ 200
//! instructions on the Cortex-M4F, whose FPU is single precision) in the
//! usual case: two positive normal times whose exponents differ by at most
//! one, so that the difference of their aligned mantissas is exact.

/// Bits below the f64 exponent.
const FRACTION_BITS: u32 = 52;
const FRACTION: u64 = (1 << FRACTION_BITS) - 1;
/// Biased exponent of infinity and NaN.
const EXP_SPECIAL: u64 = 0x7ff;

/// `Some(t − t0)` if `t` is later than `t0` (`t > t0`), else `None`;
/// bit-identical to `(t > t0).then(|| t - t0)`.
pub(crate) fn elapsed(t0: f64, t: f64) -> Option<f64> {
    let (a, b) = (t.to_bits(), t0.to_bits());
    // The sign bit is above the exponent: a set sign bit makes these
    // "special" and takes the float path.
    let (ea, eb) = (a >> FRACTION_BITS, b >> FRACTION_BITS);
    let normal = |e: u64| e != 0 && e < EXP_SPECIAL;
    if normal(ea) && normal(eb) && (ea == eb || ea == eb + 1) {
        // Positive, not NaN: ordered like their bit patterns.
        if a <= b {
            return None;
        }
        let ma = ((a & FRACTION) | 1 << FRACTION_BITS) << (ea - eb);
        let mb = (b & FRACTION) | 1 << FRACTION_BITS;
        // In units of 2^(eb − 1075); below 2^53 it is an f64 exactly.
        let d = ma - mb;
        let lz = d.leading_zeros();
        if lz >= 63 - FRACTION_BITS {
            let shift = lz - (63 - FRACTION_BITS);
            if eb > u64::from(shift) {
                let m = (d << shift) & FRACTION;
                return Some(f64::from_bits((eb - u64::from(shift)) << FRACTION_BITS | m));
            }
        }
    }
    if t > t0 {
        Some(t - t0)
    } else {
        None
    }
}

/// A closed interval of non-negative times, tested by bit pattern: IEEE 754
/// orders non-negative, non-NaN floats like their bits, so no soft-float
/// comparison runs for [`Window::contains`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Window {
    lo: u64,
    hi: u64,
}

impl Window {
    /// `[centre − half_width, centre + half_width]` (`0 ≤ half_width ≤ centre`).
    pub(crate) fn around(centre: f64, half_width: f64) -> Self {
        Self {
            lo: (centre - half_width).to_bits(),
            hi: (centre + half_width).to_bits(),
        }
    }

    /// Is the non-negative, non-NaN time `t` inside?
    pub(crate) fn contains(&self, t: f64) -> bool {
        debug_assert!(t >= 0.0, "{t}");
        (self.lo..=self.hi).contains(&t.to_bits())
    }
}

/// `t > limit` for a non-negative, non-NaN `t` and a non-negative limit
/// given by its bits ([`f64::to_bits`]); no soft-float comparison.
pub(crate) fn exceeds(t: f64, limit_bits: u64) -> bool {
    debug_assert!(t >= 0.0, "{t}");
    t.to_bits() > limit_bits
}

#[cfg(test)]
mod tests {
    use super::{elapsed, exceeds, Window};
    use proptest::prelude::*;

    fn reference(t0: f64, t: f64) -> Option<u64> {
        (t > t0).then(|| (t - t0).to_bits())
    }

    fn check(t0: f64, t: f64) {
        assert_eq!(
            elapsed(t0, t).map(f64::to_bits),
            reference(t0, t),
            "{t0} → {t}"
        );
    }

    #[test]
    fn sample_clocks_and_special_values() {
        for k in 0..200_000u64 {
            let t0 = k as f64 * 1e-3;
            check(t0, (k + 1) as f64 * 1e-3);
            check(t0, t0 + 1e-3);
            check(t0, t0 + 0.25);
        }
        let special = [
            0.0,
            -0.0,
            5e-324,
            2.2250738585072014e-308,
            1.0,
            2.0,
            1.9999999999999998,
            -1.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for a in special {
            for b in special {
                check(a, b);
            }
        }
    }

    proptest! {
        #[test]
        fn windows_and_limits_compare_like_floats(c in 1e-6..10.0f64, w in 0.0..1e-3f64, t in 0.0..20.0f64) {
            let w = w * c;
            let win = Window::around(c, w);
            prop_assert_eq!(win.contains(t), t >= c - w && t <= c + w);
            prop_assert_eq!(win.contains(c), true);
            prop_assert_eq!(exceeds(t, c.to_bits()), t > c);
            prop_assert_eq!(exceeds(f64::INFINITY, c.to_bits()), true);
        }

        #[test]
        fn bit_identical_to_ieee_subtraction(a in any::<f64>(), b in any::<f64>(), t0 in 1e-3..1e8f64, dt in 0.0..10.0f64) {
            check(a, b);
            check(t0, t0 + dt);
            check(t0, t0 * 2.0);
            check(t0, t0 * 1.999_999);
            check(t0, t0 * 3.9);
        }
    }
}
