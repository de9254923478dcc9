//! Sensitivity frame `LM_Sensitivity` (0x307, every second): the level a
//! leak estimate must exceed to alarm right now, i.e. what a `healthy`
//! verdict is measured against — per leak the alarm level in use (the
//! user's, raised to the installation's floor in the current operating
//! region, [`Status::alarm_level_lpm`]) — and the current evidence weight.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | reserved | 0 |
//! | 2–3 | | AlarmLevelInternal | u16, 0.001 l/min, 65534 = 65.534 or more, 65535 = not available |
//! | 4–5 | | AlarmLevelExternal | as above |
//! | 6 | | EvidenceWeight | u8, %, 0..=100, 255 = not available |
//! | 7 | | reserved | 0 |
//!
//! Each level is the highest in use over the frame's period (since the
//! previous frame; the level follows the operating region from sample to
//! sample), so that every sample of that second was measured against at
//! least it. The levels are not available while the monitor has no leak
//! estimate (warming up, a sensor fault), as `LM_Status`' leak sizes.

use super::bytes::{get_u16, put_u16};
use super::quantize::to_i32;
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::status::Status;

/// Raw value of an alarm level that is not available.
pub const LEVEL_NOT_AVAILABLE: u16 = u16::MAX;
/// Largest alarm level on the wire, ml/min (larger values saturate).
pub const LEVEL_MAX_ML_MIN: u16 = u16::MAX - 1;
/// Raw value of an evidence weight that is not available.
pub const WEIGHT_NOT_AVAILABLE: u8 = u8::MAX;
/// Largest evidence weight, %.
pub const WEIGHT_MAX_PCT: u8 = 100;

/// The sensitivity frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensitivityFrame {
    /// Alarm level in use for the internal leak, ml/min (= 0.001 l/min),
    /// saturating at [`LEVEL_MAX_ML_MIN`]; `None` while the monitor has
    /// no leak estimate.
    pub alarm_level_internal_ml_min: Option<u16>,
    /// Alarm level in use for the external leak, ml/min, as above.
    pub alarm_level_external_ml_min: Option<u16>,
    /// How much the sample counts as leak evidence, % (0..=100).
    pub evidence_weight_pct: Option<u8>,
}

/// `lpm` in ml/min, rounded and saturated to the wire's range.
fn level_ml_min(lpm: Option<f32>) -> Option<u16> {
    to_i32(lpm, 1e-3, 0, LEVEL_MAX_ML_MIN as i32).map(|v| v as u16)
}

impl SensitivityFrame {
    /// The frame for a monitor status: its alarm levels at that sample.
    pub fn from_status(s: &Status) -> Self {
        Self::with_levels(s.published_alarm_levels(), s)
    }

    /// The frame for a monitor status with the alarm levels `levels`
    /// (internal, external; l/min) — on the device the period's highest
    /// ([`LevelPeak`](crate::device::level_peak::LevelPeak)).
    pub fn with_levels(levels: [Option<f32>; 2], s: &Status) -> Self {
        let [internal, external] = levels;
        Self {
            alarm_level_internal_ml_min: level_ml_min(internal),
            alarm_level_external_ml_min: level_ml_min(external),
            evidence_weight_pct: to_i32(Some(s.evidence_weight), 1e-2, 0, WEIGHT_MAX_PCT as i32)
                .map(|v| v as u8),
        }
    }

    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        put_u16(
            d,
            2,
            self.alarm_level_internal_ml_min
                .unwrap_or(LEVEL_NOT_AVAILABLE),
        );
        put_u16(
            d,
            4,
            self.alarm_level_external_ml_min
                .unwrap_or(LEVEL_NOT_AVAILABLE),
        );
        d[6] = self.evidence_weight_pct.unwrap_or(WEIGHT_NOT_AVAILABLE);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let level = |at: usize| Some(get_u16(d, at)).filter(|&v| v != LEVEL_NOT_AVAILABLE);
        let evidence_weight_pct = match d[6] {
            WEIGHT_NOT_AVAILABLE => None,
            w if w <= WEIGHT_MAX_PCT => Some(w),
            w => {
                return Err(FieldError {
                    field: "EvidenceWeight",
                    raw: w.into(),
                })
            }
        };
        Ok(Self {
            alarm_level_internal_ml_min: level(2),
            alarm_level_external_ml_min: level(4),
            evidence_weight_pct,
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.quantity(
            "AlarmLevelInternal",
            self.alarm_level_internal_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.quantity(
            "AlarmLevelExternal",
            self.alarm_level_external_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.quantity(
            "EvidenceWeight",
            self.evidence_weight_pct.map(i32::from),
            0,
            "%",
        );
        s.done()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_and_round_trip() {
        let f = SensitivityFrame {
            alarm_level_internal_ml_min: Some(0x1234),
            alarm_level_external_ml_min: None,
            evidence_weight_pct: Some(100),
        };
        let mut d = [0u8; 8];
        f.write(&mut d);
        assert_eq!(d[1..8], [0x00, 0x34, 0x12, 0xFF, 0xFF, 100, 0]);
        assert_eq!(SensitivityFrame::read(&d), Ok(f));
        d[6] = WEIGHT_NOT_AVAILABLE;
        assert_eq!(
            SensitivityFrame::read(&d).unwrap().evidence_weight_pct,
            None
        );
        d[6] = 101;
        assert_eq!(
            SensitivityFrame::read(&d),
            Err(FieldError {
                field: "EvidenceWeight",
                raw: 101
            })
        );
    }
}
