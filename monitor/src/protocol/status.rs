//! Status frame `LM_Status` (0x301, every 100 ms): the monitor's verdict,
//! the estimated leak flows and the health flags.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | Verdict | 0 healthy, 1 internal, 2 external, 3 both, 4 sensor fault, 5 inconclusive |
//! | 2–3 | | LeakInternal | i16, 0.001 l/min, −32768 = not available |
//! | 4–5 | | LeakExternal | i16, 0.001 l/min, −32768 = not available |
//! | 6–7 | | Health | `status::health` bit mask |

use super::bytes::{get_opt_i16, get_u16, put_opt_i16, put_u16, I16_NOT_AVAILABLE};
use super::quantize::milli_i16;
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::status::{Status, Verdict};

/// Raw value of a leak flow that is not available.
pub const FLOW_NOT_AVAILABLE: i16 = I16_NOT_AVAILABLE;

/// The status frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StatusFrame {
    /// The monitor's verdict.
    pub verdict: Verdict,
    /// Internal leak flow, ml/min (= 0.001 l/min), ±32767 saturating;
    /// `None` while the monitor has no estimate.
    pub leak_internal_ml_min: Option<i16>,
    /// External leak flow, ml/min, as above.
    pub leak_external_ml_min: Option<i16>,
    /// Health flags (`status::health::*`).
    pub health: u16,
}

/// Verdict of a wire code.
pub(crate) fn verdict_from_code(code: u8) -> Option<Verdict> {
    [
        Verdict::Healthy,
        Verdict::Internal,
        Verdict::External,
        Verdict::Both,
        Verdict::SensorFault,
        Verdict::Inconclusive,
    ]
    .get(code as usize)
    .copied()
}

impl StatusFrame {
    /// The frame for a monitor status.
    pub fn from_status(s: &Status) -> Self {
        Self {
            verdict: s.verdict,
            leak_internal_ml_min: milli_i16(s.leak_internal_lpm),
            leak_external_ml_min: milli_i16(s.leak_external_lpm),
            health: s.health,
        }
    }

    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.verdict as u8) << 4;
        put_opt_i16(d, 2, self.leak_internal_ml_min);
        put_opt_i16(d, 4, self.leak_external_ml_min);
        put_u16(d, 6, self.health);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let code = d[1] >> 4;
        let verdict = verdict_from_code(code).ok_or(FieldError {
            field: "Verdict",
            raw: code as u32,
        })?;
        Ok(Self {
            verdict,
            leak_internal_ml_min: get_opt_i16(d, 2),
            leak_external_ml_min: get_opt_i16(d, 4),
            health: get_u16(d, 6),
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("Verdict", self.verdict as u8, self.verdict.name());
        s.quantity(
            "LeakInternal",
            self.leak_internal_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.quantity(
            "LeakExternal",
            self.leak_external_ml_min.map(i32::from),
            3,
            "l/min",
        );
        s.integer("Health", self.health as u32, "");
        s.done()
    }
}
