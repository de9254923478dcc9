//! What the monitor reports after each sample.

use crate::hypothesis::Hypothesis;
use crate::leak::LeakSet;
use crate::sample::Channel;

/// The monitor's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Verdict {
    /// No leak alarm.
    Healthy = 0,
    /// Leak across the piston seal (piston chamber → rod chamber).
    Internal = 1,
    /// Leak from the rod-side line to tank.
    External = 2,
    /// Both leaks.
    Both = 3,
    /// A measurement the monitor cannot trust: no leak verdict possible.
    SensorFault = 4,
    /// Not enough valid evidence to say `Healthy` or name a leak: warming
    /// up, time not advancing, filters resetting, the model not fitting
    /// the data, or too little quasi-steady operation for too long.
    /// `Healthy` is a claim backed by evidence; this is its absence.
    Inconclusive = 5,
}

impl Verdict {
    /// Lower-case name, as in the replay JSON.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Healthy => "healthy",
            Self::Internal => "internal",
            Self::External => "external",
            Self::Both => "both",
            Self::SensorFault => "sensor_fault",
            Self::Inconclusive => "inconclusive",
        }
    }

    /// The leak verdict for an internal and/or an external leak.
    pub const fn from_leaks(internal: bool, external: bool) -> Self {
        Self::of_leaks(LeakSet::of(internal, external))
    }

    /// The verdict naming `leaks` (`Healthy` for none).
    pub const fn of_leaks(leaks: LeakSet) -> Self {
        // The codes agree (`LeakSet::code` is 0..=3): an identity map.
        match leaks.code() & 3 {
            0 => Self::Healthy,
            1 => Self::Internal,
            2 => Self::External,
            _ => Self::Both,
        }
    }

    /// The leaks this verdict names (none for healthy, sensor fault and
    /// inconclusive).
    pub const fn leaks(self) -> LeakSet {
        match self {
            Self::Internal => LeakSet::INTERNAL,
            Self::External => LeakSet::EXTERNAL,
            Self::Both => LeakSet::BOTH,
            Self::Healthy | Self::SensorFault | Self::Inconclusive => LeakSet::NONE,
        }
    }

    /// Is this a leak alarm?
    pub const fn is_leak(self) -> bool {
        !self.leaks().is_empty()
    }
}

/// Evidence for one hypothesis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Evidence {
    /// Posterior probability among the four hypotheses.
    pub probability: f32,
    /// Windowed log-likelihood (forgetting over the evidence window).
    pub log_likelihood: f32,
    /// Windowed mean normalised innovation squared (≈ 3 when the filter's
    /// model fits the data).
    pub mean_nis: f32,
}

/// Health flags (bit mask in [`Status::health`]).
pub mod health {
    /// Filters started or restarted less than the warm-up time ago.
    pub const WARMING_UP: u16 = 1 << 0;
    /// This sample did not count as evidence (transient, fault, warm-up, a
    /// valve gain the model cannot describe).
    pub const EVIDENCE_PAUSED: u16 = 1 << 1;
    /// A gap in the sample times re-initialised the filters.
    pub const DATA_GAP: u16 = 1 << 2;
    /// A filter failed numerically this sample and was restarted.
    pub const FILTER_RESET: u16 = 1 << 3;
    /// At least one input channel is faulted.
    pub const SENSOR_FAULT: u16 = 1 << 4;
    /// A leak above the warning level is estimated.
    pub const LEAK_WARNING: u16 = 1 << 5;
    /// A leak alarm is latched (cleared only by acknowledgement).
    pub const ALARM_LATCHED: u16 = 1 << 6;
    /// Even the best hypothesis fits the data poorly, or a leak reading
    /// stands above its alarm level while the model probabilities do not
    /// support that leak (model mismatch: the verdict is `inconclusive`;
    /// recalibrate if it persists).
    pub const MODEL_MISMATCH: u16 = 1 << 7;
    /// The sample time did not increase: sample ignored.
    pub const TIME_NOT_INCREASING: u16 = 1 << 8;
    /// The monitor has not evaluated enough valid evidence to claim
    /// healthy (the verdict is `Inconclusive` unless a leak is latched or
    /// a sensor is faulted).
    pub const INCONCLUSIVE: u16 = 1 << 9;
    /// A reading was rejected as an outlier at this sample (a spike, or a
    /// valve command the motion contradicts): it was not used.
    pub const OUTLIER: u16 = 1 << 10;
    /// An acknowledge was accepted and its evidence period runs: the
    /// verdict is `inconclusive` (relay off) instead of `healthy` until the
    /// monitor has concluded healthy for `acknowledge::EVIDENCE_MS`.
    pub const ACK_EVIDENCE: u16 = 1 << 11;
    /// The parameter set is provisional, not calibrated for this
    /// installation: never `healthy`, and only gross leaks alarm
    /// (`baseline.provisional_floor_lpm`).
    pub const PROVISIONAL: u16 = 1 << 12;
    /// The machine's position loop hunts: most of the last 2 s the valve
    /// command and the chamber pressures oscillated together
    /// (`signal::oscillation`). Such samples count for nothing, neither
    /// leak nor health, like a filter reset's; a loop that keeps hunting
    /// leaves too little recent evidence and the verdict turns
    /// `inconclusive` (after a minute or more of it with the default
    /// `evidence_memory_s` of 30 s). Stabilise the loop.
    pub const LOOP_OSCILLATING: u16 = 1 << 13;
    /// The `both` filter held valve flow gains the valve model does not
    /// describe (more than `decision::VALVE_GAIN_MISFIT` off the
    /// installation's, root sum of squares, before they were learned
    /// within it): the sample was no evidence (`EVIDENCE_PAUSED` is set
    /// too). Persistent: recalibrate, or check the valve.
    pub const VALVE_MISFIT: u16 = 1 << 14;
    /// At quiet holds the loop holds the piston with a valve command
    /// beyond `baseline.hold_command_tolerance` of the leak-free
    /// installation's (`baseline.hold_command`) for more than
    /// `decision::HOLD_SHIFT_S` of evidence: some flow the installation
    /// did not have is fed through the valve — a leak the filters may not
    /// name, or a valve whose null moved. Never `healthy` while it lasts
    /// (the verdict is `inconclusive` unless a leak is latched). Beyond
    /// `decision::HOLD_ALARM_TOLERANCES` for `decision::HOLD_ALARM_S` of
    /// evidence, in the direction one leak calls for (into the rod chamber:
    /// external; into the piston chamber standing at the higher pressure:
    /// internal) and with the filters reading that leak at its warning
    /// level, that leak is raised.
    pub const HOLD_COMMAND_SHIFTED: u16 = 1 << 15;

    /// Every flag above with its name (as the CAN decoder and logs show
    /// it), in bit order. A new flag goes here too.
    pub const NAMES: [(u16, &str); 16] = [
        (WARMING_UP, "WARMING_UP"),
        (EVIDENCE_PAUSED, "EVIDENCE_PAUSED"),
        (DATA_GAP, "DATA_GAP"),
        (FILTER_RESET, "FILTER_RESET"),
        (SENSOR_FAULT, "SENSOR_FAULT"),
        (LEAK_WARNING, "LEAK_WARNING"),
        (ALARM_LATCHED, "ALARM_LATCHED"),
        (MODEL_MISMATCH, "MODEL_MISMATCH"),
        (TIME_NOT_INCREASING, "TIME_NOT_INCREASING"),
        (INCONCLUSIVE, "INCONCLUSIVE"),
        (OUTLIER, "OUTLIER"),
        (ACK_EVIDENCE, "ACK_EVIDENCE"),
        (PROVISIONAL, "PROVISIONAL"),
        (LOOP_OSCILLATING, "LOOP_OSCILLATING"),
        (VALVE_MISFIT, "VALVE_MISFIT"),
        (HOLD_COMMAND_SHIFTED, "HOLD_COMMAND_SHIFTED"),
    ];
}

/// Something that happened at this sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// A leak alarm was raised (or escalated) with this verdict.
    AlarmRaised(Verdict),
    /// The latched alarm was cleared by acknowledgement.
    AlarmCleared,
    /// A channel became untrustworthy.
    SensorFault(Channel),
    /// A channel recovered.
    SensorRecovered(Channel),
    /// The sample times jumped by more than 5 periods.
    DataGap,
    /// A filter failed numerically and was restarted.
    FilterReset(Hypothesis),
}

/// Events of one sample (at most a handful).
pub type Events = heapless::Vec<Event, 8>;

/// The monitor's output for one sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    /// Sample time, s.
    pub t_s: f64,
    /// Verdict: the latched alarm, a sensor fault of a required channel
    /// (which takes precedence), or healthy. A fault of the optional oil
    /// temperature sensor is reported in `faulted_channels`, `health` and
    /// the events, but leaves the verdict to the estimation.
    pub verdict: Verdict,
    /// The leak alarms latched until acknowledged. Shown in the verdict
    /// unless a required sensor is faulted; kept through the fault.
    pub latched: LeakSet,
    /// The best-supported hypothesis right now, before debounce and latching.
    pub leading: Hypothesis,
    /// Estimated internal leak flow, l/min, averaged over the evidence
    /// window; `None` while no estimate is possible.
    pub leak_internal_lpm: Option<f32>,
    /// Estimated external leak flow, l/min (as above).
    pub leak_external_lpm: Option<f32>,
    /// 1σ uncertainty of the internal leak flow, l/min.
    pub leak_internal_sd_lpm: Option<f32>,
    /// 1σ uncertainty of the external leak flow, l/min.
    pub leak_external_sd_lpm: Option<f32>,
    /// Internal leak flow averaged over the (short) detection window, l/min.
    pub detect_internal_lpm: Option<f32>,
    /// External leak flow averaged over the detection window, l/min.
    pub detect_external_lpm: Option<f32>,
    /// Alarm level in use for the internal and external leak, l/min: the
    /// level the leak flow estimate, after the healthy baseline and less
    /// 2σ, must stay above for the debounce time to raise an alarm at this
    /// sample: the user's `alarm.alarm_lpm` raised to the installation's
    /// detection floor in the current operating region
    /// (`baseline.region_floor_*`, `detection_floor_lpm`, a provisional
    /// set's `provisional_floor_lpm`). A `Healthy` verdict says no leak
    /// *estimate* above it; on an installation the model describes poorly
    /// the estimates run low (docs/evaluation.md), so a leak a little above
    /// it can still go unseen. After a region with a higher floor it falls
    /// with a 0.5 s time constant.
    pub alarm_level_lpm: [f32; 2],
    /// Estimated valve flow-gain deviations from the parameters for the
    /// extend and retract directions, relative (0.05: the valve passes 5 %
    /// more than parameterised). A maintenance indicator, and a hint to
    /// recalibrate when large.
    pub valve_gain_deviation: [f32; 2],
    /// How much this sample counts as leak evidence, 0..1: 1 when the plant
    /// is quasi-steady, near 0 during transients and fast moves.
    pub evidence_weight: f32,
    /// Evidence per hypothesis, in `Hypothesis::ALL` order.
    pub evidence: [Evidence; 4],
    /// Faulted channels, one bit per `Channel` (`Channel::bit`).
    pub faulted_channels: u8,
    /// Health flags (`health::*`).
    pub health: u16,
    /// White-noise σ of the position (m), piston- and rod-chamber
    /// pressure (bar) readings as estimated from the data
    /// (`signal::noise`); the filters' measurement noise follows them.
    pub noise_sigma: [f32; 3],
    /// Events at this sample.
    pub events: Events,
}

/// Valve flow-gain deviation (relative; root sum of squares of the two
/// directions') beyond which the valve model does not describe the
/// installation ([`Status::valve_model_misfit`]).
pub use crate::decision::VALVE_GAIN_MISFIT;

/// Evidence weight below which a sample is no evidence
/// ([`Status::quasi_steady`]).
pub use crate::decision::PAUSED_WEIGHT;

/// Is a sample in an operating region with an evidence weight a quiet
/// hold, where the holding command is judged?
pub use crate::decision::quiet_hold;

impl Status {
    /// The valve flow-gain deviations were beyond what the valve model
    /// describes ([`VALVE_GAIN_MISFIT`]) and the decision counted the
    /// sample as no evidence for it, neither of a leak nor of health
    /// (`health::VALVE_MISFIT`). A gain that bent that far after it had
    /// been learned within the limit is a change such as a leak's onset,
    /// not a valve the model never described, and stays evidence (see
    /// `decision`): this is the decision's own judgement, not the gains'.
    pub fn valve_model_misfit(&self) -> bool {
        self.health & health::VALVE_MISFIT != 0
    }

    /// The loop holds the piston with a command away from the leak-free
    /// installation's (`health::HOLD_COMMAND_SHIFTED`): `healthy` is
    /// withheld.
    pub fn hold_command_shifted(&self) -> bool {
        self.health & health::HOLD_COMMAND_SHIFTED != 0
    }

    /// The alarm levels in use (internal, external), each with the leak
    /// estimate it applies to: `None` where the monitor has none (warming
    /// up, a sensor fault), as the CAN frame and the replay publish them.
    pub fn published_alarm_levels(&self) -> [Option<f32>; 2] {
        let [internal, external] = self.alarm_level_lpm;
        [
            self.leak_internal_lpm.map(|_| internal),
            self.leak_external_lpm.map(|_| external),
        ]
    }

    /// The plant was quasi-steady enough at this sample for it to count as
    /// evidence ([`PAUSED_WEIGHT`]); whether the valve model fitted there
    /// is [`valve_model_misfit`](Self::valve_model_misfit)'s question.
    pub fn quasi_steady(&self) -> bool {
        f64::from(self.evidence_weight) >= PAUSED_WEIGHT
    }
}

#[cfg(test)]
mod tests {
    use super::health;

    #[test]
    fn every_health_flag_has_a_name_in_bit_order() {
        for (bit, (mask, name)) in health::NAMES.iter().enumerate() {
            assert_eq!(*mask, 1 << bit, "{name}");
        }
    }
}
