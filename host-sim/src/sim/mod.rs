//! The rig simulator: physics, sensors, scenarios, and the rig's data.
//!
//! A test plant of its own: it shares neither model code nor model data
//! types with the monitor (nothing here uses the `monitor` crate). Its rows
//! ([`SimRow`]) become `monitor::Sample`s outside, in `crate::sim_sample`.

/// Pa per bar.
const BAR: f64 = 1.0e5;
/// m³/s per l/min.
const LPM: f64 = 1.0 / 60_000.0;

pub mod rig;
pub mod rig_data;
pub mod scenario;
pub mod sensors;

pub use rig::{LeakLaw, RigPhysics};
pub use rig_data::{Rig, SensorOffsets};
pub use scenario::{perturbed_rig, Profile, Scenario, SimRow, Simulation};
pub use sensors::SensorModel;
