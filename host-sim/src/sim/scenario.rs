//! Scenarios: what the rig does (position profile under a P controller, or
//! open-loop valve steps), at which supply pressure and oil temperature,
//! with which leaks from when, on which rig (the simulator's own [`Rig`]
//! data).

pub use super::rig::RigState;
use super::rig::{LeakLaw, RigPhysics};
use super::rig_data::Rig;
use super::sensors::{SensorModel, Sensors};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{BAR, LPM};
/// Fine integration step, s.
pub const FINE_STEP_S: f64 = 5e-5;

/// What the piston is asked to do.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// A 60 s cycle of holds, slow and fast ramps and steps under position
    /// control, like the custom trajectory of thesis ch. 9 (Fig. 9-2).
    Thesis,
    /// Random holds and moves (targets, speeds, steps) from the seed.
    Random,
    /// Open-loop valve step tests (±20 %, ±40 %) between closed-loop holds,
    /// like thesis ch. 7.
    Steps,
    /// Position control holding mid-stroke, no motion.
    Hold,
}

/// One simulated run.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Length, s.
    pub duration_s: f64,
    /// Sample rate of the recording, Hz.
    pub sample_rate_hz: f64,
    /// Supply set pressure, bar.
    pub supply_bar: f64,
    /// Oil temperature, °C.
    pub temp_c: f64,
    /// Write the `temp_oil` column.
    pub write_temperature: bool,
    /// Motion profile.
    pub profile: Profile,
    /// Internal leak: mean flow over the run after onset, l/min.
    pub internal_lpm: f64,
    /// External leak: mean flow over the run after onset, l/min.
    pub external_lpm: f64,
    /// Internal leak flow law.
    pub internal_law: LeakLaw,
    /// External leak flow law.
    pub external_law: LeakLaw,
    /// Leaks start at this time, s.
    pub leak_onset_s: f64,
    /// Seed of the noise and of random profiles.
    pub seed: u64,
    /// Position controller gain, 1/m (command per metre of error).
    pub controller_gain_per_m: f64,
    /// Controller output limit.
    pub command_limit: f64,
    /// The sensors' lag, noise and quantisation (their offsets are the
    /// rig's).
    pub sensors: SensorModel,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            duration_s: 60.0,
            sample_rate_hz: 1000.0,
            supply_bar: 50.0,
            temp_c: 25.0,
            write_temperature: false,
            profile: Profile::Thesis,
            internal_lpm: 0.0,
            external_lpm: 0.0,
            internal_law: LeakLaw::Laminar,
            external_law: LeakLaw::Laminar,
            leak_onset_s: 0.0,
            seed: 1,
            controller_gain_per_m: 15.0,
            command_limit: 0.6,
            sensors: SensorModel::default(),
        }
    }
}

/// A piece of the motion profile.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Segment {
    /// Closed loop: reference moves linearly from `from` to `to` over the
    /// segment (equal for a hold; a step is a zero-length ramp).
    Track { from: f64, to: f64 },
    /// Open loop: this valve command.
    Open { u: f64 },
}

/// The motion profile as timed segments.
#[derive(Clone, Debug)]
struct Trajectory {
    /// (start time, end time, segment), contiguous.
    segments: Vec<(f64, f64, Segment)>,
}

impl Trajectory {
    fn build(profile: Profile, duration: f64, seed: u64) -> Self {
        let mut segs: Vec<(f64, f64, Segment)> = Vec::new();
        let mut t = 0.0;
        let push = |segs: &mut Vec<_>, t: &mut f64, d: f64, s: Segment| {
            segs.push((*t, *t + d, s));
            *t += d;
        };
        match profile {
            Profile::Thesis => {
                // (duration, from, to): holds, ramps of 10–43 mm/s, steps.
                let cycle: [(f64, f64, f64); 14] = [
                    (3.0, 0.04, 0.04),
                    (4.0, 0.04, 0.14),
                    (4.0, 0.14, 0.14),
                    (5.0, 0.08, 0.08),
                    (8.0, 0.08, 0.16),
                    (3.0, 0.16, 0.16),
                    (3.0, 0.16, 0.03),
                    (4.0, 0.03, 0.03),
                    (6.0, 0.10, 0.10),
                    (5.0, 0.10, 0.05),
                    (3.0, 0.05, 0.05),
                    (4.0, 0.05, 0.12),
                    (3.0, 0.12, 0.12),
                    (5.0, 0.12, 0.04),
                ];
                while t < duration {
                    for (d, a, b) in cycle {
                        push(&mut segs, &mut t, d, Segment::Track { from: a, to: b });
                    }
                }
            }
            Profile::Random => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_7a3c);
                let mut x: f64 = 0.05;
                push(&mut segs, &mut t, 3.0, Segment::Track { from: x, to: x });
                while t < duration {
                    let mut target = x;
                    while (target - x).abs() < 0.02 {
                        target = 0.02 + 0.14 * rng.random::<f64>();
                    }
                    if rng.random::<f64>() < 0.25 {
                        x = target; // a step
                    } else {
                        let speed = 0.005 + 0.045 * rng.random::<f64>();
                        let d = (target - x).abs() / speed;
                        push(
                            &mut segs,
                            &mut t,
                            d,
                            Segment::Track {
                                from: x,
                                to: target,
                            },
                        );
                        x = target;
                    }
                    let hold = 1.5 + 4.5 * rng.random::<f64>();
                    push(&mut segs, &mut t, hold, Segment::Track { from: x, to: x });
                }
            }
            Profile::Steps => {
                let cycle: [(f64, Segment); 8] = [
                    (
                        4.0,
                        Segment::Track {
                            from: 0.05,
                            to: 0.05,
                        },
                    ),
                    (1.0, Segment::Open { u: 0.2 }),
                    (
                        4.0,
                        Segment::Track {
                            from: 0.12,
                            to: 0.12,
                        },
                    ),
                    (1.0, Segment::Open { u: -0.2 }),
                    (
                        4.0,
                        Segment::Track {
                            from: 0.06,
                            to: 0.06,
                        },
                    ),
                    (0.5, Segment::Open { u: 0.4 }),
                    (
                        4.0,
                        Segment::Track {
                            from: 0.13,
                            to: 0.13,
                        },
                    ),
                    (0.5, Segment::Open { u: -0.4 }),
                ];
                while t < duration {
                    for (d, s) in cycle {
                        push(&mut segs, &mut t, d, s);
                    }
                }
            }
            Profile::Hold => push(
                &mut segs,
                &mut t,
                duration + 1.0,
                Segment::Track {
                    from: 0.09,
                    to: 0.09,
                },
            ),
        }
        Self { segments: segs }
    }

    /// The segment active at `t` and the reference position, if tracking.
    fn at(&self, t: f64) -> Segment {
        let i = self
            .segments
            .partition_point(|s| s.1 <= t)
            .min(self.segments.len() - 1);
        let (t0, t1, seg) = self.segments[i];
        match seg {
            Segment::Track { from, to } => {
                let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                let x = from + (to - from) * f;
                Segment::Track { from: x, to: x }
            }
            open => open,
        }
    }

    fn start_position(&self) -> f64 {
        match self.segments[0].2 {
            Segment::Track { from, .. } => from,
            Segment::Open { .. } => 0.09,
        }
    }
}

/// One row of a simulated recording, in the simulator's own terms: what
/// the rig's sensors read at one sample instant, with the rig's truth
/// beside it. (It becomes a `monitor::Sample` only outside `sim`, where a
/// row is written to a recording or fed to the monitor.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimRow {
    /// Time since the start of the recording, s.
    pub t_s: f64,
    /// Supply pressure reading, bar (gauge).
    pub p_supply_bar: f64,
    /// Piston-chamber pressure reading, bar (gauge).
    pub p_piston_bar: f64,
    /// Rod-chamber pressure reading, bar (gauge).
    pub p_rod_bar: f64,
    /// Tank pressure reading, bar (gauge).
    pub p_tank_bar: f64,
    /// Piston position reading, m (0 = fully retracted).
    pub x_piston_m: f64,
    /// Valve command as read back, normalised to [-1, 1] (positive
    /// extends).
    pub u_valve: f64,
    /// Oil temperature, °C, when the scenario writes it.
    pub temp_oil_c: Option<f64>,
    /// True internal leak flow, l/min.
    pub q_internal_lpm: f64,
    /// True external leak flow, l/min.
    pub q_external_lpm: f64,
}

/// A running simulation: an iterator of rows.
pub struct Simulation {
    rig: RigPhysics,
    sensors: Sensors,
    rng: ChaCha8Rng,
    traj: Trajectory,
    state: RigState,
    scenario: Scenario,
    k: u64,
    n: u64,
    substeps: u32,
}

/// Leak coefficients of the rig for `scenario` (see `Simulation::new`).
pub fn leak_coefficients(scenario: &Scenario, plant: &Rig) -> (f64, f64) {
    // First guess from typical pressure differences at this supply.
    let guess = |lpm: f64, law: LeakLaw, dp_bar: f64| match law {
        LeakLaw::Laminar => lpm * LPM / (dp_bar * BAR),
        LeakLaw::Orifice => lpm * LPM / (dp_bar * BAR).sqrt(),
    };
    let mut ki = guess(scenario.internal_lpm, scenario.internal_law, 8.0);
    let mut ke = guess(
        scenario.external_lpm,
        scenario.external_law,
        0.3 * scenario.supply_bar,
    );
    if scenario.internal_lpm <= 0.0 && scenario.external_lpm <= 0.0 {
        return (0.0, 0.0);
    }
    // The specified flow is the mean over the run after onset, as the
    // thesis' Table 9-4 reports it: rescale by measured means.
    for _ in 0..3 {
        let (mi, me) = mean_leak_flows(scenario, plant, ki, ke);
        let mut done = true;
        if scenario.internal_lpm > 0.0 && mi > 1e-9 {
            done &= (mi / scenario.internal_lpm - 1.0).abs() < 0.02;
            ki *= scenario.internal_lpm / mi;
        }
        if scenario.external_lpm > 0.0 && me > 1e-9 {
            done &= (me / scenario.external_lpm - 1.0).abs() < 0.02;
            ke *= scenario.external_lpm / me;
        }
        if done {
            break;
        }
    }
    (ki, ke)
}

fn mean_leak_flows(scenario: &Scenario, plant: &Rig, ki: f64, ke: f64) -> (f64, f64) {
    let sim = Simulation::with_coefficients(scenario.clone(), plant.clone(), ki, ke);
    let (mut si, mut se, mut n) = (0.0, 0.0, 0usize);
    for row in sim {
        if row.t_s >= scenario.leak_onset_s {
            si += row.q_internal_lpm.abs();
            se += row.q_external_lpm.abs();
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    (si / n, se / n)
}

impl Simulation {
    /// A run of `scenario` on rig `plant`. The leak coefficients are found
    /// so that the mean leak flows after onset are the scenario's l/min (up
    /// to three full-length pre-runs: a leaky run costs up to four healthy
    /// ones).
    pub fn new(scenario: Scenario, plant: Rig) -> Self {
        let (ki, ke) = leak_coefficients(&scenario, &plant);
        Self::with_coefficients(scenario, plant, ki, ke)
    }

    /// A run with explicit leak coefficients (laminar: m³/(s·Pa), orifice:
    /// m³/(s·√Pa)).
    pub fn with_coefficients(scenario: Scenario, plant: Rig, ki: f64, ke: f64) -> Self {
        let offsets = plant.sensors.clone();
        let mut rig = RigPhysics::new(plant, scenario.supply_bar, scenario.temp_c);
        rig.internal_k = ki;
        rig.internal_law = scenario.internal_law;
        rig.external_k = ke;
        rig.external_law = scenario.external_law;
        rig.leak_onset_s = scenario.leak_onset_s;
        let traj = Trajectory::build(scenario.profile, scenario.duration_s, scenario.seed);
        let mut state = rig.rest_state(traj.start_position());
        // Settle the hydraulics for 2 s under control before recording.
        let settle_traj = traj.at(0.0);
        let mut u = 0.0;
        let h = FINE_STEP_S;
        // Settling happens before t = 0: a leak present from the start
        // (onset 0) acts during it, a later one does not.
        let t_settle = if scenario.leak_onset_s <= 0.0 {
            0.0
        } else {
            -1.0
        };
        for i in 0..(2.0 / h) as usize {
            if i % 20 == 0 {
                if let Segment::Track { from, .. } = settle_traj {
                    u = (scenario.controller_gain_per_m * (from - state.x))
                        .clamp(-scenario.command_limit, scenario.command_limit);
                }
            }
            state = rig.rk4(&state, u, t_settle, h).0;
        }
        let n = (scenario.duration_s * scenario.sample_rate_hz).round() as u64;
        let substeps = ((1.0 / scenario.sample_rate_hz) / h).round().max(1.0) as u32;
        Self {
            sensors: Sensors::new(scenario.sensors.clone(), offsets),
            rng: ChaCha8Rng::seed_from_u64(scenario.seed),
            traj,
            state,
            k: 0,
            n,
            substeps,
            scenario,
            rig,
        }
    }

    /// The rig's physics (for tests).
    pub fn rig(&self) -> &RigPhysics {
        &self.rig
    }

    /// The rig's true state now (after the last row's interval).
    pub fn state(&self) -> RigState {
        self.state
    }
}

impl Iterator for Simulation {
    type Item = SimRow;

    fn next(&mut self) -> Option<SimRow> {
        if self.k >= self.n {
            return None;
        }
        let t = self.k as f64 / self.scenario.sample_rate_hz;
        let (_, out) = self.rig.derivative(&self.state, 0.0, t);
        if self.k == 0 {
            self.sensors.track(self.pressures_bar(out.p2, out.p5), 0.0);
        }
        let r = self.sensors.read(self.state.x, &mut self.rng);
        // Controller at the sample instant, from the measured position.
        let sc = &self.scenario;
        let u = match self.traj.at(t) {
            Segment::Track { from, .. } => (sc.controller_gain_per_m * (from - r.x_m))
                .clamp(-sc.command_limit, sc.command_limit),
            Segment::Open { u } => u,
        };
        let u_read = self.sensors.read_command(u, &mut self.rng);
        let row = SimRow {
            t_s: t,
            p_supply_bar: r.pressures_bar[0],
            p_piston_bar: r.pressures_bar[1],
            p_rod_bar: r.pressures_bar[2],
            p_tank_bar: r.pressures_bar[3],
            x_piston_m: r.x_m,
            u_valve: u_read,
            temp_oil_c: sc.write_temperature.then_some(sc.temp_c),
            q_internal_lpm: out.q_internal / LPM,
            q_external_lpm: out.q_external / LPM,
        };
        // Hold the command until the next sample.
        let h = 1.0 / sc.sample_rate_hz / self.substeps as f64;
        for i in 0..self.substeps {
            let ti = t + i as f64 * h;
            let (next, o) = self.rig.rk4(&self.state, u, ti, h);
            self.state = next;
            let p = self.pressures_bar(o.p2, o.p5);
            self.sensors.track(p, h);
        }
        self.k += 1;
        Some(row)
    }
}

impl Simulation {
    fn pressures_bar(&self, p2: f64, p5: f64) -> [f64; 4] {
        [p2 / BAR, self.state.p3 / BAR, self.state.p4 / BAR, p5 / BAR]
    }
}

/// The reference rig with random rig-to-rig variation from `seed` (see
/// [`Rig::perturbed`]): the rigs `--rig-seed` simulates.
pub fn perturbed_rig(seed: u64) -> Rig {
    Rig::reference().perturbed(seed)
}
