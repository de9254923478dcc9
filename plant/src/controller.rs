//! The machine's position controller: P or PI with velocity feed-forward,
//! output saturated at ±1, run at the sample rate on the machine's own
//! position reading (the true position; the recording's sensor is a
//! different instrument).

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// One rig's position controller.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerSpec {
    /// Proportional gain, 1/m (valve command per metre of error, 20–80).
    pub kp_per_m: f64,
    /// Integral gain, 1/(m·s) (0 for a P controller; PI on ~30 % of rigs).
    pub ki_per_m_s: f64,
    /// Limit of the integral part, fraction of full command.
    pub integral_limit: f64,
    /// Velocity feed-forward, command per m/s (0 or 2–5).
    pub feed_forward_s_per_m: f64,
}

impl ControllerSpec {
    pub(crate) fn random(r: &mut Rand) -> Self {
        let kp = r.uniform(20.0, 80.0);
        let ki = if r.chance(0.3) {
            kp * r.uniform(0.2, 1.0)
        } else {
            0.0
        };
        let ff = if r.chance(0.5) {
            r.uniform(2.0, 5.0)
        } else {
            0.0
        };
        Self {
            kp_per_m: kp,
            ki_per_m_s: ki,
            integral_limit: 0.05,
            feed_forward_s_per_m: ff,
        }
    }
}

/// Controller state.
#[derive(Clone, Debug, Default)]
pub(crate) struct Controller {
    integral: f64,
}

impl Controller {
    /// Command for setpoint `x_ref` (m), setpoint speed `v_ref` (m/s) and
    /// measured position `x` (m), advancing the integral by `dt` (s).
    pub(crate) fn step(
        &mut self,
        spec: &ControllerSpec,
        x_ref: f64,
        v_ref: f64,
        x: f64,
        dt: f64,
    ) -> f64 {
        let e = x_ref - x;
        if spec.ki_per_m_s > 0.0 {
            self.integral = (self.integral + spec.ki_per_m_s * e * dt)
                .clamp(-spec.integral_limit, spec.integral_limit);
        }
        (spec.kp_per_m * e + self.integral + spec.feed_forward_s_per_m * v_ref).clamp(-1.0, 1.0)
    }
}
