//! Device concerns around the monitor: the estimator pipeline run once per
//! ADC block ([`Estimator`]), the alarm output it drives (relay, LED, alarm
//! frame), the alarm levels a sensitivity frame reports, the 1 ms sample
//! deadline, the watchdog supervisor and the
//! device's own diagnostics.

pub mod alarm;
pub mod deadline;
pub mod diagnostics;
pub mod estimator;
pub mod level_peak;
pub mod supervisor;

pub use estimator::{Estimator, Inputs, Outputs};
