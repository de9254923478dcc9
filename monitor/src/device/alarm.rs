//! The alarm output: what the fail-safe relay, the status LED and the CAN
//! alarm frame show. It is a pure function of the monitor's [`Status`] and
//! of whether the supervisor declared the estimator stalled
//! ([`AlarmOutput::of`]); it holds no state of its own.
//!
//! The relay is **energised only when healthy**: at boot, during the
//! filters' warm-up, on a latched leak alarm, on a sensor fault and after
//! the estimator stalled it is de-energised (and a dead board, a reset or
//! a missing supply de-energise it too). Precedence, highest first:
//! estimator stalled > sensor fault > latched leak > starting >
//! inconclusive > healthy. `Inconclusive` keeps the relay off like the
//! warm-up: the relay's "healthy" is a claim backed by evidence.
//!
//! Leak alarms latch in one place, the decision layer's latch
//! (`decision::latch`), reported as [`Status::latched`]: kept through
//! sensor faults and filter restarts until acknowledged through
//! [`Monitor::acknowledge`](crate::Monitor::acknowledge).

use crate::device::diagnostics::DeviceFaults;
use crate::leak::LeakSet;
use crate::status::{health, Status, Verdict};

/// What the alarm output shows, in precedence order (low to high).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlarmState {
    /// Booting or filters warming up: no verdict yet. Relay off.
    Starting = 0,
    /// Monitoring, no alarm. Relay energised.
    Healthy = 1,
    /// A leak alarm is latched. Relay off.
    Leak = 2,
    /// A required sensor is faulted: no leak verdict possible. Relay off.
    SensorFault = 3,
    /// The estimator stopped keeping its deadline. Relay off; the
    /// watchdog resets the board.
    EstimatorStalled = 4,
    /// Running, but the monitor has not seen enough valid evidence to
    /// claim healthy (time not advancing, filters resetting, model misfit,
    /// too little quasi-steady operation). Relay off, like the warm-up.
    Inconclusive = 5,
    /// The device itself failed a diagnostic (flash, RAM, ADC reference,
    /// clock, brown-out level, relay read-back, program flow; the code is
    /// in the alarm frame's `DeviceFault`). Relay off until reset.
    DeviceFault = 6,
}

impl AlarmState {
    /// Every state, in wire-code order.
    pub const ALL: [AlarmState; 7] = [
        Self::Starting,
        Self::Healthy,
        Self::Leak,
        Self::SensorFault,
        Self::EstimatorStalled,
        Self::Inconclusive,
        Self::DeviceFault,
    ];

    /// Wire code (CAN alarm frame).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The state of a wire code, if valid.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name (logs, `host-sim decode`, the DBC value table).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Starting => "starting",
            Self::Healthy => "healthy",
            Self::Leak => "leak",
            Self::SensorFault => "sensor_fault",
            Self::EstimatorStalled => "estimator_stalled",
            Self::Inconclusive => "inconclusive",
            Self::DeviceFault => "device_fault",
        }
    }

    /// Is the fail-safe relay energised in this state?
    pub const fn relay_energised(self) -> bool {
        matches!(self, Self::Healthy)
    }

    /// Status LED at `t_ms` since boot: a short flash every second when
    /// healthy, 1 Hz blink while starting, steady on for a leak, 5 Hz
    /// blink for a sensor fault, off when stalled.
    pub const fn led_on(self, t_ms: u32) -> bool {
        match self {
            Self::Healthy => t_ms % 1000 < 50,
            Self::Starting | Self::Inconclusive => t_ms % 1000 < 500,
            Self::Leak => true,
            Self::SensorFault | Self::DeviceFault => t_ms % 200 < 100,
            Self::EstimatorStalled => false,
        }
    }
}

/// Everything the alarm output shows; a change of any field is sent at
/// once as a CAN alarm frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlarmOutput {
    /// The state shown.
    pub state: AlarmState,
    /// Latched leaks (kept while a higher-precedence state is shown).
    pub latched: LeakSet,
    /// Faulted input channels, `Channel::bit` mask.
    pub faulted_channels: u8,
    /// The device fault shown (`DeviceFault` wire code, 0 = none).
    pub device_fault: u8,
}

impl AlarmOutput {
    /// The output at boot, before the first sample: starting, relay off,
    /// nothing latched.
    pub const BOOT: Self = Self {
        state: AlarmState::Starting,
        latched: LeakSet::NONE,
        faulted_channels: 0,
        device_fault: 0,
    };

    /// The output for the monitor's `status`, `stalled` if the supervisor
    /// declared the estimator stalled.
    pub fn of(status: &Status, stalled: bool) -> Self {
        let state = if status.verdict == Verdict::SensorFault {
            AlarmState::SensorFault
        } else if !status.latched.is_empty() {
            AlarmState::Leak
        } else if status.health & health::WARMING_UP != 0 {
            AlarmState::Starting
        } else if status.verdict == Verdict::Inconclusive {
            AlarmState::Inconclusive
        } else {
            AlarmState::Healthy
        };
        let out = Self {
            state,
            latched: status.latched,
            faulted_channels: status.faulted_channels,
            device_fault: 0,
        };
        if stalled {
            out.stalled()
        } else {
            out
        }
    }

    /// This output once the estimator stalled: state `EstimatorStalled`
    /// (above everything), relay off, latch and faults as they were. The
    /// one rule for the stall, used by the estimator pipeline and, when
    /// the estimator no longer runs, by the supervisor (through
    /// `AlarmFrame::stalled`).
    pub const fn stalled(self) -> Self {
        Self {
            state: AlarmState::EstimatorStalled,
            ..self
        }
    }

    /// This output when the device has `faults`: state `DeviceFault`
    /// (above everything but a stall), relay off, the first fault's code
    /// shown; unchanged without a fault.
    pub fn with_device_faults(self, faults: DeviceFaults) -> Self {
        if !faults.any() {
            return self;
        }
        let state = match self.state {
            AlarmState::EstimatorStalled => AlarmState::EstimatorStalled,
            _ => AlarmState::DeviceFault,
        };
        Self {
            state,
            device_fault: faults.code(),
            ..self
        }
    }

    /// Is the fail-safe relay energised?
    pub const fn relay_energised(&self) -> bool {
        self.state.relay_energised()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::Channel;

    fn status(verdict: Verdict, latched: LeakSet, health: u16, faulted: u8) -> Status {
        let mut s = crate::testutil::status();
        s.verdict = verdict;
        s.latched = latched;
        s.health = health;
        s.faulted_channels = faulted;
        s
    }

    fn healthy() -> Status {
        status(Verdict::Healthy, LeakSet::NONE, 0, 0)
    }

    fn of(s: &Status) -> AlarmOutput {
        AlarmOutput::of(s, false)
    }

    #[test]
    fn boot_and_warm_up_keep_the_relay_off() {
        assert!(!AlarmOutput::BOOT.relay_energised());
        let warming = status(Verdict::Inconclusive, LeakSet::NONE, health::WARMING_UP, 0);
        assert_eq!(of(&warming).state, AlarmState::Starting);
        assert!(!of(&warming).relay_energised());
        let inconclusive = status(Verdict::Inconclusive, LeakSet::NONE, 0, 0);
        assert_eq!(of(&inconclusive).state, AlarmState::Inconclusive);
        assert!(!of(&inconclusive).relay_energised());
        assert_eq!(of(&healthy()).state, AlarmState::Healthy);
        assert!(of(&healthy()).relay_energised());
    }

    #[test]
    fn a_device_fault_drops_the_relay_names_the_fault_and_yields_only_to_a_stall() {
        use crate::device::diagnostics::{DeviceFault, DeviceFaults};
        assert_eq!(
            of(&healthy()).with_device_faults(DeviceFaults::NONE),
            of(&healthy())
        );
        for fault in DeviceFault::ALL {
            let mut faults = DeviceFaults::NONE;
            faults.raise(fault);
            let leak = status(
                Verdict::Internal,
                LeakSet::INTERNAL,
                health::ALARM_LATCHED,
                0,
            );
            for s in [healthy(), leak] {
                let out = of(&s).with_device_faults(faults);
                assert_eq!(out.state, AlarmState::DeviceFault, "{}", fault.name());
                assert_eq!(out.device_fault, fault.code());
                assert_eq!(out.latched, s.latched, "the latch still shows");
                assert!(!out.relay_energised());
            }
            let stalled = AlarmOutput::of(&healthy(), true).with_device_faults(faults);
            assert_eq!(stalled.state, AlarmState::EstimatorStalled);
            assert!(!stalled.relay_energised());
        }
    }

    #[test]
    fn a_latched_leak_shows_whatever_the_warm_up() {
        let s = status(Verdict::Both, LeakSet::BOTH, health::ALARM_LATCHED, 0);
        assert_eq!(of(&s).state, AlarmState::Leak);
        assert_eq!(of(&s).latched, LeakSet::BOTH);
        assert!(!of(&s).relay_energised());
        // Restarted after a data gap: warming up, the latch still shows.
        let s = status(Verdict::Internal, LeakSet::INTERNAL, health::WARMING_UP, 0);
        assert_eq!(of(&s).state, AlarmState::Leak);
    }

    #[test]
    fn a_sensor_fault_takes_precedence_and_keeps_the_latch() {
        let rod = Channel::PRod.bit();
        let s = status(
            Verdict::SensorFault,
            LeakSet::EXTERNAL,
            health::SENSOR_FAULT,
            rod,
        );
        let out = of(&s);
        assert_eq!(out.state, AlarmState::SensorFault);
        assert_eq!(out.latched, LeakSet::EXTERNAL);
        assert_eq!(out.faulted_channels, rod);
        assert!(!out.relay_energised());
    }

    #[test]
    fn a_stalled_estimator_overrides_everything() {
        let s = status(
            Verdict::Internal,
            LeakSet::INTERNAL,
            health::ALARM_LATCHED,
            0,
        );
        let out = AlarmOutput::of(&s, true);
        assert_eq!(out.state, AlarmState::EstimatorStalled);
        assert_eq!(out.latched, LeakSet::INTERNAL, "latch as it was");
        assert!(!out.relay_energised());
        assert_eq!(AlarmOutput::of(&healthy(), true), of(&healthy()).stalled());
    }

    #[test]
    fn codes_round_trip_and_unknown_codes_are_rejected() {
        for s in AlarmState::ALL {
            assert_eq!(AlarmState::from_code(s.code()), Some(s));
        }
        assert_eq!(AlarmState::from_code(7), None);
    }

    #[test]
    fn led_patterns_tell_the_states_apart() {
        let lit = |s: AlarmState| (0..1000).filter(|&t| s.led_on(t)).count();
        assert_eq!(lit(AlarmState::Healthy), 50);
        assert_eq!(lit(AlarmState::Starting), 500);
        assert_eq!(lit(AlarmState::Leak), 1000);
        assert_eq!(lit(AlarmState::SensorFault), 500);
        assert_eq!(lit(AlarmState::EstimatorStalled), 0);
        assert!(AlarmState::SensorFault.led_on(0) && !AlarmState::SensorFault.led_on(150));
    }
}
