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

/// A small deterministic random source for tests (no_std: no `rand`).
pub struct Lcg(u64);

impl Lcg {
    /// Seeded.
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1))
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn gaussian(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        libm::sqrt(-2.0 * libm::log(a)) * libm::cos(2.0 * core::f64::consts::PI * b)
    }
}
