//! The alarm output: what the fail-safe relay, the status LED and the CAN
//! alarm frame show, derived from the monitor's [`Status`] each sample.
//!
//! The relay is **energised only when healthy**: at boot, during the
//! filters' warm-up, on a latched leak alarm, on a sensor fault and after
//! the estimator stalled it is de-energised (and a dead board, a reset or
//! a missing supply de-energise it too). Precedence, highest first:
//! estimator stalled > sensor fault > latched leak > starting >
//! inconclusive > healthy. `Inconclusive` keeps the relay off like the
//! warm-up: the relay's "healthy" is a claim backed by evidence.
//!
//! Leak alarms latch here as well as in the monitor: once raised, the leak
//! kind stays latched — through sensor faults and filter restarts — until
//! an operator acknowledges it ([`AlarmLogic::acknowledge`], the CAN
//! command frame), which also clears the monitor's latch. If the leak is
//! still there, the monitor raises it again after its debounce time.

use crate::monitor::Monitor;
use crate::real::Real;
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
}

impl AlarmState {
    /// Every state, in wire-code order.
    pub const ALL: [AlarmState; 6] = [
        Self::Starting,
        Self::Healthy,
        Self::Leak,
        Self::SensorFault,
        Self::EstimatorStalled,
        Self::Inconclusive,
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
            Self::SensorFault => t_ms % 200 < 100,
            Self::EstimatorStalled => false,
        }
    }
}

/// Which leaks are latched.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LeakKind {
    /// No leak latched.
    #[default]
    None = 0,
    /// Leak across the piston seal.
    Internal = 1,
    /// Leak from the rod-side line to tank.
    External = 2,
    /// Both.
    Both = 3,
}

impl LeakKind {
    /// Every kind, in wire-code order.
    pub const ALL: [LeakKind; 4] = [Self::None, Self::Internal, Self::External, Self::Both];

    /// Wire code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The kind of a wire code, if valid.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Internal => "internal",
            Self::External => "external",
            Self::Both => "both",
        }
    }

    /// The leak part of a verdict (`None` for healthy and sensor fault).
    pub const fn of_verdict(v: Verdict) -> Self {
        match v {
            Verdict::Internal => Self::Internal,
            Verdict::External => Self::External,
            Verdict::Both => Self::Both,
            Verdict::Healthy | Verdict::SensorFault | Verdict::Inconclusive => Self::None,
        }
    }

    /// Both leaks of `self` and `other`.
    pub const fn union(self, other: Self) -> Self {
        match (self.code() | other.code()) & 3 {
            1 => Self::Internal,
            2 => Self::External,
            3 => Self::Both,
            _ => Self::None,
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
    pub latched: LeakKind,
    /// Faulted input channels, `Channel::bit` mask.
    pub faulted_channels: u8,
}

impl AlarmOutput {
    /// Is the fail-safe relay energised?
    pub const fn relay_energised(&self) -> bool {
        self.state.relay_energised()
    }
}

/// The alarm and relay state machine.
#[derive(Clone, Debug)]
pub struct AlarmLogic {
    out: AlarmOutput,
    stalled: bool,
    changed_at_ms: u32,
}

impl Default for AlarmLogic {
    fn default() -> Self {
        Self::new()
    }
}

impl AlarmLogic {
    /// The state at boot: starting, relay off, nothing latched.
    pub const fn new() -> Self {
        Self {
            out: AlarmOutput {
                state: AlarmState::Starting,
                latched: LeakKind::None,
                faulted_channels: 0,
            },
            stalled: false,
            changed_at_ms: 0,
        }
    }

    /// What the output shows now.
    pub const fn output(&self) -> AlarmOutput {
        self.out
    }

    /// Time of the last change, ms on the sample clock.
    pub const fn changed_at_ms(&self) -> u32 {
        self.changed_at_ms
    }

    /// Take the monitor's status of the sample at `t_ms` (ms on the sample
    /// clock).
    /// Returns true when the output changed (send the alarm frame now).
    pub fn update(&mut self, status: &Status, t_ms: u32) -> bool {
        let latched = self.out.latched.union(LeakKind::of_verdict(status.verdict));
        let state = if self.stalled {
            AlarmState::EstimatorStalled
        } else if status.verdict == Verdict::SensorFault {
            AlarmState::SensorFault
        } else if latched != LeakKind::None {
            AlarmState::Leak
        } else if status.health & health::WARMING_UP != 0 {
            AlarmState::Starting
        } else if status.verdict == Verdict::Inconclusive {
            AlarmState::Inconclusive
        } else {
            AlarmState::Healthy
        };
        self.set(
            AlarmOutput {
                state,
                latched,
                faulted_channels: status.faulted_channels,
            },
            t_ms,
        )
    }

    /// Operator acknowledgement: clears the latched leak here and in the
    /// monitor's decision (which raises it again if the evidence still
    /// holds for the debounce time). Returns true when one was latched.
    /// The shown state follows at the next [`update`](Self::update).
    pub fn acknowledge<T: Real>(&mut self, monitor: &mut Monitor<T>) -> bool {
        monitor.clear_alarm();
        let was = self.out.latched != LeakKind::None;
        self.out.latched = LeakKind::None;
        was
    }

    /// The estimator stopped keeping its deadline (seen by the
    /// supervisor): relay off until reset. Returns true on the change.
    pub fn estimator_stalled(&mut self, t_ms: u32) -> bool {
        self.stalled = true;
        self.set(
            AlarmOutput {
                state: AlarmState::EstimatorStalled,
                ..self.out
            },
            t_ms,
        )
    }

    fn set(&mut self, out: AlarmOutput, t_ms: u32) -> bool {
        let changed = out != self.out;
        if changed {
            self.out = out;
            self.changed_at_ms = t_ms;
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::Channel;

    fn status(verdict: Verdict, health: u16, faulted: u8) -> Status {
        let mut s = crate::testutil::status();
        s.verdict = verdict;
        s.health = health;
        s.faulted_channels = faulted;
        s
    }

    /// A monitor whose latch the acknowledgement clears too.
    fn monitor() -> Monitor<f32> {
        Monitor::new(&crate::params::Params::nominal()).unwrap()
    }

    fn healthy() -> Status {
        status(Verdict::Healthy, 0, 0)
    }

    #[test]
    fn boot_and_warm_up_keep_the_relay_off() {
        let mut a = AlarmLogic::new();
        assert_eq!(a.output().state, AlarmState::Starting);
        assert!(!a.output().relay_energised());
        assert!(!a.update(&status(Verdict::Healthy, health::WARMING_UP, 0), 1));
        assert!(!a.output().relay_energised());
        assert!(a.update(&healthy(), 10_000));
        assert_eq!(a.output().state, AlarmState::Healthy);
        assert!(a.output().relay_energised());
        assert_eq!(a.changed_at_ms(), 10_000);
        assert!(!a.update(&healthy(), 10_001), "no change, no frame");
    }

    #[test]
    fn a_leak_raises_and_latches_until_acknowledged() {
        let mut a = AlarmLogic::new();
        a.update(&healthy(), 0);
        assert!(a.update(&status(Verdict::Internal, health::ALARM_LATCHED, 0), 5));
        assert_eq!(a.output().state, AlarmState::Leak);
        assert_eq!(a.output().latched, LeakKind::Internal);
        assert!(!a.output().relay_energised());
        // The monitor's verdict goes back to healthy (e.g. restarted
        // after a data gap): the output stays latched.
        assert!(!a.update(&healthy(), 6));
        assert_eq!(a.output().state, AlarmState::Leak);
        // A second leak escalates.
        assert!(a.update(&status(Verdict::External, health::ALARM_LATCHED, 0), 7));
        assert_eq!(a.output().latched, LeakKind::Both);
        // Acknowledge: cleared, relay back on at the next healthy sample.
        assert!(a.acknowledge(&mut monitor()));
        assert!(
            !a.acknowledge(&mut monitor()),
            "nothing left to acknowledge"
        );
        assert!(a.update(&healthy(), 8));
        assert_eq!(a.output().state, AlarmState::Healthy);
        assert!(a.output().relay_energised());
    }

    #[test]
    fn an_acknowledged_leak_that_persists_is_raised_again() {
        let mut a = AlarmLogic::new();
        a.update(&status(Verdict::Both, health::ALARM_LATCHED, 0), 0);
        assert!(a.acknowledge(&mut monitor()));
        // The monitor still reports the leak (it re-raised it): latched again.
        a.update(&status(Verdict::Both, health::ALARM_LATCHED, 0), 1);
        assert_eq!(a.output().state, AlarmState::Leak);
        assert_eq!(a.output().latched, LeakKind::Both);
    }

    #[test]
    fn a_sensor_fault_takes_precedence_and_keeps_the_latch() {
        let mut a = AlarmLogic::new();
        a.update(&status(Verdict::External, health::ALARM_LATCHED, 0), 0);
        let rod = Channel::PRod.bit();
        assert!(a.update(&status(Verdict::SensorFault, health::SENSOR_FAULT, rod), 1));
        assert_eq!(a.output().state, AlarmState::SensorFault);
        assert_eq!(a.output().latched, LeakKind::External);
        assert_eq!(a.output().faulted_channels, rod);
        assert!(!a.output().relay_energised());
        // Sensor back, filters warming up: the latched leak shows again.
        assert!(a.update(&status(Verdict::External, health::WARMING_UP, 0), 2));
        assert_eq!(a.output().state, AlarmState::Leak);
        // Without a latched leak a sensor fault de-energises too, and
        // recovery goes through warm-up before the relay comes back.
        let mut b = AlarmLogic::new();
        b.update(&healthy(), 0);
        b.update(&status(Verdict::SensorFault, health::SENSOR_FAULT, rod), 1);
        assert!(!b.output().relay_energised());
        b.update(&status(Verdict::Healthy, health::WARMING_UP, 0), 2);
        assert_eq!(b.output().state, AlarmState::Starting);
        assert!(!b.output().relay_energised());
        b.update(&healthy(), 3);
        assert!(b.output().relay_energised());
    }

    #[test]
    fn a_stalled_estimator_overrides_everything_for_good() {
        let mut a = AlarmLogic::new();
        a.update(&status(Verdict::Internal, health::ALARM_LATCHED, 0), 0);
        assert!(a.estimator_stalled(3));
        assert_eq!(a.output().state, AlarmState::EstimatorStalled);
        assert!(!a.output().relay_energised());
        a.update(&healthy(), 4);
        assert_eq!(a.output().state, AlarmState::EstimatorStalled);
        assert!(!a.estimator_stalled(5), "already stalled: no new frame");
    }

    #[test]
    fn codes_round_trip_and_unknown_codes_are_rejected() {
        for s in AlarmState::ALL {
            assert_eq!(AlarmState::from_code(s.code()), Some(s));
        }
        assert_eq!(AlarmState::from_code(6), None);
        for k in LeakKind::ALL {
            assert_eq!(LeakKind::from_code(k.code()), Some(k));
        }
        assert_eq!(LeakKind::from_code(4), None);
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
