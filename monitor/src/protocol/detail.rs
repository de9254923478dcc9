//! Detail frame `LM_Detail` (0x302, every second): the uncertainty of the
//! leak estimates, the leading hypothesis and the valve's flow-gain
//! deviation (a wear indicator).
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–5 | Leading | 0 healthy, 1 internal, 2 external, 3 both |
//! | 2 | | LeakInternalSd | u8, 0.001 l/min, 254 = 0.254 or more, 255 = not available |
//! | 3 | | LeakExternalSd | as above |
//! | 4–5 | | ValveGainDevExtend | i16, 0.1 %, −32768 = not available |
//! | 6–7 | | ValveGainDevRetract | i16, 0.1 %, −32768 = not available |

use super::bytes::{get_opt_i16, put_opt_i16, I16_NOT_AVAILABLE};
use super::quantize::{milli_i16, to_i32};
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::hypothesis::Hypothesis;
use crate::status::Status;

/// Raw value of an uncertainty that is not available.
pub const SD_NOT_AVAILABLE: u8 = u8::MAX;
/// Largest uncertainty on the wire, ml/min (larger values saturate).
pub const SD_MAX_ML_MIN: u8 = u8::MAX - 1;
/// Raw value of a valve deviation that is not available.
pub const GAIN_NOT_AVAILABLE: i16 = I16_NOT_AVAILABLE;

/// The detail frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DetailFrame {
    /// Best-supported hypothesis (before debounce and latching).
    pub leading: Hypothesis,
    /// 1σ of the internal leak flow, ml/min, saturating at 254.
    pub leak_internal_sd_ml_min: Option<u8>,
    /// 1σ of the external leak flow, ml/min, saturating at 254.
    pub leak_external_sd_ml_min: Option<u8>,
    /// Valve flow-gain deviation, extend direction, ‰ (0.1 %).
    pub valve_gain_extend_permille: Option<i16>,
    /// Valve flow-gain deviation, retract direction, ‰.
    pub valve_gain_retract_permille: Option<i16>,
}

fn sd_ml_min(lpm: Option<f32>) -> Option<u8> {
    to_i32(lpm, 1e-3, 0, SD_MAX_ML_MIN as i32).map(|v| v as u8)
}

impl DetailFrame {
    /// The frame for a monitor status.
    pub fn from_status(s: &Status) -> Self {
        Self {
            leading: s.leading,
            leak_internal_sd_ml_min: sd_ml_min(s.leak_internal_sd_lpm),
            leak_external_sd_ml_min: sd_ml_min(s.leak_external_sd_lpm),
            valve_gain_extend_permille: milli_i16(Some(s.valve_gain_deviation[0])),
            valve_gain_retract_permille: milli_i16(Some(s.valve_gain_deviation[1])),
        }
    }

    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.leading as u8) << 4;
        d[2] = self.leak_internal_sd_ml_min.unwrap_or(SD_NOT_AVAILABLE);
        d[3] = self.leak_external_sd_ml_min.unwrap_or(SD_NOT_AVAILABLE);
        put_opt_i16(d, 4, self.valve_gain_extend_permille);
        put_opt_i16(d, 6, self.valve_gain_retract_permille);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        // Two bits: every value is a hypothesis.
        let leading = Hypothesis::ALL[((d[1] >> 4) & 0x03) as usize];
        let sd = |v: u8| (v != SD_NOT_AVAILABLE).then_some(v);
        Ok(Self {
            leading,
            leak_internal_sd_ml_min: sd(d[2]),
            leak_external_sd_ml_min: sd(d[3]),
            valve_gain_extend_permille: get_opt_i16(d, 4),
            valve_gain_retract_permille: get_opt_i16(d, 6),
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("Leading", self.leading as u8, self.leading.name());
        s.quantity(
            "LeakInternalSd",
            self.leak_internal_sd_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.quantity(
            "LeakExternalSd",
            self.leak_external_sd_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.quantity(
            "ValveGainDevExtend",
            self.valve_gain_extend_permille.map(i32::from),
            1,
            "%",
        );
        s.quantity(
            "ValveGainDevRetract",
            self.valve_gain_retract_permille.map(i32::from),
            1,
            "%",
        );
        s.done()
    }
}
