//! The power unit: a pressure-compensated pump with a flow limit feeding a
//! compliant supply line, pump ripple, and the tank line's back pressure.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;
use crate::valve::LPM;

/// One rig's supply and tank lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SupplySpec {
    /// Maximum pump flow, l/min (25–45).
    pub pump_max_lpm: f64,
    /// Compensator droop: the supply pressure falls this far below the
    /// set pressure at the maximum flow, bar (1–5). Beyond the maximum
    /// flow the pressure collapses.
    pub droop_bar: f64,
    /// Oil volume of the supply line (pump, filter, hose), m³ (0.5–2 l).
    pub line_volume_m3: f64,
    /// Ripple fundamental, Hz (100–400).
    pub ripple_hz: f64,
    /// Ripple amplitude of harmonics 1..3, bar (first 0.2–2; higher ones
    /// 0.2–0.7 of it; 0 when absent).
    pub ripple_bar: [f64; 3],
    /// Ripple phases, rad.
    pub ripple_phase: [f64; 3],
    /// Tank back pressure at zero return flow, bar (0.3–2).
    pub tank_bar: f64,
    /// Extra tank back pressure at 30 l/min return flow, bar (0.5–3),
    /// quadratic in flow (return filter and cooler).
    pub tank_rise_bar_at_30lpm: f64,
    /// Time constant of the tank-line pressure, s (2–10 ms).
    pub tank_tau_s: f64,
}

impl SupplySpec {
    pub(crate) fn random(r: &mut Rand) -> Self {
        let n = r.int(1, 3) as usize;
        let a1 = r.uniform(0.2, 2.0);
        let mut ripple_bar = [0.0; 3];
        let mut ripple_phase = [0.0; 3];
        for h in 0..3 {
            let a = if h == 0 { a1 } else { a1 * r.uniform(0.2, 0.7) };
            if h < n {
                ripple_bar[h] = a;
            }
            ripple_phase[h] = r.uniform(0.0, std::f64::consts::TAU);
        }
        Self {
            pump_max_lpm: r.uniform(25.0, 45.0),
            droop_bar: r.uniform(1.0, 5.0),
            line_volume_m3: r.uniform(0.5e-3, 2e-3),
            ripple_hz: r.uniform(100.0, 400.0),
            ripple_bar,
            ripple_phase,
            tank_bar: r.uniform(0.3, 2.0),
            tank_rise_bar_at_30lpm: r.uniform(0.5, 3.0),
            tank_tau_s: r.uniform(0.002, 0.01),
        }
    }

    /// Pump delivery, m³/s, at supply pressure `ps` for set pressure
    /// `p_set` (bar): full flow up to `p_set − droop`, linear to zero at
    /// `p_set`.
    #[inline]
    pub fn pump_flow(&self, ps: f64, p_set: f64) -> f64 {
        self.pump_max_lpm * LPM * ((p_set - ps) / self.droop_bar).clamp(0.0, 1.0)
    }

    /// Pressure ripple at time `t` (s), bar.
    #[inline]
    pub fn ripple(&self, t: f64) -> f64 {
        let w = std::f64::consts::TAU * self.ripple_hz * t;
        let mut p = 0.0;
        for h in 0..3 {
            if self.ripple_bar[h] != 0.0 {
                p += self.ripple_bar[h] * ((h + 1) as f64 * w + self.ripple_phase[h]).sin();
            }
        }
        p
    }

    /// Ripple at the instants `t0 + j·dt_half`, j = 0..=2n (bar), into
    /// `out`: exact phasors at `t0`, rotated by half-steps (cheap, and
    /// re-synchronised every sample).
    pub(crate) fn ripple_series(&self, t0: f64, dt_half: f64, out: &mut Vec<f64>, n: usize) {
        out.clear();
        out.resize(n, 0.0);
        for h in 0..3 {
            let a = self.ripple_bar[h];
            if a == 0.0 {
                continue;
            }
            let w = std::f64::consts::TAU * self.ripple_hz * (h + 1) as f64;
            let (mut s, mut c) = (w * t0 + self.ripple_phase[h]).sin_cos();
            let (ds, dc) = (w * dt_half).sin_cos();
            for o in out.iter_mut() {
                *o += a * s;
                (s, c) = (s * dc + c * ds, c * dc - s * ds);
            }
        }
    }

    /// Quasi-static tank pressure at return flow `q` (m³/s), bar.
    #[inline]
    pub fn tank_static(&self, q: f64) -> f64 {
        let r = q.max(0.0) / (30.0 * LPM);
        self.tank_bar + self.tank_rise_bar_at_30lpm * r * r
    }
}
