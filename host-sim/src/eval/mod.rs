//! `host-sim eval`: the monitor on the independent test plant (crate
//! `plant`, which shares no model code with the monitor), over a matrix of
//! rigs × supply pressures × oil temperatures, each cell calibrated from its
//! own healthy recording; scored against the product's targets, separately
//! for the development rigs and the held-out rigs.
//!
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

use serde::{Deserialize, Serialize};

pub use exec::{run_plan, CalibrationOutcome, CellResult, Evaluation, ExecConfig, RunResult};
pub use plan::{plan, Plan, PlanConfig};

/// Development rigs: the plant seeds the monitor may be looked at and tuned
/// on. Fixed before any tuning on the plant; never change them.
pub const DEV_RIGS: [u64; 6] = [1, 2, 3, 4, 5, 6];

/// Held-out rigs: plant seeds fixed in advance, before any tuning, and never
/// looked at while tuning (run `--set holdout` only to report). Disjoint
/// from [`DEV_RIGS`]; never change them.
pub const HOLDOUT_RIGS: [u64; 12] = [
    1001, 1002, 1003, 1004, 1005, 1006, 1007, 1008, 1009, 1010, 1011, 1012,
];

/// Further development rigs: more of the population the development rigs
/// come from, to find failures on (tuned on like them; reported
/// separately so that the fixed sets' figures stay comparable). Disjoint
/// from [`DEV_RIGS`] and [`HOLDOUT_RIGS`].
pub const WIDE_RIGS: [u64; 24] = [
    7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30,
];

/// Survey rigs: a larger sample of the same population (seeds 31–78),
/// to look for rare failures with `--quick` (tuned on like the other
/// development rigs; reported separately). Disjoint from the other sets.
pub const SURVEY_RIGS: [u64; 48] = consecutive(31);

/// Second survey rigs (seeds 79–126): drawn from the same population and
/// first run, untuned, on 2026-12-05 to check whether the held-out rigs'
/// false-alarm rate is chance or a mechanism the other development rigs
/// never showed; from then on tuned on like them (reported separately).
/// Disjoint from the other sets.
pub const SURVEY2_RIGS: [u64; 48] = consecutive(79);

/// Third survey rigs (seeds 127–174): set aside on 2026-12-05 and first
/// run, untuned, in the next session, before anything in it was looked
/// at, to measure again on rigs nobody tuned on; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY3_RIGS: [u64; 48] = consecutive(127);

/// Fourth survey rigs (seeds 175–222): set aside at the end of the eighth
/// session of 2026-12-05 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY4_RIGS: [u64; 48] = consecutive(175);

/// Fifth survey rigs (seeds 223–270): set aside at the end of the ninth
/// session of 2026-12-05 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY5_RIGS: [u64; 48] = consecutive(223);

/// Sixth survey rigs (seeds 271–318): set aside at the end of the first
/// session of 2026-12-06 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY6_RIGS: [u64; 48] = consecutive(271);

/// Seventh survey rigs (seeds 319–366): set aside at the end of the
/// second session of 2026-12-06 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY7_RIGS: [u64; 48] = consecutive(319);

/// Eighth survey rigs (seeds 367–414): set aside at the end of the third
/// session of 2026-12-06 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY8_RIGS: [u64; 48] = consecutive(367);

/// Ninth survey rigs (seeds 415–462): set aside at the end of the fourth
/// session of 2026-12-06 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY9_RIGS: [u64; 48] = consecutive(415);

/// Tenth survey rigs (seeds 463–510): set aside at the end of the fifth
/// session of 2026-12-06 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY10_RIGS: [u64; 48] = consecutive(463);

/// Eleventh survey rigs (seeds 511–558): set aside at the end of the sixth
/// session of 2026-12-06 and first run, untuned, at the start of the
/// next, before anything in it was looked at; from then on tuned on like
/// the others (reported separately). Disjoint from the other sets.
pub const SURVEY11_RIGS: [u64; 48] = consecutive(511);

/// Twelfth survey rigs (seeds 559–606): set aside at the end of the
/// seventh session of 2026-12-06 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY12_RIGS: [u64; 48] = consecutive(559);

/// Thirteenth survey rigs (seeds 607–654): set aside at the end of the
/// eighth session of 2026-12-06 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY13_RIGS: [u64; 48] = consecutive(607);

/// Fourteenth survey rigs (seeds 655–702): set aside at the end of the
/// first session of 2026-12-07 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY14_RIGS: [u64; 48] = consecutive(655);

/// Fifteenth survey rigs (seeds 703–750): set aside at the end of the
/// second session of 2026-12-07 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY15_RIGS: [u64; 48] = consecutive(703);

/// Sixteenth survey rigs (seeds 751–798): set aside at the end of the
/// third session of 2026-12-07 and first run, untuned, at the start of
/// the next, before anything in it was looked at; from then on tuned on
/// like the others (reported separately). Disjoint from the other sets.
pub const SURVEY16_RIGS: [u64; 48] = consecutive(751);

/// `N` consecutive seeds from `first`.
const fn consecutive<const N: usize>(first: u64) -> [u64; N] {
    let mut seeds = [0; N];
    let mut i = 0;
    while i < N {
        seeds[i] = first + i as u64;
        i += 1;
    }
    seeds
}

/// A set of rigs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RigSet {
    /// [`DEV_RIGS`].
    Dev,
    /// [`HOLDOUT_RIGS`].
    Holdout,
    /// [`WIDE_RIGS`].
    Wide,
    /// [`SURVEY_RIGS`].
    Survey,
    /// [`SURVEY2_RIGS`].
    Survey2,
    /// [`SURVEY3_RIGS`].
    Survey3,
    /// [`SURVEY4_RIGS`].
    Survey4,
    /// [`SURVEY5_RIGS`].
    Survey5,
    /// [`SURVEY6_RIGS`].
    Survey6,
    /// [`SURVEY7_RIGS`].
    Survey7,
    /// [`SURVEY8_RIGS`].
    Survey8,
    /// [`SURVEY9_RIGS`].
    Survey9,
    /// [`SURVEY10_RIGS`].
    Survey10,
    /// [`SURVEY11_RIGS`].
    Survey11,
    /// [`SURVEY12_RIGS`].
    Survey12,
    /// [`SURVEY13_RIGS`].
    Survey13,
    /// [`SURVEY14_RIGS`].
    Survey14,
    /// [`SURVEY15_RIGS`].
    Survey15,
    /// [`SURVEY16_RIGS`].
    Survey16,
}

impl RigSet {
    /// Every set, in report order: development sets first, held-out last.
    /// A new set goes here too (the report, `--set` and the disjointness
    /// test read this list).
    pub const ALL: [RigSet; 19] = [
        Self::Dev,
        Self::Wide,
        Self::Survey,
        Self::Survey2,
        Self::Survey3,
        Self::Survey4,
        Self::Survey5,
        Self::Survey6,
        Self::Survey7,
        Self::Survey8,
        Self::Survey9,
        Self::Survey10,
        Self::Survey11,
        Self::Survey12,
        Self::Survey13,
        Self::Survey14,
        Self::Survey15,
        Self::Survey16,
        Self::Holdout,
    ];

    /// The rig seeds of the set.
    pub fn seeds(self) -> &'static [u64] {
        self.facts().seeds
    }

    /// Lower-case name (`--set`, the JSON's `set`).
    pub fn name(self) -> &'static str {
        self.facts().name
    }

    /// The report's heading for the set.
    pub fn title(self) -> &'static str {
        self.facts().title
    }

    /// What the set is for (`--set` help).
    pub fn about(self) -> &'static str {
        self.facts().about
    }

    /// Everything said about the set, in one place per set.
    fn facts(self) -> SetFacts {
        let (seeds, name, title, about): (&'static [u64], _, _, _) = match self {
            Self::Dev => (&DEV_RIGS, "dev", "Development rigs", "The development rigs"),
            Self::Holdout => (&HOLDOUT_RIGS, "holdout", "Held-out rigs", "The held-out rigs"),
            Self::Wide => (
                &WIDE_RIGS,
                "wide",
                "Further development rigs",
                "Further development rigs (seeds 7–30), to find failures on",
            ),
            Self::Survey => (
                &SURVEY_RIGS,
                "survey",
                "Survey development rigs",
                "A larger sample of development rigs (seeds 31–78), for rare failures (use with `--quick`)",
            ),
            Self::Survey2 => (
                &SURVEY2_RIGS,
                "survey2",
                "Second survey development rigs",
                "A second survey sample (seeds 79–126), first run untuned on 2026-12-05 (use with `--quick`)",
            ),
            Self::Survey3 => (
                &SURVEY3_RIGS,
                "survey3",
                "Third survey development rigs",
                "A third survey sample (seeds 127–174), first run untuned in the session after (use with `--quick`)",
            ),
            Self::Survey4 => (
                &SURVEY4_RIGS,
                "survey4",
                "Fourth survey development rigs",
                "A fourth survey sample (seeds 175–222), first run untuned at the start of the ninth session of 2026-12-05 (use with `--quick`)",
            ),
            Self::Survey5 => (
                &SURVEY5_RIGS,
                "survey5",
                "Fifth survey development rigs",
                "A fifth survey sample (seeds 223–270), first run untuned at the start of the first session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey6 => (
                &SURVEY6_RIGS,
                "survey6",
                "Sixth survey development rigs",
                "A sixth survey sample (seeds 271–318), first run untuned at the start of the second session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey7 => (
                &SURVEY7_RIGS,
                "survey7",
                "Seventh survey development rigs",
                "A seventh survey sample (seeds 319–366), first run untuned at the start of the third session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey8 => (
                &SURVEY8_RIGS,
                "survey8",
                "Eighth survey development rigs",
                "An eighth survey sample (seeds 367–414), first run untuned at the start of the fourth session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey9 => (
                &SURVEY9_RIGS,
                "survey9",
                "Ninth survey development rigs",
                "A ninth survey sample (seeds 415–462), first run untuned at the start of the fifth session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey10 => (
                &SURVEY10_RIGS,
                "survey10",
                "Tenth survey development rigs",
                "A tenth survey sample (seeds 463–510), first run untuned at the start of the sixth session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey11 => (
                &SURVEY11_RIGS,
                "survey11",
                "Eleventh survey development rigs",
                "An eleventh survey sample (seeds 511–558), first run untuned at the start of the seventh session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey12 => (
                &SURVEY12_RIGS,
                "survey12",
                "Twelfth survey development rigs",
                "A twelfth survey sample (seeds 559–606), first run untuned at the start of the eighth session of 2026-12-06 (use with `--quick`)",
            ),
            Self::Survey13 => (
                &SURVEY13_RIGS,
                "survey13",
                "Thirteenth survey development rigs",
                "A thirteenth survey sample (seeds 607–654), first run untuned at the start of the first session of 2026-12-07 (use with `--quick`)",
            ),
            Self::Survey14 => (
                &SURVEY14_RIGS,
                "survey14",
                "Fourteenth survey development rigs",
                "A fourteenth survey sample (seeds 655–702), first run untuned at the start of the second session of 2026-12-07 (use with `--quick`)",
            ),
            Self::Survey15 => (
                &SURVEY15_RIGS,
                "survey15",
                "Fifteenth survey development rigs",
                "A fifteenth survey sample (seeds 703–750), first run untuned at the start of the third session of 2026-12-07 (use with `--quick`)",
            ),
            Self::Survey16 => (
                &SURVEY16_RIGS,
                "survey16",
                "Sixteenth survey development rigs",
                "A sixteenth survey sample (seeds 751–798), first run untuned at the start of the fourth session of 2026-12-07 (use with `--quick`)",
            ),
        };
        SetFacts {
            seeds,
            name,
            title,
            about,
        }
    }
}

/// What [`RigSet`]'s accessors read.
struct SetFacts {
    seeds: &'static [u64],
    name: &'static str,
    title: &'static str,
    about: &'static str,
}

/// Which rig sets to evaluate (command line `--set`): one set by its
/// name ([`RigSet::name`], help [`RigSet::about`]), or `both`. Its
/// values come from [`RigSet::ALL`]: a new set is added to `RigSet`
/// alone (its variant, `ALL` and its arm of `RigSet::facts`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetChoice {
    /// One set.
    One(RigSet),
    /// The development and the held-out rigs, reported separately.
    Both,
}

impl SetChoice {
    /// Every choice in `--help` order: the development rigs, the held-out
    /// ones, both, then the further development sets.
    const ALL: [SetChoice; RigSet::ALL.len() + 1] = {
        let mut out = [SetChoice::Both; RigSet::ALL.len() + 1];
        out[0] = SetChoice::One(RigSet::Dev);
        out[1] = SetChoice::One(RigSet::Holdout);
        let (mut i, mut k) = (0, 3);
        while i < RigSet::ALL.len() {
            let set = RigSet::ALL[i];
            if !matches!(set, RigSet::Dev | RigSet::Holdout) {
                out[k] = SetChoice::One(set);
                k += 1;
            }
            i += 1;
        }
        out
    };

    /// The sets, in report order.
    pub fn sets(self) -> Vec<RigSet> {
        match self {
            Self::One(set) => vec![set],
            Self::Both => vec![RigSet::Dev, RigSet::Holdout],
        }
    }
}

impl clap::ValueEnum for SetChoice {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let (name, help) = match self {
            Self::One(set) => (set.name(), set.about()),
            Self::Both => ("both", "Both, reported separately"),
        };
        Some(clap::builder::PossibleValue::new(name).help(help))
    }
}

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
