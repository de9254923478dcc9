//! Leak monitor core for a valve-controlled hydraulic cylinder.
//!
//! `no_std`, no allocation, deterministic. One entry point:
//! [`Monitor::step`] takes one [`Sample`] (one row of a recording, in
//! engineering units) and returns a [`Status`]. The same code runs on the
//! STM32 (f32) and in `host-sim` on a desktop (f32, or f64 as a reference).
//!
//! Layout, in the order data flows:
//! - `signal`: input conditioning (NAMUR NE43, frozen readings, spikes,
//!   noise estimate; `signal::frontend` turns ADC codes into units);
//! - `physics`: load, oil, valve and friction pieces in SI units;
//! - `estimation` (internal): the six-state model, the EKF core and the
//!   bank of one filter per leak hypothesis;
//! - `decision`: evidence, verdict and alarm latching;
//! - `monitor`: the entry point tying them together, with `params`,
//!   `sample` and `status` as its data;
//! - `device` and `protocol`: the fail-safe relay, the 1 ms deadline, the
//!   watchdog supervisor and the CAN frames.
#![no_std]
#![deny(missing_docs)]
// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must be
// rejected, where `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Numeric code indexes parallel arrays (states, channels, hypotheses) by
// the same index; iterator chains over three arrays read worse.
#![allow(clippy::needless_range_loop)]

pub(crate) mod decision;
pub mod device;
pub(crate) mod estimation;
mod hypothesis;
mod monitor;
pub mod params;
pub mod physics;
pub mod protocol;
mod real;
mod sample;
pub mod signal;
pub mod status;
#[cfg(test)]
mod testutil;

pub use decision::acknowledge;
pub use hypothesis::Hypothesis;
pub use monitor::{FilterState, Monitor};
pub use params::Params;
pub use real::Real;
pub use sample::{Channel, Sample};
pub use status::{Event, Status, Verdict};
