//! The scalar the filter runs in: `f32` on the MCU, `f64` for the host's
//! reference runs of the very same code.
//!
//! Every transcendental goes through this trait and through `libm` (or the
//! FPU's correctly rounded `vsqrt.f32`), never through `std`'s inherent float
//! methods: those exist only on the host, so the same source could otherwise
//! compile to different maths on the desktop and on the device (see
//! `../shared/notes/embedded-toolchain-facts.md`, "Numerics pitfall").
//! IEEE-754 makes `+ - * / sqrt` correctly rounded on both x86-64 (SSE) and
//! the Cortex-M4F FPU, and Rust never contracts `a*b+c` into a fused
//! multiply-add, so host and target produce bit-identical results.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real scalar: `f32` (device) or `f64` (host reference).
pub trait Real:
    Copy
    + Debug
    + Default
    + PartialOrd
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + nalgebra::Scalar
    + nalgebra::ClosedAddAssign
    + nalgebra::ClosedSubAssign
    + nalgebra::ClosedMulAssign
    + num_traits::Zero
    + num_traits::One
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// A constant, rounded to this precision.
    fn c(v: f64) -> Self;
    /// Widen or keep an `f32` input.
    fn from_f32(v: f32) -> Self;
    /// Round to `f32` for reporting.
    fn to_f32(self) -> f32;
    /// Widen to `f64` for reporting.
    fn to_f64(self) -> f64;
    /// Correctly rounded square root.
    fn sqrt(self) -> Self;
    /// e^x (libm).
    fn exp(self) -> Self;
    /// Natural logarithm (libm).
    fn ln(self) -> Self;
    /// |x|.
    fn abs(self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// The larger of two values (NaN-free inputs assumed).
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        if self > other {
            self
        } else {
            other
        }
    }
    /// The smaller of two values (NaN-free inputs assumed).
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        if self < other {
            self
        } else {
            other
        }
    }
    /// Clamp into `[lo, hi]`.
    #[inline(always)]
    fn clamp_to(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline(always)]
    fn c(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        sqrt_f32(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        libm::expf(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        libm::logf(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline(always)]
    fn c(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v as f64
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        libm::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        libm::log(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

/// `sqrtf` on the Cortex-M4F FPU: one `vsqrt.f32` (14 cycles) instead of
/// libm's ~60-instruction software routine. Stable Rust has no `f32::sqrt`
/// in `core` and `asm!` takes no FP-register operands on this target, so the
/// value travels through a core register. IEEE-754 requires sqrt to be
/// correctly rounded, so this equals `libm::sqrtf` bit for bit (tested on
/// the host against libm, and in QEMU against the host's results).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    let mut bits = x.to_bits();
    // SAFETY: pure register arithmetic; s15 is declared clobbered.
    unsafe {
        core::arch::asm!(
            "vmov s15, {b}",
            "vsqrt.f32 s15, s15",
            "vmov {b}, s15",
            b = inout(reg) bits,
            out("s15") _,
            options(pure, nomem, nostack),
        );
    }
    f32::from_bits(bits)
}

#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    libm::sqrtf(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_sqrt_is_correctly_rounded() {
        // Compare against the f64 result rounded to f32 over a wide sweep.
        let mut x = 1.0e-30_f32;
        while x < 1.0e30 {
            let got = Real::sqrt(x);
            let want = libm::sqrt(x as f64) as f32;
            assert_eq!(got.to_bits(), want.to_bits(), "sqrt({x})");
            x *= 1.37;
        }
    }

    #[test]
    fn helpers() {
        assert_eq!(Real::max(1.0f32, 2.0), 2.0);
        assert_eq!(Real::min(1.0f64, 2.0), 1.0);
        assert_eq!(Real::clamp_to(5.0f32, 0.0, 1.0), 1.0);
        assert!(!Real::is_finite(f32::NAN));
    }
}
