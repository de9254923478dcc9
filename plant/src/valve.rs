//! The servo valve: a second-order spool with travel limits, four metering
//! edges with their own gains and overlaps, a smooth turbulent/laminar
//! orifice law, and laminar land leakage per edge that shrinks as the edge
//! overlap grows.
//!
//! Spool position `s` is a fraction of full travel (−1..1). Positive travel
//! opens P→A and B→T (the cylinder extends), negative opens P→B and A→T.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// l/min → m³/s.
pub const LPM: f64 = 1e-3 / 60.0;

/// Edge order used in arrays: P→A, A→T, P→B, B→T.
pub const EDGES: [&str; 4] = ["P→A", "A→T", "P→B", "B→T"];

/// One rig's valve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValveSpec {
    /// Spool natural frequency, rad/s (880 ±20 %).
    pub natural_frequency_rad_s: f64,
    /// Spool damping ratio (0.92 ±20 %).
    pub damping_ratio: f64,
    /// Spool position at zero command (null bias), fraction of travel
    /// (±0.005).
    pub null_bias: f64,
    /// Overlap (dead zone) of each edge, fraction of travel, order P→A,
    /// A→T, P→B, B→T (a common 0.005–0.03, ±15 % per edge).
    pub overlap: [f64; 4],
    /// Turbulent flow gain of each edge at full opening, l/min/√bar
    /// (P→A, B→T ≈ 7.9; A→T, P→B ≈ 7.4; overall ±8 %, each edge ±3 %).
    /// Full opening is spool travel 1; the opening grows linearly from the
    /// overlap to 1.
    pub flow_gain_lpm_sqrt_bar: [f64; 4],
    /// Pressure drop of the laminar/turbulent transition, bar (0.3–2):
    /// `Q = K·a·Δp / (Δp² + Δp_t²)^¼`.
    pub transition_dp_bar: f64,
    /// Land leakage of each edge with the spool centred at the reference
    /// viscosity (25 °C), l/min/bar (3e-3 × 0.3–3, drawn per edge).
    pub land_leak_lpm_per_bar: [f64; 4],
    /// Overlap length over which the land leakage decays by e, fraction of
    /// travel (0.005–0.02): leak ∝ exp(−(cover − overlap)/w), where
    /// `cover` is the edge's actual covering (overlap ∓ spool travel).
    pub land_leak_decay: f64,
}

impl ValveSpec {
    pub(crate) fn random(r: &mut Rand) -> Self {
        let overall = r.uniform(0.92, 1.08);
        let nominal = [7.9025, 7.4187, 7.4187, 7.9025];
        let mut flow_gain = [0.0; 4];
        for (g, n) in flow_gain.iter_mut().zip(nominal) {
            *g = n * overall * r.uniform(0.97, 1.03);
        }
        let d = r.uniform(0.005, 0.03);
        let mut overlap = [0.0; 4];
        for o in &mut overlap {
            *o = d * r.uniform(0.85, 1.15);
        }
        let mut leak = [0.0; 4];
        for l in &mut leak {
            *l = 3e-3 * r.log_uniform(0.3, 3.0);
        }
        Self {
            natural_frequency_rad_s: 879.6 * r.uniform(0.8, 1.2),
            damping_ratio: 0.92 * r.uniform(0.8, 1.2),
            null_bias: r.uniform(-0.005, 0.005),
            overlap,
            flow_gain_lpm_sqrt_bar: flow_gain,
            transition_dp_bar: r.uniform(0.3, 2.0),
            land_leak_lpm_per_bar: leak,
            land_leak_decay: r.uniform(0.005, 0.02),
        }
    }

    /// Spool acceleration, 1/s², for command `u` (clamped to ±1), spool
    /// position `s` and velocity `sv`.
    #[inline]
    pub fn spool_accel(&self, u: f64, s: f64, sv: f64) -> f64 {
        let w = self.natural_frequency_rad_s;
        w * w * (u.clamp(-1.0, 1.0) + self.null_bias - s) - 2.0 * self.damping_ratio * w * sv
    }

    /// Flow through each edge, m³/s, in the edge's direction (P→A, A→T,
    /// P→B, B→T; negative is back-flow), at spool `s`, supply `ps`,
    /// chambers `pa`, `pb`, tank `pt` (bar) and viscosity ratio
    /// `nu_ref/nu` (laminar leaks scale with it).
    #[inline]
    pub fn edge_flows(
        &self,
        s: f64,
        ps: f64,
        pa: f64,
        pb: f64,
        pt: f64,
        fluidity: f64,
    ) -> [f64; 4] {
        // Signed travel opening each edge: positive opens P→A and B→T.
        let travel = [s, -s, -s, s];
        let dp = [ps - pa, pa - pt, ps - pb, pb - pt];
        let mut q = [0.0; 4];
        let dpt2 = self.transition_dp_bar * self.transition_dp_bar;
        // exp(−(cover − overlap)/w) = exp(±s/w) while the edge is covered:
        // one exponential serves all four edges.
        let grow = (s / self.land_leak_decay).exp();
        let growth = [grow, 1.0 / grow, 1.0 / grow, grow];
        for e in 0..4 {
            let ov = self.overlap[e];
            let cover = ov - travel[e];
            let d = dp[e];
            let (turb, factor) = if cover < 0.0 {
                let open = -cover / (1.0 - ov);
                let turb = self.flow_gain_lpm_sqrt_bar[e] * open * d / (d * d + dpt2).sqrt().sqrt();
                (turb, (ov / self.land_leak_decay).exp()) // open: rare
            } else {
                (0.0, growth[e])
            };
            let leak = self.land_leak_lpm_per_bar[e] * factor * d * fluidity;
            q[e] = (turb + leak) * LPM;
        }
        q
    }
}
