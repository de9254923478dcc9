//! The rig simulator: physics, sensors, scenarios.

pub mod rig;
pub mod scenario;
pub mod sensors;

pub use rig::{LeakLaw, RigPhysics};
pub use scenario::{perturbed_rig, Profile, Rig, Scenario, SimRow, Simulation};
pub use sensors::SensorModel;
