//! Helpers shared by unit tests.

use crate::{Monitor, Params, Sample, Status};

/// A plausible sample of the reference rig at rest.
pub fn good_sample(t_s: f64) -> Sample {
    Sample {
        t_s,
        p_supply_bar: Some(50.0),
        p_piston_bar: Some(21.4),
        p_rod_bar: Some(12.9),
        p_tank_bar: Some(0.8),
        x_piston_m: Some(0.04),
        u_valve: Some(0.0),
        temp_oil_c: None,
    }
}

/// A real status of the monitor (so tests do not depend on every field
/// of `Status`); tests then set the fields they exercise.
pub fn status() -> Status {
    let mut m = Monitor::<f32>::new(&Params::nominal()).expect("nominal parameters are valid");
    m.step(&good_sample(0.0))
}
