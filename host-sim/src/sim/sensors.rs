//! The measurement chain of the rig: 4–20 mA pressure transmitters with a
//! first-order lag, a position transducer, the valve command read back by
//! the ADC; white noise, offsets and ADC quantisation on each. The offsets
//! are the rig's ([`SensorOffsets`]), the rest is the scenario's
//! [`SensorModel`].

use super::rig_data::SensorOffsets;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Sensor imperfections other than offsets (those are the rig's).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorModel {
    /// First-order lag of every pressure transmitter, s (MBS 3050: < 4 ms).
    pub pressure_lag_s: f64,
    /// White noise on pressures, bar (1σ).
    pub pressure_noise_bar: f64,
    /// White noise on position, m (1σ).
    pub position_noise_m: f64,
    /// White noise on the valve command read-back (1σ).
    pub command_noise: f64,
    /// Quantisation step of a pressure reading after oversampling, bar.
    pub pressure_step_bar: f64,
    /// Quantisation step of the position reading, m.
    pub position_step_m: f64,
    /// Quantisation step of the valve command reading.
    pub command_step: f64,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self {
            pressure_lag_s: 0.004,
            pressure_noise_bar: 0.04,
            position_noise_m: 2.0e-5,
            command_noise: 2.0e-4,
            // 12-bit ADC, 150 Ω shunt, 0–250 bar transmitter: 0.084 bar per
            // count, 8× oversampling.
            pressure_step_bar: 0.0105,
            // 12-bit over 0.2 m, 4× oversampling.
            position_step_m: 1.2e-5,
            // 12-bit over ±10 V, 4× oversampling.
            command_step: 1.2e-4,
        }
    }
}

/// The running sensor chain (lag states).
#[derive(Clone, Debug)]
pub struct Sensors {
    model: SensorModel,
    offsets: SensorOffsets,
    lagged: Option<[f64; 4]>,
}

/// One reading of every channel, engineering units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Readings {
    /// Supply, piston, rod, tank pressures, bar.
    pub pressures_bar: [f64; 4],
    /// Position, m.
    pub x_m: f64,
}

impl Sensors {
    /// A sensor chain with imperfections `model` and the rig's `offsets`.
    pub fn new(model: SensorModel, offsets: SensorOffsets) -> Self {
        Self {
            model,
            offsets,
            lagged: None,
        }
    }

    /// Advance the transmitter lags by `h` seconds with true pressures
    /// `p_bar` (supply, piston, rod, tank).
    pub fn track(&mut self, p_bar: [f64; 4], h: f64) {
        let tau = self.model.pressure_lag_s;
        let lagged = self.lagged.get_or_insert(p_bar);
        let a = if tau > 0.0 {
            1.0 - (-h / tau).exp()
        } else {
            1.0
        };
        for i in 0..4 {
            lagged[i] += a * (p_bar[i] - lagged[i]);
        }
    }

    /// Read the pressures and the position now.
    pub fn read(&self, x_m: f64, rng: &mut ChaCha8Rng) -> Readings {
        let (m, o) = (&self.model, &self.offsets);
        let lagged = self.lagged.unwrap_or([0.0; 4]);
        let mut pressures_bar = [0.0; 4];
        for i in 0..4 {
            let n: f64 = rng.sample(StandardNormal);
            pressures_bar[i] = quantise(
                lagged[i] + o.pressure_offsets_bar[i] + m.pressure_noise_bar * n,
                m.pressure_step_bar,
            );
        }
        let n: f64 = rng.sample(StandardNormal);
        Readings {
            pressures_bar,
            x_m: quantise(
                x_m + o.position_offset_m + m.position_noise_m * n,
                m.position_step_m,
            ),
        }
    }

    /// Read back the valve command `u`.
    pub fn read_command(&self, u: f64, rng: &mut ChaCha8Rng) -> f64 {
        let n: f64 = rng.sample(StandardNormal);
        quantise(u + self.model.command_noise * n, self.model.command_step).clamp(-1.0, 1.0)
    }
}

fn quantise(v: f64, step: f64) -> f64 {
    if step > 0.0 {
        (v / step).round() * step
    } else {
        v
    }
}
