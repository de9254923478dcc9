//! Device concerns around the monitor: the fail-safe relay and alarm state
//! machine, the 1 ms sample deadline and the watchdog supervisor.

pub mod alarm;
pub mod deadline;
pub mod diagnostics;
pub mod supervisor;
