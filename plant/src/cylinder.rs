//! The cylinder: areas, stroke, the oil volumes between valve and piston
//! (part of them in hoses whose walls stretch with pressure), and the end
//! stops: a stiff spring–damper contact (a thin bumper, [`BUMPER_M`])
//! just inside each end, backed by the rigid cylinder head at exactly 0
//! and the stroke (a plastic impact: the integrator clamps the position
//! and stops the piston should a fast impact squeeze the bumper through).

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// Thickness of the end-stop bumper inside each end of the stroke, m.
pub const BUMPER_M: f64 = 1e-4;

/// One rig's cylinder and lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CylinderSpec {
    /// Piston (cap) side area, m² (3.117e-3 ±0.5 %).
    pub piston_area_m2: f64,
    /// Rod side (annulus) area, m² (2.41e-3 ±0.5 %).
    pub rod_area_m2: f64,
    /// Stroke, m (0.18); position 0 = fully retracted.
    pub stroke_m: f64,
    /// Dead volume on the piston side (port, hose, valve), m³ (2e-4 ±15 %).
    pub dead_volume_piston_m3: f64,
    /// Dead volume on the rod side at full extension, m³ (2e-4 ±15 %).
    pub dead_volume_rod_m3: f64,
    /// Fraction of each dead volume that is hose (0.3–0.8).
    pub hose_fraction: f64,
    /// Hose wall stiffness: a hose volume V grows by V·Δp/K, bar
    /// (5000–30000, log-uniform).
    pub hose_stiffness_bar: f64,
    /// End-stop contact stiffness, N/m (2e9–5e9: ≈ 0.01 mm at 100 bar).
    pub stop_stiffness_n_per_m: f64,
    /// End-stop contact damping, N·s/m (0.5–1 × critical for the nominal
    /// mass; only while in contact, never pulls).
    pub stop_damping_ns_per_m: f64,
}

impl CylinderSpec {
    pub(crate) fn random(r: &mut Rand, nominal_mass_kg: f64) -> Self {
        let k = r.uniform(2e9, 5e9);
        Self {
            piston_area_m2: 3.117e-3 * r.uniform(0.995, 1.005),
            rod_area_m2: 2.41e-3 * r.uniform(0.995, 1.005),
            stroke_m: 0.18,
            dead_volume_piston_m3: 2e-4 * r.uniform(0.85, 1.15),
            dead_volume_rod_m3: 2e-4 * r.uniform(0.85, 1.15),
            hose_fraction: r.uniform(0.3, 0.8),
            hose_stiffness_bar: r.log_uniform(5000.0, 30000.0),
            stop_stiffness_n_per_m: k,
            stop_damping_ns_per_m: r.uniform(0.5, 1.0) * 2.0 * (k * nominal_mass_kg).sqrt(),
        }
    }

    /// End-stop contact force, N (positive pushes towards extension), at
    /// position `x` (m), velocity `v` (m/s).
    #[inline]
    pub fn stop_force(&self, x: f64, v: f64) -> f64 {
        let hi = self.stroke_m - BUMPER_M;
        if x < BUMPER_M {
            (self.stop_stiffness_n_per_m * (BUMPER_M - x) - self.stop_damping_ns_per_m * v).max(0.0)
        } else if x > hi {
            (-self.stop_stiffness_n_per_m * (x - hi) - self.stop_damping_ns_per_m * v).min(0.0)
        } else {
            0.0
        }
    }

    /// The rigid heads: clamp position `x` (m) into the stroke and stop a
    /// velocity `v` (m/s) that points out of it.
    #[inline]
    pub fn clamp_to_heads(&self, x: &mut f64, v: &mut f64) {
        if *x < 0.0 {
            *x = 0.0;
            *v = v.max(0.0);
        } else if *x > self.stroke_m {
            *x = self.stroke_m;
            *v = v.min(0.0);
        }
    }
}
