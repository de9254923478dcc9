//! Alarm frame `LM_Alarm` (0x300): the alarm output, sent at once when
//! anything in it changes, and every second.
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | AlarmState | 0 starting, 1 healthy, 2 leak, 3 sensor fault, 4 estimator stalled, 5 inconclusive, 6 device fault |
//! | 2 | 0–1 | LatchedLeak | 0 none, 1 internal, 2 external, 3 both |
//! | 2 | 2 | RelayEnergised | 1 = energised (healthy) |
//! | 2 | 3–7 | DeviceFault | 0 none, else `DeviceFault` code (1 flash image … 8 program flow) |
//! | 3 | 0–7 | FaultedChannels | bit per `Channel` (0 p_supply … 6 temp_oil) |
//! | 4–7 | | ChangedAt | u32, ms on the sample clock (since the first sample) of the last change (wraps after 49.7 days) |

use super::bytes::{get_u32, put_u32};
use super::signal::SignalList;
use super::{FieldError, Signals};
use crate::device::alarm::{AlarmOutput, AlarmState};
use crate::device::diagnostics::DeviceFault;
use crate::leak::LeakSet;

/// The alarm frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlarmFrame {
    /// The state shown.
    pub state: AlarmState,
    /// Latched leaks.
    pub latched: LeakSet,
    /// Relay commanded energised.
    pub relay_energised: bool,
    /// Faulted input channels, `Channel::bit` mask.
    pub faulted_channels: u8,
    /// The device fault shown (`DeviceFault` code, 0 = none).
    pub device_fault: u8,
    /// Time of the last change of the alarm output, ms on the monitor's
    /// sample clock (since the first sample; it counts samples, lost ones
    /// included, so it runs on across ADC overruns).
    pub changed_at_ms: u32,
}

impl AlarmFrame {
    /// The frame for the alarm output `out`, last changed at
    /// `changed_at_ms`.
    pub const fn new(out: &AlarmOutput, changed_at_ms: u32) -> Self {
        Self {
            state: out.state,
            latched: out.latched,
            relay_energised: out.relay_energised(),
            faulted_channels: out.faulted_channels,
            device_fault: out.device_fault,
            changed_at_ms,
        }
    }

    /// The output this frame shows.
    pub const fn output(&self) -> AlarmOutput {
        AlarmOutput {
            state: self.state,
            latched: self.latched,
            faulted_channels: self.faulted_channels,
            device_fault: self.device_fault,
        }
    }

    /// This frame as the supervisor reports a stalled estimator at
    /// `changed_at_ms`, the estimator being the one that stopped: its
    /// output [once stalled](AlarmOutput::stalled).
    pub const fn stalled(&self, changed_at_ms: u32) -> Self {
        Self::new(&self.output().stalled(), changed_at_ms)
    }

    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = self.state.code() << 4;
        d[2] = self.latched.code() | (self.relay_energised as u8) << 2 | self.device_fault << 3;
        d[3] = self.faulted_channels;
        put_u32(d, 4, self.changed_at_ms);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let code = d[1] >> 4;
        let state = AlarmState::from_code(code).ok_or(FieldError {
            field: "AlarmState",
            raw: code as u32,
        })?;
        let device_fault = d[2] >> 3;
        if device_fault != 0 && DeviceFault::from_code(device_fault).is_none() {
            return Err(FieldError {
                field: "DeviceFault",
                raw: device_fault as u32,
            });
        }
        Ok(Self {
            state,
            // Two bits: every value is a kind.
            latched: LeakSet::of(d[2] & 0x01 != 0, d[2] & 0x02 != 0),
            relay_energised: d[2] & 0x04 != 0,
            device_fault,
            faulted_channels: d[3],
            changed_at_ms: get_u32(d, 4),
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.enumerated("AlarmState", self.state.code(), self.state.name());
        s.enumerated("LatchedLeak", self.latched.code(), self.latched.name());
        s.flag("RelayEnergised", self.relay_energised);
        let fault = DeviceFault::from_code(self.device_fault).map_or("none", DeviceFault::name);
        s.enumerated("DeviceFault", self.device_fault, fault);
        s.integer("FaultedChannels", self.faulted_channels as u32, "");
        s.integer("ChangedAt", self.changed_at_ms, "ms");
        s.done()
    }
}
