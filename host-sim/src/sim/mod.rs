//! The rig simulator: physics, sensors, scenarios.

/// Pa per bar.
const BAR: f64 = 1.0e5;
/// m³/s per l/min.
const LPM: f64 = 1.0 / 60_000.0;

pub mod rig;
pub mod scenario;
pub mod sensors;

pub use rig::{LeakLaw, RigPhysics};
pub use scenario::{perturbed_rig, Profile, Rig, Scenario, SimRow, Simulation};
pub use sensors::SensorModel;
