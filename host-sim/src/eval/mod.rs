//! `host-sim eval`: the monitor on the independent test plant (crate
//! `plant`, which shares no model code with the monitor), over a matrix of
//! rigs × supply pressures × oil temperatures, each cell calibrated from its
//! own healthy recording; scored against the product's targets, separately
//! for the development rigs and the held-out rigs.
//!
//! - [`sets`]: the rig sets (`--set`) and what is said about each.
//! - [`plan`]: the matrix (cells, runs, seeds) — no simulation.
//! - [`exec`]: simulation (or the cache), calibration per cell, replay of
//!   every run through the monitor, on worker threads.
//! - [`score`]: what each run should have given and whether it did.
//! - [`report`]: the Markdown report.
//!
//! Every run is simulated to the text of a recording (the format of
//! `recording-csv.md`, written by [`crate::recording::RecordingWriter`]) and
//! the monitor reads that text back, so a run replayed from the cache gives
//! bit for bit the result of a freshly simulated one. The reader here is
//! lenient where the file reader is strict: a NaN or repeated time stamp
//! (the time faults) reaches the monitor as it is.

pub mod exec;
pub mod plan;
pub mod report;
pub mod score;
pub mod sets;

use serde::{Deserialize, Serialize};

pub use exec::{run_plan, CalibrationOutcome, CellResult, Evaluation, ExecConfig, RunResult};
pub use plan::{plan, Plan, PlanConfig};
pub use sets::{RigSet, SetChoice, SurveyNo, DEV_RIGS, HOLDOUT_RIGS, WIDE_RIGS};

/// One rig at one operating condition: calibrated once, then every run of
/// the cell uses that calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// The set the rig belongs to.
    pub set: RigSet,
    /// Plant seed of the rig.
    pub rig: u64,
    /// Supply pressure, bar.
    pub supply_bar: f64,
    /// Oil temperature, °C.
    pub temp_c: f64,
    /// The recordings have the `temp_oil` column (rigs with an even seed).
    pub temp_column: bool,
}

impl Cell {
    /// A short unique name, e.g. `dev/rig3/50bar/25C`.
    pub fn id(&self) -> String {
        format!(
            "{}/rig{}/{}bar/{}C",
            self.set.name(),
            self.rig,
            self.supply_bar,
            self.temp_c
        )
    }

    /// The rig at this condition (deterministic).
    pub fn rig_spec(&self) -> plant::RigSpec {
        plant::RigSpec::random(self.rig, self.supply_bar, self.temp_c)
    }
}

/// What a run tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Category {
    /// The healthy recording a cell is calibrated from (not scored).
    Calibration,
    /// Healthy, position control through a work cycle.
    HealthyClosedLoop,
    /// Healthy, a long hold between moves.
    HealthyLongHold,
    /// Healthy, an open-loop valve step test.
    HealthyStep,
    /// A leak in closed loop (mid-run onset or from the start).
    Leak,
    /// A leak starting as the moves resume after a long hold.
    LeakAfterHold,
    /// An open-loop valve step test with a leak from the start.
    StepLeak,
    /// A fault of the measurement chain on a healthy plant.
    Fault,
}

impl Category {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Calibration => "calibration",
            Self::HealthyClosedLoop => "healthy_closed_loop",
            Self::HealthyLongHold => "healthy_long_hold",
            Self::HealthyStep => "healthy_step",
            Self::Leak => "leak",
            Self::LeakAfterHold => "leak_after_hold",
            Self::StepLeak => "step_leak",
            Self::Fault => "fault",
        }
    }

    /// A healthy plant with healthy sensors: no alarm, verdict `healthy`.
    pub fn is_healthy(self) -> bool {
        matches!(
            self,
            Self::HealthyClosedLoop | Self::HealthyLongHold | Self::HealthyStep
        )
    }
}

/// The faults of the matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// Position spikes, about 1.5 per second.
    SpikesXPiston,
    /// Open wire on the piston-chamber pressure loop.
    OpenWirePPiston,
    /// Open wire on the position loop.
    OpenWireXPiston,
    /// Open wire on the valve command (reads 0).
    OpenWireUValve,
    /// Frozen position reading, from mid-move.
    FrozenXPiston,
    /// Frozen rod-chamber pressure reading, from mid-move.
    FrozenPRod,
    /// The time stamp stops for 2 s.
    StuckTime,
    /// NaN time stamps.
    NanTime,
    /// Random noise on every channel (not a machine).
    RandomNoise,
}

impl FaultKind {
    /// All of them, in report order.
    pub const ALL: [FaultKind; 9] = [
        Self::SpikesXPiston,
        Self::OpenWirePPiston,
        Self::OpenWireXPiston,
        Self::OpenWireUValve,
        Self::FrozenXPiston,
        Self::FrozenPRod,
        Self::StuckTime,
        Self::NanTime,
        Self::RandomNoise,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::SpikesXPiston => "spikes x_piston",
            Self::OpenWirePPiston => "open wire p_piston",
            Self::OpenWireXPiston => "open wire x_piston",
            Self::OpenWireUValve => "open wire u_valve",
            Self::FrozenXPiston => "frozen x_piston",
            Self::FrozenPRod => "frozen p_rod",
            Self::StuckTime => "stuck time",
            Self::NanTime => "NaN time",
            Self::RandomNoise => "random noise",
        }
    }

    /// The monitor must say `sensor_fault` (a channel it can name as
    /// untrustworthy); otherwise `inconclusive` or `sensor_fault` will do.
    pub fn expects_sensor_fault(self) -> bool {
        !matches!(self, Self::StuckTime | Self::NanTime | Self::RandomNoise)
    }

    /// Frozen faults start mid-move (placed from the healthy twin's truth).
    pub fn mid_move(self) -> bool {
        matches!(self, Self::FrozenXPiston | Self::FrozenPRod)
    }
}

/// One run of the matrix: everything [`plant::Run`] needs but the rig
/// (drawn from the cell when the run executes), plus what it tests.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Unique name, e.g. `dev/rig3/50bar/25C/internal-0.30-on30`.
    pub id: String,
    /// The rig and condition.
    pub cell: Cell,
    /// What the run tests.
    pub category: Category,
    /// Which fault (category `fault`).
    pub fault: Option<FaultKind>,
    /// What the machine does.
    pub scenario: plant::Scenario,
    /// Leaks.
    pub leak: plant::Leak,
    /// Faults of the measurement chain.
    pub faults: Vec<plant::Fault>,
    /// Seed of the run's noise.
    pub noise_seed: u64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// How a time of the run was placed from its healthy twin's truth
    /// (leak after a hold, frozen mid-move), once placed.
    pub placed: Option<String>,
}

impl RunSpec {
    /// The plant run (draws the rig from its seed).
    pub fn run(&self) -> plant::Run {
        plant::Run {
            rig: self.cell.rig_spec(),
            scenario: self.scenario,
            leak: self.leak,
            faults: self.faults.clone(),
            temp_column: self.cell.temp_column,
            sample_rate_hz: self.sample_rate_hz,
            noise_seed: self.noise_seed,
        }
    }

    /// Has an internal leak.
    pub fn internal(&self) -> bool {
        self.leak.internal_lpm > 0.0
    }

    /// Has an external leak.
    pub fn external(&self) -> bool {
        self.leak.external_lpm > 0.0
    }

    /// Has any leak.
    pub fn has_leak(&self) -> bool {
        self.internal() || self.external()
    }

    /// The verdict naming exactly the run's leaks (`healthy` without).
    pub fn leak_kind(&self) -> &'static str {
        monitor::Verdict::from_leaks(self.internal(), self.external()).name()
    }

    /// Nominal size of the (each) leak, l/min.
    pub fn leak_size_lpm(&self) -> f64 {
        self.leak.internal_lpm.max(self.leak.external_lpm)
    }

    /// Planned length, s: the scheduling cost (a leak costs the plant a
    /// second calibration pass).
    pub fn planned_s(&self) -> f64 {
        let passes = if self.has_leak() { 2.0 } else { 1.0 };
        passes * plant::planned_duration_s(&self.scenario)
    }
}

/// A time of a follower run placed from its twin's truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Placement {
    /// The leak starts `hold_s` after the twin's longest hold began, i.e.
    /// after that long holding (`fallback_s` if the twin shows no hold).
    OnsetAfterHold {
        /// Length of the hold, s.
        hold_s: f64,
        /// Onset if the twin shows no hold, s.
        fallback_s: f64,
    },
    /// The run's fault starts at the twin's first mid-move instant at or
    /// after `after_s`.
    FaultMidMove {
        /// Earliest time, s.
        after_s: f64,
    },
}

/// A run whose timing depends on its twin (the job's head: same scenario
/// and noise seeds, healthy).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Follower {
    /// The run, its placed time still a placeholder.
    pub spec: RunSpec,
    /// How to place it.
    pub placement: Placement,
}

/// Runs executed in order on one worker: a head and the runs placed from
/// its truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// The first run.
    pub head: RunSpec,
    /// Runs placed from the head's truth.
    pub followers: Vec<Follower>,
}

impl Job {
    /// A job of one run.
    pub fn single(spec: RunSpec) -> Self {
        Self {
            head: spec,
            followers: Vec::new(),
        }
    }

    /// Every run's spec (followers unplaced).
    pub fn specs(&self) -> impl Iterator<Item = &RunSpec> {
        std::iter::once(&self.head).chain(self.followers.iter().map(|f| &f.spec))
    }

    /// Scheduling cost, simulated seconds.
    pub fn cost(&self) -> f64 {
        self.specs().map(RunSpec::planned_s).sum()
    }
}

/// FNV-1a, 64 bit: a hash that is the same on every platform and Rust
/// version (cache keys, seeds).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// A seed derived from a description of what it is for, so that a run's
/// seeds depend on the run, not on its position in the matrix.
pub fn seed_of(what: &str) -> u64 {
    // FNV mixes a string's last bytes poorly into the high bits: finish
    // with SplitMix64's mixer. Keep seeds below 2^53 so they survive JSON
    // readers that use doubles.
    let mut z = fnv1a64(what.as_bytes());
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    (z ^ (z >> 31)) >> 11
}
