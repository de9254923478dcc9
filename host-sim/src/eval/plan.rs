//! The evaluation matrix: which cells, which runs, with which seeds. Pure
//! bookkeeping: nothing here simulates (rigs are drawn when a run executes).

use super::{seed_of, Category, Cell, FaultKind, Follower, Job, Placement, RigSet, RunSpec};
use plant::{Channel, Fault, Leak, Scenario};
use serde::{Deserialize, Serialize};

/// Length of the closed-loop runs, s.
pub const CLOSED_LOOP_S: f64 = 60.0;
/// Onset of the mid-run leaks, s.
pub const ONSET_S: f64 = 30.0;
/// Single-leak sizes, l/min (mean flow after onset).
pub const LEAK_SIZES_LPM: [f64; 5] = [0.1, 0.2, 0.3, 0.5, 1.0];
/// The single-leak size also run with the leak present from the start.
pub const FROM_START_LPM: f64 = 0.3;
/// Sizes of each leak of the combined-leak runs, l/min.
pub const BOTH_SIZES_LPM: [f64; 2] = [0.2, 0.5];
/// Leak sizes of the step tests with a leak, l/min.
pub const STEP_LEAK_LPM: [f64; 2] = [0.5, 1.0];
/// Step test: length and step time, s.
pub const STEP_TEST_S: (f64, f64) = (10.0, 3.0);
/// Step amplitude range (either sign), fraction of full opening.
pub const STEP_AMPLITUDE: (f64, f64) = (0.2, 0.6);
/// The long hold, s.
pub const HOLD_S: f64 = 600.0;
/// The long hold in `--quick`, s.
pub const QUICK_HOLD_S: f64 = 120.0;
/// Leak after the hold, l/min.
pub const AFTER_HOLD_LPM: f64 = 0.3;
/// Faults start here (frozen ones at the first mid-move instant after it), s.
pub const FAULT_AT_S: f64 = 20.0;
/// Stuck and NaN time last this long, s.
pub const TIME_FAULT_S: f64 = 2.0;
/// Mean rate of the position spikes, 1/s.
pub const SPIKE_RATE_HZ: f64 = 1.5;

/// What to plan.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanConfig {
    /// Rig sets.
    pub sets: Vec<RigSet>,
    /// Only the first this many rigs of each set.
    pub rigs: Option<usize>,
    /// Supply pressures, bar.
    pub supply_bar: Vec<f64>,
    /// Oil temperatures, °C.
    pub temp_c: Vec<f64>,
    /// The smaller development matrix.
    pub quick: bool,
    /// Sample rate of every recording, Hz.
    pub sample_rate_hz: f64,
    /// Length of each cell's healthy calibration recording, s.
    pub calibration_s: f64,
}

impl Default for PlanConfig {
    fn default() -> Self {
        Self {
            sets: vec![RigSet::Dev],
            rigs: None,
            supply_bar: vec![50.0, 100.0],
            temp_c: vec![25.0, 40.0],
            quick: false,
            sample_rate_hz: 1000.0,
            calibration_s: 60.0,
        }
    }
}

/// A cell and its calibration recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellPlan {
    /// The cell.
    pub cell: Cell,
    /// The healthy recording it is calibrated from (its own seeds).
    pub calibration: RunSpec,
}

/// The whole matrix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// How it was planned.
    pub config: PlanConfig,
    /// Cells, in order.
    pub cells: Vec<CellPlan>,
    /// Runs, grouped into jobs.
    pub jobs: Vec<Job>,
}

impl Plan {
    /// Every run (followers unplaced).
    pub fn specs(&self) -> impl Iterator<Item = &RunSpec> {
        self.jobs.iter().flat_map(Job::specs)
    }

    /// Number of runs (not counting calibrations).
    pub fn runs(&self) -> usize {
        self.specs().count()
    }
}

/// Builds the runs of one cell.
struct CellRuns<'a> {
    cell: &'a Cell,
    rate: f64,
}

impl CellRuns<'_> {
    fn spec(
        &self,
        tag: &str,
        category: Category,
        scenario: Scenario,
        leak: Leak,
        noise_seed: Option<u64>,
    ) -> RunSpec {
        let id = format!("{}/{tag}", self.cell.id());
        RunSpec {
            noise_seed: noise_seed.unwrap_or_else(|| seed_of(&format!("{id}/noise"))),
            id,
            cell: self.cell.clone(),
            category,
            fault: None,
            scenario,
            leak,
            faults: Vec::new(),
            sample_rate_hz: self.rate,
            placed: None,
        }
    }

    fn scenario_seed(&self, tag: &str) -> u64 {
        seed_of(&format!("{}/{tag}/scenario", self.cell.id()))
    }

    fn closed_loop(&self, tag: &str, duration_s: f64) -> Scenario {
        Scenario::ClosedLoop {
            duration_s,
            seed: self.scenario_seed(tag),
        }
    }

    /// A step test whose amplitude (±0.2..0.6) is drawn from its tag.
    fn step(&self, tag: &str) -> Scenario {
        let h = self.scenario_seed(tag);
        let u = (h >> 1) as f64 / (1u64 << 52) as f64;
        let u = u.clamp(0.0, 1.0);
        let a = STEP_AMPLITUDE.0 + (STEP_AMPLITUDE.1 - STEP_AMPLITUDE.0) * u;
        Scenario::StepTest {
            duration_s: STEP_TEST_S.0,
            step_at_s: STEP_TEST_S.1,
            amplitude: if h & 1 == 1 { -a } else { a },
        }
    }
}

fn leak(internal: bool, external: bool, size: f64, onset_s: f64) -> Leak {
    Leak {
        internal_lpm: if internal { size } else { 0.0 },
        external_lpm: if external { size } else { 0.0 },
        onset_s,
    }
}

/// The fault list of `kind` (frozen ones at a placeholder time, placed
/// later from the twin).
pub fn faults_of(kind: FaultKind) -> Vec<Fault> {
    let at_s = FAULT_AT_S;
    vec![match kind {
        FaultKind::SpikesXPiston => Fault::Spikes {
            channel: Channel::XPiston,
            rate_hz: SPIKE_RATE_HZ,
            at_s,
        },
        FaultKind::OpenWirePPiston => Fault::OpenWire {
            channel: Channel::PPiston,
            at_s,
        },
        FaultKind::OpenWireXPiston => Fault::OpenWire {
            channel: Channel::XPiston,
            at_s,
        },
        FaultKind::OpenWireUValve => Fault::OpenWire {
            channel: Channel::UValve,
            at_s,
        },
        FaultKind::FrozenXPiston => Fault::Frozen {
            channel: Channel::XPiston,
            at_s,
        },
        FaultKind::FrozenPRod => Fault::Frozen {
            channel: Channel::PRod,
            at_s,
        },
        FaultKind::StuckTime => Fault::StuckTime {
            at_s,
            for_s: TIME_FAULT_S,
        },
        FaultKind::NanTime => Fault::NanTime {
            at_s,
            for_s: TIME_FAULT_S,
        },
        FaultKind::RandomNoise => Fault::RandomNoise,
    }]
}

/// When a run's fault is active, s (`None`: no fault); `end` is the end of
/// the run for lasting faults.
pub fn fault_window(faults: &[Fault]) -> Option<(f64, Option<f64>)> {
    faults.first().map(|f| match *f {
        Fault::Spikes { at_s, .. } | Fault::OpenWire { at_s, .. } | Fault::Frozen { at_s, .. } => {
            (at_s, None)
        }
        Fault::StuckTime { at_s, for_s } | Fault::NanTime { at_s, for_s } => {
            (at_s, Some(at_s + for_s))
        }
        Fault::RandomNoise => (0.0, None),
    })
}

/// The matrix for `config`.
///
/// Per cell (rig × supply × temperature; `temp_oil` column on rigs with an
/// even seed): 2 healthy closed-loop runs, 1 healthy step test, internal and
/// external leaks of every size in [`LEAK_SIZES_LPM`] from 30 s (0.3 l/min
/// also from the start), both leaks at each size of [`BOTH_SIZES_LPM`], and
/// step tests with a leak (internal on even rigs, external on odd) of each
/// size in [`STEP_LEAK_LPM`]. On one cell per rig (rotating through the
/// conditions, see below): a healthy long hold and the same hold with a 0.3 l/min leak
/// starting after 600 s of holding, and every fault on the first healthy
/// closed-loop run's plant. `--quick`: one cell per rig (the rig with index
/// `i` in its set gets condition `(i + i/2) mod n`, so that with 4 conditions
/// and 6 rigs each supply and temperature is covered with and without the
/// `temp_oil` column), one
/// healthy closed-loop run, 0.2 and 0.5 l/min single leaks, 0.5 l/min both,
/// a 1.0 l/min step-test leak, a 120 s hold and five faults (spikes, open
/// piston-pressure and valve-command wires, frozen position, NaN time).
pub fn plan(config: &PlanConfig) -> Plan {
    let mut cells = Vec::new();
    let mut jobs = Vec::new();
    let conditions: Vec<(f64, f64)> = config
        .supply_bar
        .iter()
        .flat_map(|&s| config.temp_c.iter().map(move |&t| (s, t)))
        .collect();
    for &set in &config.sets {
        let seeds = set.seeds();
        let n = config.rigs.unwrap_or(seeds.len()).min(seeds.len());
        for (i, &rig) in seeds[..n].iter().enumerate() {
            let temp_column = rig % 2 == 0;
            // Rotate through the conditions so that every condition, and
            // each supply and temperature with and without the `temp_oil`
            // column, gets a rig (a plain `i % n` would tie the column's
            // parity to one condition).
            let k = (i + i / 2) % conditions.len().max(1);
            let (conds, special) = if config.quick {
                (vec![conditions[k]], 0)
            } else {
                (conditions.clone(), k)
            };
            for (ci, &(supply_bar, temp_c)) in conds.iter().enumerate() {
                let cell = Cell {
                    set,
                    rig,
                    supply_bar,
                    temp_c,
                    temp_column,
                };
                let b = CellRuns {
                    cell: &cell,
                    rate: config.sample_rate_hz,
                };
                let calibration = b.spec(
                    "calibration",
                    Category::Calibration,
                    b.closed_loop("calibration", config.calibration_s),
                    Leak::default(),
                    None,
                );
                cell_jobs(&b, config.quick, ci == special, rig, &mut jobs);
                cells.push(CellPlan {
                    cell: cell.clone(),
                    calibration,
                });
            }
        }
    }
    Plan {
        config: config.clone(),
        cells,
        jobs,
    }
}

fn cell_jobs(b: &CellRuns, quick: bool, special: bool, rig: u64, jobs: &mut Vec<Job>) {
    let none = Leak::default();
    let even = rig.is_multiple_of(2);
    // Healthy closed loop; the first is the faults' twin on the special cell.
    let healthy_runs = if quick { 1 } else { 2 };
    let mut twin = None;
    for k in 1..=healthy_runs {
        let tag = format!("healthy-{k}");
        let s = b.spec(
            &tag,
            Category::HealthyClosedLoop,
            b.closed_loop(&tag, CLOSED_LOOP_S),
            none,
            None,
        );
        if k == 1 && special {
            twin = Some(s);
        } else {
            jobs.push(Job::single(s));
        }
    }
    jobs.push(Job::single(b.spec(
        "healthy-step",
        Category::HealthyStep,
        b.step("healthy-step"),
        none,
        None,
    )));
    // Single leaks.
    let sizes: &[f64] = if quick { &[0.2, 0.5] } else { &LEAK_SIZES_LPM };
    for (kind, internal) in [("internal", true), ("external", false)] {
        for &size in sizes {
            let mut onsets = vec![ONSET_S];
            if !quick && size == FROM_START_LPM {
                onsets.push(0.0);
            }
            for onset in onsets {
                let tag = format!("{kind}-{size:.2}-on{onset}");
                jobs.push(Job::single(b.spec(
                    &tag,
                    Category::Leak,
                    b.closed_loop(&tag, CLOSED_LOOP_S),
                    leak(internal, !internal, size, onset),
                    None,
                )));
            }
        }
    }
    let both: &[f64] = if quick { &[0.5] } else { &BOTH_SIZES_LPM };
    for &size in both {
        let tag = format!("both-{size:.2}-on{ONSET_S}");
        jobs.push(Job::single(b.spec(
            &tag,
            Category::Leak,
            b.closed_loop(&tag, CLOSED_LOOP_S),
            leak(true, true, size, ONSET_S),
            None,
        )));
    }
    // Step tests with a leak from the start.
    let step_sizes: &[f64] = if quick { &[1.0] } else { &STEP_LEAK_LPM };
    for &size in step_sizes {
        let kind = if even { "internal" } else { "external" };
        let tag = format!("step-{kind}-{size:.2}");
        jobs.push(Job::single(b.spec(
            &tag,
            Category::StepLeak,
            b.step(&tag),
            leak(even, !even, size, 0.0),
            None,
        )));
    }
    if !special {
        return;
    }
    // The long hold, healthy, and with a leak starting once the piston has
    // held for `hold_s` (same motion and noise seeds: identical until the
    // onset; the plant's hold is followed by 8-15 s of work cycle).
    let hold_s = if quick { QUICK_HOLD_S } else { HOLD_S };
    let hold = Scenario::LongHold {
        hold_s,
        seed: b.scenario_seed("long-hold"),
    };
    let head = b.spec("long-hold", Category::HealthyLongHold, hold, none, None);
    let kind = if even { "internal" } else { "external" };
    let fallback_s = hold_s + 10.0;
    let after = b.spec(
        &format!("{kind}-{AFTER_HOLD_LPM:.2}-after-hold"),
        Category::LeakAfterHold,
        hold,
        leak(even, !even, AFTER_HOLD_LPM, fallback_s),
        Some(head.noise_seed),
    );
    jobs.push(Job {
        head,
        followers: vec![Follower {
            spec: after,
            placement: Placement::OnsetAfterHold { hold_s, fallback_s },
        }],
    });
    // Faults, on the plant (motion and noise seeds) of the first healthy run.
    let twin = twin.expect("the special cell has its first healthy run");
    let kinds: &[FaultKind] = if quick {
        &[
            FaultKind::SpikesXPiston,
            FaultKind::OpenWirePPiston,
            // The issue names the valve command's wire: the never-seen
            // rigs are run with `--quick` and must show it too.
            FaultKind::OpenWireUValve,
            FaultKind::FrozenXPiston,
            FaultKind::NanTime,
        ]
    } else {
        &FaultKind::ALL
    };
    let mut followers = Vec::new();
    for &kind in kinds {
        let tag = format!("fault-{}", kind.name().replace(' ', "-").to_lowercase());
        let mut s = b.spec(
            &tag,
            Category::Fault,
            twin.scenario,
            none,
            Some(twin.noise_seed),
        );
        s.fault = Some(kind);
        s.faults = faults_of(kind);
        if kind.mid_move() {
            followers.push(Follower {
                spec: s,
                placement: Placement::FaultMidMove {
                    after_s: FAULT_AT_S,
                },
            });
        } else {
            jobs.push(Job::single(s));
        }
    }
    jobs.push(Job {
        head: twin,
        followers,
    });
}
