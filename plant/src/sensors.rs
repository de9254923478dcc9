//! The measurement chain of each channel: first-order lag, offset, white
//! noise, coloured (AR(1)) noise, pickup of the pump ripple, loop range
//! (4–20 mA under/over-range) and quantisation.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// One measured channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelSpec {
    /// White noise, 1σ, channel units (bar or m).
    pub white_sigma: f64,
    /// Stationary 1σ of the coloured (AR(1)) noise, channel units
    /// (0–1 × the white level).
    pub coloured_sigma: f64,
    /// Correlation time of the coloured noise, s (2–50 ms).
    pub coloured_tau_s: f64,
    /// Offset added to the reading, channel units (±0.5 bar, ±1 mm).
    pub offset: f64,
    /// First-order lag of the transmitter, s (0–8 ms).
    pub lag_s: f64,
    /// Quantisation step, channel units (0 = none).
    pub quantum: f64,
    /// Readable range `[lo, hi]`, channel units (beyond: clipped).
    pub range: [f64; 2],
    /// Fraction of the pump pressure ripple picked up electrically or by
    /// the pulsation at the port (pressure channels), 0–0.3.
    pub ripple_pickup: f64,
}

/// All measured channels of a rig.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorSpec {
    /// Supply, piston chamber, rod chamber and tank pressure, bar.
    pub pressure: [ChannelSpec; 4],
    /// Piston position, m.
    pub position: ChannelSpec,
    /// Offset of the recorded valve command (a voltage read back), −1..1
    /// units (0 on most rigs, ±0.003 on 30 %).
    pub valve_command_offset: f64,
    /// Oil temperature reading noise, 1σ °C (0.1–0.5); quantised to 0.1 °C.
    pub temperature_sigma_c: f64,
}

impl ChannelSpec {
    fn random(
        r: &mut Rand,
        white: f64,
        offset: f64,
        quantum: f64,
        range: [f64; 2],
        ripple: f64,
    ) -> Self {
        Self {
            white_sigma: white,
            coloured_sigma: white * r.uniform(0.0, 1.0),
            coloured_tau_s: r.log_uniform(0.002, 0.05),
            offset: r.uniform(-offset, offset),
            lag_s: r.uniform(0.0, 0.008),
            quantum,
            range,
            ripple_pickup: ripple,
        }
    }

    /// Readings of the true signal `truth` sampled every `dt` (s), with the
    /// pump ripple `ripple` at the same instants (bar), noise from `r`.
    pub(crate) fn measure(&self, truth: &[f64], ripple: &[f64], dt: f64, r: &mut Rand) -> Vec<f64> {
        let a_lag = if self.lag_s > 0.0 {
            1.0 - (-dt / self.lag_s).exp()
        } else {
            1.0
        };
        let phi = (-dt / self.coloured_tau_s).exp();
        let drive = self.coloured_sigma * (1.0 - phi * phi).sqrt();
        let mut lagged = truth.first().copied().unwrap_or(0.0);
        let mut col = self.coloured_sigma * r.normal();
        let mut out = Vec::with_capacity(truth.len());
        for (k, &y) in truth.iter().enumerate() {
            lagged += a_lag * (y - lagged);
            col = phi * col + drive * r.normal();
            let mut v = lagged
                + self.offset
                + self.white_sigma * r.normal()
                + col
                + self.ripple_pickup * ripple[k];
            v = v.clamp(self.range[0], self.range[1]);
            if self.quantum > 0.0 {
                v = (v / self.quantum).round() * self.quantum;
            }
            out.push(v);
        }
        out
    }
}

impl SensorSpec {
    pub(crate) fn random(r: &mut Rand) -> Self {
        let full_scale = if r.chance(0.5) { 250.0 } else { 400.0 };
        let p_bits = if r.chance(0.5) { 12 } else { 16 };
        let q = full_scale / f64::from(1u32 << p_bits);
        // 4–20 mA: 3.8 mA under-range, 20.5 mA over-range.
        let range = [-0.0125 * full_scale, 1.03125 * full_scale];
        let ch = |r: &mut Rand, pickup: f64| {
            let white = r.log_uniform(0.02, 0.6);
            ChannelSpec::random(r, white, 0.5, q, range, pickup)
        };
        let supply = ch(r, 0.0);
        let pa = {
            let k = r.uniform(0.0, 0.3);
            ch(r, k)
        };
        let pb = {
            let k = r.uniform(0.0, 0.3);
            ch(r, k)
        };
        let pt = {
            let k = r.uniform(0.0, 0.1);
            ch(r, k)
        };
        let x_bits = r.int(12, 16);
        let xq = 0.2 / f64::from(1u32 << x_bits);
        let xw = r.log_uniform(1e-5, 1.5e-4);
        let position = ChannelSpec::random(r, xw, 0.001, xq, [-0.005, 0.205], 0.0);
        let valve_command_offset = if r.chance(0.3) {
            r.uniform(-0.003, 0.003)
        } else {
            0.0
        };
        Self {
            pressure: [supply, pa, pb, pt],
            position,
            valve_command_offset,
            temperature_sigma_c: r.uniform(0.1, 0.5),
        }
    }
}
