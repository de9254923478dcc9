//! Units shared by the model, the filters and calibration.

/// Pascal per bar.
pub const BAR: f64 = 1.0e5;
/// Leak coefficient unit: 1 l/min per 10 bar, in m³/(s·Pa).
pub const LEAK_UNIT: f64 = 1.0 / 60_000.0 / 1.0e6;
/// l/min per m³/s.
pub const LPM_PER_M3S: f64 = 60_000.0;
