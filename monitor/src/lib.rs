//! Leak monitor core for a valve-controlled hydraulic cylinder.
//!
//! `no_std`, no allocation, deterministic. One entry point:
//! [`Monitor::step`] takes one [`Sample`] (one row of a recording, in
//! engineering units) and returns a [`Status`]. The same code runs on the
//! STM32 (f32) and in `host-sim` on a desktop (f32, or f64 as a reference).
//!
//! Layout: `params` (installation parameters) → `load`, `fluid`, `valve`
//! (physics pieces) → `model` (the six-state plant and its Jacobian) →
//! `ekf` (filter core) → `bank` (one filter per leak hypothesis) →
//! `decision` (evidence, verdict, alarm latching) → `monitor` (the entry
//! point, with `signal` checking the inputs).
//!
//! For the device: `signal::frontend` (ADC codes → engineering units,
//! NAMUR NE43), `alarm` (the fail-safe relay and alarm state machine),
//! `protocol` (the CAN frames, E2E protection, frame scheduling),
//! `deadline` and `supervisor` (the 1 ms deadline and the watchdog).
#![no_std]
#![deny(missing_docs)]
// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must be
// rejected, where `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Numeric code indexes parallel arrays (states, channels, hypotheses) by
// the same index; iterator chains over three arrays read worse.
#![allow(clippy::needless_range_loop)]

pub mod alarm;
pub mod bank;
pub mod consistency;
pub mod deadline;
pub mod decision;
pub mod ekf;
pub mod fluid;
pub mod hypothesis;
pub mod load;
pub mod model;
pub mod monitor;
pub mod params;
pub mod protocol;
pub mod quiet;
pub mod real;
pub mod sample;
pub mod signal;
pub mod status;
pub mod supervisor;
#[cfg(test)]
mod testutil;
pub mod valve;

pub use hypothesis::Hypothesis;
pub use monitor::Monitor;
pub use params::Params;
pub use real::Real;
pub use sample::{Channel, Sample};
pub use status::{Event, Status, Verdict};
