//! Physics pieces of the cylinder, valve and load, in SI units: what the
//! model is built from and what calibration fits against.

pub mod fluid;
pub mod friction;
pub mod load;
pub mod units;
pub mod valve;
