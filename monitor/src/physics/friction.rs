//! The friction law's shape, shared by the model and calibration.

use crate::real::Real;

/// The model's Stribeck decay for y = c_v·|v|: 1/(1 + y + y²/2 + y³/6), a
/// cheap stand-in for e^(−y) (within 2 % for y < 1, where the term matters).
#[inline]
pub fn stribeck_decay<T: Real>(y: T) -> T {
    T::ONE / (T::ONE + y * (T::ONE + y * (T::c(0.5) + y * T::c(1.0 / 6.0))))
}
