//! Heartbeat frame `LM_Heartbeat` (0x303, every second): liveness, why
//! the board last reset, and how the estimator keeps its deadline.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | ResetCause | see [`ResetCause`] |
//! | 2–3 | | Uptime | u16, s since boot (wraps after 18.2 h) |
//! | 4 | | EstimatorLoad | u8, %, estimator busy time over the last second |
//! | 5 | | PeakLoad | u8, %, longest single step over the last second vs. the 1 ms period (> 100: a missed deadline) |
//! | 6 | | MissedSamples | u8, samples missed in the last second (late or lost), saturating at 255 |
//! | 7 | 0–3 | AdcOverruns | ADC ring-buffer overruns in the last second, saturating at 15 |
//! | 7 | 4–7 | CanTxDropped | CAN frames dropped (timeout, bus off, no ACK) in the last second, saturating at 15 |

use super::bytes::{get_u16, put_u16};
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::device::deadline::LoadReport;

/// Why the board last reset (from the reset flags at boot).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// Power-on or power-down reset.
    PowerOn = 0,
    /// Reset pin.
    Pin = 1,
    /// Independent watchdog: the estimator stopped keeping its deadline
    /// (or the firmware hung or panicked).
    Watchdog = 2,
    /// Software reset.
    Software = 3,
    /// Brown-out.
    BrownOut = 4,
    /// Low-power management reset.
    LowPower = 5,
    /// Window watchdog.
    WindowWatchdog = 6,
    /// No flag set.
    Unknown = 7,
}

impl ResetCause {
    /// Every cause, in wire-code order.
    pub const ALL: [ResetCause; 8] = [
        Self::PowerOn,
        Self::Pin,
        Self::Watchdog,
        Self::Software,
        Self::BrownOut,
        Self::LowPower,
        Self::WindowWatchdog,
        Self::Unknown,
    ];

    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::PowerOn => "power_on",
            Self::Pin => "pin",
            Self::Watchdog => "watchdog",
            Self::Software => "software",
            Self::BrownOut => "brown_out",
            Self::LowPower => "low_power",
            Self::WindowWatchdog => "window_watchdog",
            Self::Unknown => "unknown",
        }
    }
}

/// Largest value of the 4-bit counters.
pub const NIBBLE_MAX: u8 = 15;

/// The heartbeat frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeartbeatFrame {
    /// Why the board last reset.
    pub reset_cause: ResetCause,
    /// Seconds since boot, wrapping at 65536.
    pub uptime_s: u16,
    /// Estimator busy time over the last second, % (rounded).
    pub estimator_load_pct: u8,
    /// Longest single estimator step of the last second, % of the 1 ms
    /// sample period (saturating at 255).
    pub peak_load_pct: u8,
    /// Samples missed in the last second (saturating at 255).
    pub missed_samples: u8,
    /// ADC overruns in the last second, 0..=15 (15: 15 or more).
    pub adc_overruns: u8,
    /// CAN frames dropped in the last second, 0..=15 (15: 15 or more).
    pub can_tx_dropped: u8,
}

impl HeartbeatFrame {
    /// The heartbeat for one report period: `load` from the deadline
    /// monitor, `can_dropped` frames dropped in the period, `uptime_s`
    /// since boot (wrapping). Counts saturate as the wire requires.
    pub fn new(
        reset_cause: ResetCause,
        uptime_s: u64,
        load: &LoadReport,
        can_dropped: u32,
    ) -> Self {
        let nibble = |v: u32| v.min(NIBBLE_MAX as u32) as u8;
        Self {
            reset_cause,
            uptime_s: uptime_s as u16,
            estimator_load_pct: load.load_pct,
            peak_load_pct: load.peak_pct,
            missed_samples: load.missed.min(u8::MAX as u32) as u8,
            adc_overruns: nibble(load.overruns),
            can_tx_dropped: nibble(can_dropped),
        }
    }

    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = (self.reset_cause as u8) << 4;
        put_u16(d, 2, self.uptime_s);
        d[4] = self.estimator_load_pct;
        d[5] = self.peak_load_pct;
        d[6] = self.missed_samples;
        d[7] = self.adc_overruns.min(NIBBLE_MAX) | self.can_tx_dropped.min(NIBBLE_MAX) << 4;
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let code = d[1] >> 4;
        let reset_cause = ResetCause::ALL
            .get(code as usize)
            .copied()
            .ok_or(FieldError {
                field: "ResetCause",
                raw: code as u32,
            })?;
        Ok(Self {
            reset_cause,
            uptime_s: get_u16(d, 2),
            estimator_load_pct: d[4],
            peak_load_pct: d[5],
            missed_samples: d[6],
            adc_overruns: d[7] & 0x0F,
            can_tx_dropped: d[7] >> 4,
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated(
            "ResetCause",
            self.reset_cause as u8,
            self.reset_cause.name(),
        );
        s.integer("Uptime", self.uptime_s as u32, "s");
        s.integer("EstimatorLoad", self.estimator_load_pct as u32, "%");
        s.integer("PeakLoad", self.peak_load_pct as u32, "%");
        s.integer("MissedSamples", self.missed_samples as u32, "");
        s.integer("AdcOverruns", self.adc_overruns.min(NIBBLE_MAX) as u32, "");
        s.integer(
            "CanTxDropped",
            self.can_tx_dropped.min(NIBBLE_MAX) as u32,
            "",
        );
        s.done()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_from_a_load_report_with_saturation() {
        let load = LoadReport {
            processed: 990,
            missed: 300,
            overruns: 2,
            load_pct: 37,
            peak_pct: 142,
        };
        let h = HeartbeatFrame::new(ResetCause::Watchdog, 65_536 + 7, &load, 40);
        assert_eq!(h.uptime_s, 7, "wraps");
        assert_eq!((h.estimator_load_pct, h.peak_load_pct), (37, 142));
        assert_eq!(h.missed_samples, 255);
        assert_eq!((h.adc_overruns, h.can_tx_dropped), (2, 15));
        assert_eq!(h.reset_cause, ResetCause::Watchdog);
    }
}
