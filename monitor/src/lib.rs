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
//! - `decision` (internal): evidence, verdict, and the one leak-alarm
//!   latch with its acknowledge policy, in the leak vocabulary of
//!   [`Leak`], [`LeakSet`] and [`PerLeak`];
//! - `monitor`: the entry point tying them together ([`Monitor::step`],
//!   [`Monitor::acknowledge`]), with `params`, `sample` and `status` as
//!   its data;
//! - `device`: the pipeline the firmware runs per ADC block
//!   ([`device::Estimator`]: front end → acknowledge → step → alarm
//!   output → frames due), the alarm output (a pure function of the
//!   status), the 1 ms deadline and the watchdog supervisor;
//! - `protocol`: the CAN frames.
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
mod elapsed;
pub(crate) mod estimation;
mod hypothesis;
mod leak;
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
pub use decision::latch::AckOutcome;
pub use hypothesis::Hypothesis;
pub use leak::{Leak, LeakSet, PerLeak};
pub use monitor::{FilterState, Monitor};
pub use params::Params;
pub use real::Real;
pub use sample::{Channel, Sample};
pub use status::{Event, Status, Verdict};
