//! An independent, hostile test plant for the leak monitor.
//!
//! It shares **no model code** with `monitor` (this crate must never depend
//! on it): its own derivation of the pantograph load, its own fluid, valve,
//! friction, supply and sensor models. Each rig is drawn from a seed and
//! varies what real rigs vary: noise levels and colour, offsets, lags,
//! quantisation, valve land leakage per edge, friction law, supply
//! dynamics, tank back pressure, hose compliance, air, load errors,
//! temperature drift, end stops; and faults.
//!
//! Interface (stable: `host-sim` builds on it):
//! - [`RigSpec::random`]: a rig from a seed, at a supply pressure and
//!   oil temperature.
//! - [`Run`]: a rig, a [`Scenario`], a [`Leak`] and optional [`Fault`]s.
//! - [`simulate`]: the recording rows at the sample rate, with truth.
//! - Additions: [`simulate_with_report`] (rows plus how the leaks came
//!   out: law, coefficients, realised means, passes), [`simulate_reusing`]
//!   (a run that differs from the last only in its faults takes the
//!   last's [`Motion`]: the same rows, one physics run fewer), [`leak_law`], the
//!   public spec structs of every model (fields of [`RigSpec`]), and extra
//!   [`Truth`] fields (supply and tank pressure, spool, temperature,
//!   setpoint).
//!
//! # Models (one module each)
//! - [`load`]: pantograph kinematics from thesis ch. 5 (angle fits in
//!   degrees), `M(x)`, `M'(x)`, `G(x)` by virtual work; payload at the tip.
//! - [`cylinder`]: areas, dead volumes, hose compliance, end stops (bumper
//!   spring–damper plus rigid heads: the truth position never leaves
//!   `[0, stroke]`).
//! - [`fluid`]: Walther viscosity law, bulk modulus with entrained air.
//! - [`valve`]: 2nd-order spool with travel limits, four edges with own
//!   gains and overlaps, smooth orifice law, land leakage per edge.
//! - [`friction`]: LuGre or Karnopp–Stribeck per rig.
//! - [`supply`]: compensated pump with flow limit and droop, supply line
//!   compliance, ripple, tank back pressure rising with return flow.
//! - [`leak`]: the leak laws. [`controller`], [`scenario`]: the machine's
//!   P/PI position control and its setpoints. [`sensors`], [`faults`]: the
//!   measurement chain.
//!
//! # What is randomised (per rig seed unless noted)
//! | What | Range |
//! |---|---|
//! | rod masses / inertias | ±10 % / ±30 % |
//! | payload at the tip / force offset | 0–30 kg / ±200 N |
//! | areas / dead volumes | ±0.5 % / ±15 % |
//! | hose share of dead volume / hose stiffness | 0.3–0.8 / 5000–30000 bar |
//! | oil ν(40 °C) / ν(25)/ν(40) / bulk modulus | 46 cSt ±15 % / 1.8–2.2 / 16000 bar ±15 % |
//! | entrained air / polytropic exponent | 0.2–3 % (log) / 1.0–1.4 |
//! | spool ω / ζ | 880 rad/s ±20 % / 0.92 ±20 % |
//! | edge flow gains | 7.9 / 7.4 l/min/√bar, overall ±8 %, each ±3 % |
//! | overlap / per edge / null bias | 0.005–0.03 / ±15 % / ±0.005 |
//! | laminar transition of the orifices | 0.3–2 bar |
//! | land leakage per edge / decay with cover | 3e-3 l/min/bar × 0.3–3 (log) / 0.005–0.02 |
//! | friction law | LuGre (σ0 3e6–2e7 N/m) or Karnopp (window 0.05–0.3 mm/s) |
//! | Coulomb / breakaway / viscous / Stribeck v | 300–700 N / 1.2–2.5 × / 2000–8000 N·s/m / 2–20 mm/s |
//! | viscous ∝ (ν/ν_ref)^e | e 0.3–0.8 |
//! | pump flow / droop / supply line | 25–45 l/min / 1–5 bar / 0.5–2 l |
//! | ripple | 1–3 harmonics of 100–400 Hz, 0.2–2 bar |
//! | tank back pressure / rise at 30 l/min / lag | 0.3–2 bar / 0.5–3 bar / 2–10 ms |
//! | controller | P (Kp 20–80 /m) or PI (30 %), velocity feed-forward (50 %) |
//! | pressure noise (each channel) | white 0.02–0.6 bar (log), AR(1) 0–1 × white with τ 2–50 ms |
//! | position noise | white 0.01–0.15 mm (log), AR(1) as above |
//! | offsets / lags | ±0.5 bar, ±1 mm / 0–8 ms |
//! | quantisation | 12 or 16 bit on 250 or 400 bar; 12–16 bit on 200 mm |
//! | ripple pickup | chambers 0–0.3, tank 0–0.1 of the ripple |
//! | valve command read-back offset | 0 (70 %) or ±0.003 |
//! | temperature reading noise | 0.1–0.5 °C, 0.1 °C steps |
//! | per run (noise seed): leak law; oil temperature drift | laminar / orifice / mix; ±3 °C per 10 min |
//!
//! # Speed (release, one core, CPU time on the shared 2-core dev box)
//! - 60 s closed loop, no leak: 0.39–0.55 s (110–150× real time);
//!   with a leak (2 calibration passes; rarely 3–6): 0.8–1.0 s (60–75×).
//! - 10-min long hold, no leak: 3.1–3.4 s (≈ 185×); with a leak (2
//!   passes): 6.6–7.1 s (85–90×). Wall-clock time was up to 2× longer
//!   while the machine was shared (load ≈ 5 on 2 cores).
//! - Integration: RK4 at 50 µs, 100 µs in quiet samples (valve ≤ 8 %
//!   open, |v| < 30 mm/s, clear of the stops); a 3 s pre-roll settles
//!   the machine before the recording starts.

#![deny(missing_docs)]

use serde::{Deserialize, Serialize};

pub mod controller;
pub mod cylinder;
pub mod faults;
pub mod fluid;
pub mod friction;
pub mod leak;
pub mod load;
mod physics;
mod rig;
mod rng;
pub mod scenario;
pub mod sensors;
mod sim;
pub mod supply;
pub mod valve;

pub use controller::ControllerSpec;
pub use cylinder::CylinderSpec;
pub use fluid::FluidSpec;
pub use friction::{FrictionLaw, FrictionSpec};
pub use leak::LeakLaw;
pub use load::LoadSpec;
pub use sensors::{ChannelSpec, SensorSpec};
pub use sim::{leak_law, simulate_reusing, simulate_with_report, Motion, RunReport};
pub use supply::SupplySpec;
pub use valve::ValveSpec;

/// Temperature the viscosity-dependent coefficients (valve land leakage,
/// viscous friction, laminar leaks) refer to, °C.
pub const REFERENCE_TEMP_C: f64 = 25.0;

/// Everything physical and metrological about one rig. Drawn from a seed
/// by [`RigSpec::random`]; fields are public so a test can pin one effect.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigSpec {
    /// The seed it was drawn from.
    pub seed: u64,
    /// Relief / compensator set pressure, bar.
    pub supply_bar: f64,
    /// Oil temperature at the start, °C.
    pub temp_c: f64,
    /// Pantograph geometry, masses, payload, force offset.
    pub load: LoadSpec,
    /// Cylinder areas, dead volumes, hoses, end stops.
    pub cylinder: CylinderSpec,
    /// Oil viscosity law, bulk modulus, air.
    pub fluid: FluidSpec,
    /// Servo valve: spool dynamics, edges, land leakage.
    pub valve: ValveSpec,
    /// Cylinder friction law and levels.
    pub friction: FrictionSpec,
    /// Pump, supply line, ripple, tank line.
    pub supply: SupplySpec,
    /// Measurement chain of every channel.
    pub sensors: SensorSpec,
    /// The machine's position controller.
    pub controller: ControllerSpec,
}

impl RigSpec {
    /// A rig drawn from `seed` (deterministic), running at `supply_bar`
    /// with oil at `temp_c`.
    pub fn random(seed: u64, supply_bar: f64, temp_c: f64) -> Self {
        rig::random(seed, supply_bar, temp_c)
    }
}

/// What the machine does with the cylinder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Scenario {
    /// Position control through a work cycle of holds, slow and fast moves
    /// in both directions (thesis ch. 9 style), drawn from `seed`.
    ClosedLoop {
        /// Length, s.
        duration_s: f64,
        /// Seed of the motion profile.
        seed: u64,
    },
    /// Position control: a few moves, then one hold of `hold_s` at a
    /// mid-stroke position, then a few moves again.
    LongHold {
        /// Length of the hold, s (≥ 600 for the 10-minute case).
        hold_s: f64,
        /// Seed of the moves around the hold.
        seed: u64,
    },
    /// Open-loop valve step test: closed-loop hold, then at `step_at_s` the
    /// valve command steps to `amplitude` (signed, fraction of full
    /// opening) for the rest of the run (the piston may reach an end stop).
    StepTest {
        /// Length, s (10 for the thesis-style test).
        duration_s: f64,
        /// Time of the step, s.
        step_at_s: f64,
        /// Command after the step, −1..1.
        amplitude: f64,
    },
}

/// Leaks of the run, given as the **mean flow** they would have over the
/// run after onset at this rig's operating pressures, l/min (0: none).
///
/// The flow law (laminar, orifice or a mix; see [`LeakLaw`]) is drawn from
/// the run's noise seed; its coefficient is found by repeated simulation
/// (deterministic) so that the realised mean of the signed flow after
/// onset matches the request within ~2 %. Where the pressure difference
/// across a leak changes sign so often that its signed mean is below 30 %
/// of its mean magnitude, the mean magnitude is matched instead (see
/// [`RunReport`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Leak {
    /// Piston seal leak, piston chamber → rod chamber, l/min.
    pub internal_lpm: f64,
    /// Leak from the rod-side line to tank, l/min.
    pub external_lpm: f64,
    /// Time the leaks start, s (0: present from the start).
    pub onset_s: f64,
}

/// A measured channel of the recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Channel {
    /// Supply pressure.
    PSupply,
    /// Piston chamber pressure.
    PPiston,
    /// Rod chamber pressure.
    PRod,
    /// Tank pressure.
    PTank,
    /// Piston position.
    XPiston,
    /// Valve command.
    UValve,
    /// Oil temperature (a fault shows only where the run records it).
    TempOil,
}

/// A fault of the measurement chain, from `at_s` on.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Fault {
    /// Spikes of 1–3 samples on `channel` (position: 5–30 mm; pressures:
    /// 5–50 bar), about `rate_hz` per second.
    Spikes {
        /// Which channel.
        channel: Channel,
        /// Mean spike rate, 1/s.
        rate_hz: f64,
        /// From this time, s.
        at_s: f64,
    },
    /// Open wire: a 4–20 mA pressure or position loop reads empty
    /// (invalid); the valve command (a voltage input) reads 0.
    OpenWire {
        /// Which channel.
        channel: Channel,
        /// From this time, s.
        at_s: f64,
    },
    /// The channel repeats its last reading bit for bit.
    Frozen {
        /// Which channel.
        channel: Channel,
        /// From this time, s.
        at_s: f64,
    },
    /// The time stamp stops advancing (repeats) for `for_s` of real time.
    StuckTime {
        /// From this time, s.
        at_s: f64,
        /// For this long, s.
        for_s: f64,
    },
    /// The time stamp is NaN (written as `NaN`) for `for_s`.
    NanTime {
        /// From this time, s.
        at_s: f64,
        /// For this long, s.
        for_s: f64,
    },
    /// Every channel is replaced by random noise in its plausible range
    /// (not a machine at all).
    RandomNoise,
}

/// One simulated run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Run {
    /// The rig.
    pub rig: RigSpec,
    /// What the machine does.
    pub scenario: Scenario,
    /// Leaks.
    pub leak: Leak,
    /// Faults (usually none).
    pub faults: Vec<Fault>,
    /// Write the oil temperature reading.
    pub temp_column: bool,
    /// Sample rate of the recording, Hz (1000).
    pub sample_rate_hz: f64,
    /// Seed of the noise of this run.
    pub noise_seed: u64,
}

/// What really happened at a sample (not in the recording).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// True internal leak flow, l/min, signed in the nominal direction
    /// (piston chamber → rod chamber): a seal leaks either way, so it is
    /// negative while the rod chamber pressure is the higher one.
    pub internal_lpm: f64,
    /// True external leak flow, l/min, signed (rod-side line → tank;
    /// negative only if the rod side falls below tank pressure).
    pub external_lpm: f64,
    /// True piston position, m.
    pub x_m: f64,
    /// True piston velocity, m/s.
    pub v_m_s: f64,
    /// True chamber pressures (piston, rod), bar.
    pub p_chambers_bar: [f64; 2],
    /// At an end stop (within 0.2 mm of 0 or of the stroke: the bumper of
    /// [`cylinder::BUMPER_M`] and its compression).
    pub at_end_stop: bool,
    /// True supply pressure at the valve (including pump ripple), bar.
    pub p_supply_bar: f64,
    /// True tank line pressure, bar.
    pub p_tank_bar: f64,
    /// True spool position, fraction of travel.
    pub spool: f64,
    /// True oil temperature, °C.
    pub temp_c: f64,
    /// The machine controller's position setpoint, m (the last one during
    /// an open-loop step).
    pub x_ref_m: f64,
}

/// One row of the recording (`None`: an empty, invalid field), plus truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Time stamp as recorded, s (may repeat or be NaN under a fault).
    pub t: f64,
    /// Supply pressure, bar.
    pub p_supply: Option<f64>,
    /// Piston chamber pressure, bar.
    pub p_piston: Option<f64>,
    /// Rod chamber pressure, bar.
    pub p_rod: Option<f64>,
    /// Tank pressure, bar.
    pub p_tank: Option<f64>,
    /// Piston position, m (0 = retracted).
    pub x_piston: Option<f64>,
    /// Valve command, −1..1.
    pub u_valve: Option<f64>,
    /// Oil temperature, °C (only with `Run::temp_column`).
    pub temp_oil: Option<f64>,
    /// Truth.
    pub truth: Truth,
}

/// Length of the recording `scenario` produces, s (a long hold adds its
/// moves before and after the hold, drawn from its seed: 17–31 s plus the
/// ramp to the hold position).
pub fn planned_duration_s(scenario: &Scenario) -> f64 {
    scenario::Profile::new(scenario).duration_s
}

/// Simulate `run`: one row per sample.
pub fn simulate(run: &Run) -> Vec<Row> {
    simulate_with_report(run).0
}
