//! The rig simulator: physics, sensors, scenarios.

/// Pa per bar (the monitor's unit conversions; the physics is the rig's own).
const BAR: f64 = monitor::model::BAR;
/// m³/s per l/min.
const LPM: f64 = 1.0 / monitor::model::LPM_PER_M3S;

pub mod rig;
pub mod scenario;
pub mod sensors;

pub use rig::{LeakLaw, RigPhysics};
pub use scenario::{perturbed_rig, Profile, Rig, Scenario, SimRow, Simulation};
pub use sensors::SensorModel;
