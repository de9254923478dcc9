//! The monitor: one entry point, [`Monitor::step`], from a sample to a
//! status. Deterministic: the same samples give the same statuses, bit for
//! bit, on any IEEE-754 machine (see `real.rs`).

use crate::decision::latch::AckOutcome;
use crate::decision::{Decision, SampleFacts, GAIN_SETTLED_SD};
use crate::elapsed::{elapsed, exceeds, Window};
use crate::estimation::bank::{
    external_index, internal_index, Bank, BankOutput, HypothesisFilter, Measurement, ProcessNoise,
    StepContext, LAMINAR, NB, NZ,
};
use crate::estimation::consistency::NoiseMatch;
use crate::estimation::model::{Inputs, Plant, Step, BAR, GAIN_REF, LAMINAR_REF, NX, P_REF, X_REF};
use crate::estimation::quiet::{self, EvidenceWeight, PistonSpeed, Quietness};
use crate::hypothesis::Hypothesis;
use crate::params::{operating_region, ParamError, Params, HOLDING_REGION};
use crate::physics::fluid::laminar_flow_factor;
use crate::physics::valve::SpoolStep;
use crate::real::Real;
use crate::sample::Sample;
use crate::signal::oscillation::LoopWatch;
use crate::signal::{Conditioned, SampleChecker};
use crate::status::{health, Event, Events, Status, Verdict};

/// A step longer than this many nominal periods is a data gap.
pub const GAP_PERIODS: f64 = 5.0;
/// Relative change of the step length that recomputes the spool maps.
const SPOOL_DT_TOLERANCE: f64 = 1e-6;

/// Derived per-installation constants.
#[derive(Clone, Debug)]
struct Config<T> {
    /// Scale of each reading's σ into the filter's units: position (m →
    /// X_REF), pressures (bar → P_REF).
    r_scale: [T; NZ],
    noise: ProcessNoise<T>,
    p0: [T; NB],
    leak_prior_sd: T,
    substeps: u32,
    period_s: f64,
    /// GAP_PERIODS · period_s, as its bits (`elapsed::exceeds`): a longer
    /// step is a data gap.
    gap_bits: u64,
    pressure_lag_s: T,
    warm_up_s: f64,
    /// Lowest leak coefficients (internal, external), l/min at 10 bar.
    leak_floor: [T; 2],
    /// Lowest laminar-leakage deviation (scaled state).
    laminar_floor: T,
    /// Stroke in the scaled position unit.
    stroke: T,
    /// Valve command band of the holding region: null ± dead zone.
    hold_band: (f32, f32),
}

/// Piston speed (from the position reading), m/s, below which the piston
/// is at rest: the sample belongs to the holding region whatever the
/// valve command (0.2 l/min of piston flow at the thesis rig's piston area).
const HOLD_SPEED_M_S: f64 = 1e-3;

/// The leak monitor for one cylinder.
#[derive(Clone, Debug)]
pub struct Monitor<T: Real = f32> {
    plant: Plant<T>,
    cfg: Config<T>,
    checker: SampleChecker,
    bank: Option<Bank<T>>,
    /// The bank's plant states are stale (a gap in the samples): the next
    /// valid sample restarts them and keeps what the filters learned.
    stale: bool,
    last_t: Option<f64>,
    /// The steps the spool maps are for: within ±1e-6 of the step they
    /// were computed for; a step outside needs new spool maps.
    spool_dt_window: Window,
    spool_sub: SpoolStep<T>,
    spool_dt: SpoolStep<T>,
    /// Time since the filters (re)started, s, counted only until the
    /// warm-up is over (an f64 add and compare the MCU emulates in software).
    since_start_s: f64,
    warming: bool,
    decision: Decision<T>,
    temp_c: Option<f32>,
    laminar_factor: T,
    /// Operating region of the last sample for the baseline and the alarm
    /// level (`operating_region`, or holding while the piston is at rest).
    region: usize,
    /// The piston speed from the position reading alone.
    speed: PistonSpeed<T>,
    /// Whether the machine's position loop hunts.
    loop_watch: LoopWatch<T>,
    /// Inputs of the previous sample: they drove the plant until this one.
    held: Option<HeldInputs>,
    /// How quasi-steady the plant is: the learning weight of the parameter
    /// states and the weight of each sample as evidence (see `quiet`).
    quiet: EvidenceWeight<T>,
    fluid_ref: crate::params::Fluid,
    /// Innovation statistics that size the measurement noise.
    matching: NoiseMatch<T>,
}

impl<T: Real> Monitor<T> {
    /// A monitor for the installation described by `params`.
    pub fn new(params: &Params) -> Result<Self, ParamError> {
        params.validate()?;
        let plant = Plant::new(params);
        let f = &params.filter;
        let sx = params.sensors.position_noise_m / X_REF;
        let sp = params.sensors.pressure_noise_bar * BAR / P_REF;
        let leakage = &params.leakage;
        let cfg = Config {
            r_scale: [T::c(1.0 / X_REF), T::c(BAR / P_REF), T::c(BAR / P_REF)],
            noise: ProcessNoise {
                base: [
                    T::c(f.q_position),
                    T::c(f.q_velocity),
                    T::c(f.q_spool),
                    T::c(f.q_spool_rate),
                    T::c(f.q_pressure),
                    T::c(f.q_pressure),
                    T::c(f.q_gain / (GAIN_REF * GAIN_REF)),
                    T::c(f.q_gain / (GAIN_REF * GAIN_REF)),
                    T::c(f.q_laminar / (LAMINAR_REF * LAMINAR_REF)),
                ],
                leak: T::c(f.q_leak),
            },
            // Start: position and pressures from the readings, velocity 0,
            // spool at the command, valve as parameterised.
            p0: [
                T::c(sx * sx * 4.0),
                T::c(0.01),
                T::c(0.0025),
                T::c(0.01),
                T::c(4.0 * sp * sp),
                T::c(4.0 * sp * sp),
                T::c(sq(f.gain_prior / GAIN_REF)),
                T::c(sq(f.gain_prior / GAIN_REF)),
                T::c(sq(f.laminar_prior / LAMINAR_REF)),
            ],
            leak_prior_sd: T::c(f.leak_prior_lpm),
            substeps: f.substeps,
            period_s: f.sample_period_s,
            gap_bits: (GAP_PERIODS * f.sample_period_s).to_bits(),
            pressure_lag_s: T::c(params.sensors.pressure_lag_s),
            warm_up_s: f.warm_up_s,
            // l/min per bar → l/min at 10 bar.
            leak_floor: [
                T::c(-10.0 * leakage.seal_lpm_per_bar),
                T::c(-10.0 * leakage.external_lpm_per_bar.max(0.0)),
            ],
            // factor = 1 + deviation · LAMINAR_REF ≥ laminar_factor_min.
            laminar_floor: T::c((f.laminar_factor_min - 1.0) / LAMINAR_REF),
            stroke: T::c(params.cylinder.stroke_m / X_REF),
            hold_band: params.hold_band(),
        };
        let period = f.sample_period_s;
        Ok(Self {
            spool_sub: plant.spool_step(period / f.substeps as f64),
            spool_dt: plant.spool_step(period),
            spool_dt_window: Window::around(period, SPOOL_DT_TOLERANCE * period),
            plant,
            cfg,
            checker: SampleChecker::new(params),
            bank: None,
            stale: false,
            last_t: None,
            since_start_s: 0.0,
            warming: true,
            decision: Decision::new(params),
            temp_c: None,
            laminar_factor: T::ONE,
            held: None,
            region: HOLDING_REGION,
            speed: PistonSpeed::default(),
            loop_watch: LoopWatch::default(),
            quiet: EvidenceWeight::new(Quietness::new(
                f.quiet_rate_bar_s,
                f.quiet_flow_lpm,
                f.gain_learning_flow_lpm,
                f.learning_recovery_s,
            )),
            fluid_ref: params.fluid.clone(),
            matching: NoiseMatch::default(),
        })
    }

    /// An operator's acknowledgement of the latched leak alarm (the CAN
    /// command, a button). Whether it is accepted is the decision layer's
    /// acknowledge policy (`decision::latch`); when it is, the latch is
    /// cleared, and a leak that is still there is raised again after the
    /// debounce time. Apply it between two [`step`](Self::step)s: it is
    /// dated with the last sample's time. An accepted one keeps the
    /// verdict from `healthy` (and so the relay off) until the monitor
    /// has concluded healthy for `acknowledge::EVIDENCE_MS`
    /// (`health::ACK_EVIDENCE` meanwhile).
    pub fn acknowledge(&mut self) -> AckOutcome {
        let t_ms = self.last_t.map_or(0, crate::acknowledge::sample_ms);
        self.decision.acknowledge(t_ms)
    }

    /// The acknowledge policy with other times than the documented ones
    /// (`decision::acknowledge::AckTiming`), for tests and studies (e.g.
    /// the zero timing, which accepts every acknowledge at once as before
    /// the policy existed). The firmware never calls this.
    pub fn with_ack_timing(mut self, timing: crate::acknowledge::AckTiming) -> Self {
        self.decision.set_ack_timing(timing);
        self
    }

    /// Process one sample.
    pub fn step(&mut self, sample: &Sample) -> Status {
        let mut events = Events::new();
        let mut flags = 0u16;
        // Time step: a non-increasing time is ignored, a gap restarts.
        let dt = match self.last_t {
            Some(t0) => elapsed(t0, sample.t_s),
            None => Some(self.cfg.period_s),
        };
        // The time the readings were seen to hold, for the frozen-reading
        // test: none before the first or at an ignored sample, at most
        // 0.1 s across a gap.
        let held_s = match (self.last_t, dt) {
            // (`Real::min`: `f32::min` is a call on the MCU; dt is finite.)
            (Some(_), Some(dt)) => Real::min(dt as f32, 0.1),
            _ => 0.0,
        };
        let checked = self.checker.check(sample, held_s, &mut events);
        if checked.outlier {
            flags |= health::OUTLIER;
        }
        let Some(dt) = dt else {
            flags |= health::TIME_NOT_INCREASING;
            return self.status(sample.t_s, checked.faulted, flags, events);
        };
        self.last_t = Some(sample.t_s);
        if exceeds(dt, self.cfg.gap_bits) && self.bank.is_some() {
            // The plant moved on in the gap; its valve and leaks did not.
            self.stale = true;
            self.held = None;
            self.checker.break_pressure_sequence();
            self.loop_watch.break_window();
            flags |= health::DATA_GAP;
            let _ = events.push(Event::DataGap);
        }

        let Some(c) = checked.values else {
            // A required channel is faulted: no estimation. Filters restart
            // from fresh readings once every channel is back (what they
            // learned may hold a faulty reading: it goes too).
            self.bank = None;
            self.held = None;
            self.checker.break_pressure_sequence();
            self.loop_watch.break_window();
            return self.status(
                sample.t_s,
                checked.faulted,
                flags | health::SENSOR_FAULT,
                events,
            );
        };
        self.update_temperature(c.temp_oil_c);
        if self.loop_watch.update(T::from_f32(held_s), &c) {
            flags |= health::LOOP_OSCILLATING;
        }
        self.checker.observe_pressures(c.p_piston_bar, c.p_rod_bar);
        let suspect = checked.suspect != 0;

        let m = self.measurement(&c);
        // The command (and the port pressures) read at the previous sample
        // were held over the interval that ends now: the recorded command is
        // the one issued at its sample instant.
        let now = HeldInputs {
            p_supply_bar: c.p_supply_bar,
            p_tank_bar: c.p_tank_bar,
            u_valve: c.u_valve,
        };
        let held = self.held.replace(now).unwrap_or(now);
        let bank = match self.bank.as_mut() {
            Some(bank) if !self.stale => bank,
            _ => {
                self.start_filters(&m, c.u_valve);
                return self.status(
                    sample.t_s,
                    checked.faulted,
                    flags | health::WARMING_UP,
                    events,
                );
            }
        };

        // dt > 0 here (`elapsed`, or the nominal period).
        if !self.spool_dt_window.contains(dt) {
            self.spool_dt_window = Window::around(dt, SPOOL_DT_TOLERANCE * dt);
            self.spool_dt = self.plant.spool_step(dt);
            self.spool_sub = self.plant.spool_step(dt / self.cfg.substeps as f64);
        }
        // Pinned with the valve open (an end stop): no leak evidence, and
        // nothing for the leak states or valve gains to learn.
        let command_region = operating_region(c.u_valve, self.cfg.hold_band);
        let pinned = quiet::pinned(&c, command_region);
        // For the baseline and the alarm level a piston at rest holds,
        // whatever the command: the loop that holds it against a leak
        // opens the valve past the dead zone to feed the leak, and a
        // move's floor there would hide the leak it feeds.
        let speed_m_s = self.speed.update(T::from_f32(c.x_piston_m), T::c(dt));
        let at_rest = speed_m_s.abs() < T::c(HOLD_SPEED_M_S);
        let region = if at_rest {
            HOLDING_REGION
        } else {
            command_region
        };
        self.region = region;
        // At rest the `both` filter's view of the plant counts while its
        // model describes it (its mean NIS from the last sample).
        self.quiet.judge_both(
            region == HOLDING_REGION,
            self.decision.mean_nis(Hypothesis::Both),
        );
        let no_evidence = suspect || pinned;
        let u_valve = T::from_f32(held.u_valve);
        let ctx = StepContext {
            inputs: Inputs {
                p_supply_pa: T::from_f32(held.p_supply_bar) * T::c(BAR),
                p_tank_pa: T::from_f32(held.p_tank_bar) * T::c(BAR),
                u_valve,
                laminar_factor: self.laminar_factor,
                land: self.plant.land_leak(u_valve),
                hold_share: self.plant.hold_share(u_valve),
                rod: self.plant.rod_edges(u_valve),
                // At the `both` filter's estimate: it is never reset
                // alone for long, and any filter's is as good.
                tables: self.plant.tabulated(&bank.plant_state(Hypothesis::Both)),
            },
            step: Step {
                dt: T::c(dt),
                substeps: self.cfg.substeps,
                spool: self.spool_sub,
            },
            spool_dt: self.spool_dt,
            pressure_lag_s: self.cfg.pressure_lag_s,
            // A possibly frozen reading teaches the leak states nothing.
            learning: if no_evidence {
                T::ZERO
            } else {
                self.quiet.weight()
            },
            gain_learning: if no_evidence {
                T::ZERO
            } else {
                self.quiet.gain_weight()
            },
            leak_floor: self.cfg.leak_floor,
            laminar_floor: self.cfg.laminar_floor,
            stroke: self.cfg.stroke,
        };
        let mut ok: BankOutput<T> = [None; 4];
        bank.step(&self.plant, &ctx, &self.cfg.noise, &m, &mut ok);
        for (h, out) in Hypothesis::ALL.into_iter().zip(&ok) {
            if out.is_none() {
                // The filter failed numerically: restart it from the
                // readings.
                let s0 = initial_state(&m, c.u_valve);
                bank.reset(h, &s0, &self.cfg.p0, self.cfg.leak_prior_sd);
                flags |= health::FILTER_RESET;
                let _ = events.push(Event::FilterReset(h));
            }
        }
        if let Some(b) = &ok[Hypothesis::Both as usize] {
            self.matching
                .update(&b.innovation_sq, &b.predicted_var, &m.r, T::c(dt));
        }
        let mut chamber_dp_bar = T::ZERO;
        let bar = T::c(P_REF / BAR);
        let views = [
            (Hypothesis::Healthy, &mut self.quiet.healthy),
            (Hypothesis::Both, &mut self.quiet.both),
        ];
        for (h, view) in views {
            if let Some(out) = &ok[h as usize] {
                let s = bank.plant_state(h);
                if h == Hypothesis::Healthy {
                    chamber_dp_bar = (s[4] - s[5]) * bar;
                }
                view.update(
                    s[4] * bar,
                    s[5] * bar,
                    T::from_f32(c.u_valve),
                    out.valve_flow_lpm,
                    T::c(dt),
                );
            }
        }
        if self.warming {
            self.since_start_s += dt;
            self.warming = self.since_start_s < self.cfg.warm_up_s;
        }
        let warming = self.warming;
        if warming {
            flags |= health::WARMING_UP;
        }
        // A hunting loop is no evidence either way: the model's
        // quasi-steady valve and load do not describe its swings, and the
        // leak states take in what they miss (three of the survey sets'
        // false alarms came with the flag set).
        let counts = !warming
            && !no_evidence
            && flags & (health::FILTER_RESET | health::LOOP_OSCILLATING) == 0;
        let facts = SampleFacts {
            dt: T::c(dt),
            weight: self.quiet.weight(),
            valid: counts,
            observable: !pinned,
            region,
            at_rest,
            t_s: sample.t_s,
            valve_gains_learned: bank.valve_gains_learned(GAIN_SETTLED_SD),
            u_valve,
            chamber_dp_bar,
        };
        flags |= self.decision.update(&ok, facts, &mut events);
        self.status(sample.t_s, checked.faulted, flags, events)
    }

    /// (Re)start the filters from the readings `m` and the command
    /// `u_valve`: a new bank, or after a data gap the stale bank's plant
    /// states only (what the filters learned stays); the warm-up and the
    /// evidence start afresh.
    fn start_filters(&mut self, m: &Measurement<T>, u_valve: f32) {
        let s0 = initial_state(m, u_valve);
        match self.bank.as_mut() {
            Some(stale) => stale.restart_plant(&s0, &self.cfg.p0),
            None => self.bank = Some(Bank::new(&s0, &self.cfg.p0, self.cfg.leak_prior_sd)),
        }
        self.stale = false;
        self.since_start_s = 0.0;
        self.warming = true;
        self.decision.restart();
        self.quiet.restart();
        self.speed.restart();
        self.matching.restart();
    }

    fn update_temperature(&mut self, temp: Option<f32>) {
        // exp() only when the temperature moves by more than 0.1 °C.
        match (temp, self.temp_c) {
            (Some(t), Some(last)) if (t - last).abs() < 0.1 => {}
            (Some(t), _) => {
                self.temp_c = Some(t);
                self.laminar_factor = T::c(laminar_flow_factor(&self.fluid_ref, t as f64));
            }
            (None, _) => {}
        }
    }

    fn measurement(&self, c: &Conditioned) -> Measurement<T> {
        // Each reading's noise as estimated from the data (`signal::noise`).
        let sigma = self.checker.noise_sigma();
        let white: [T; NZ] = core::array::from_fn(|k| {
            let s = T::from_f32(sigma[k]) * self.cfg.r_scale[k];
            s * s
        });
        // What the innovations show beyond the white noise (`consistency`).
        let r = self.matching.matched(&white);
        Measurement {
            z: [
                T::from_f32(c.x_piston_m) / T::c(X_REF),
                T::from_f32(c.p_piston_bar) * T::c(BAR / P_REF),
                T::from_f32(c.p_rod_bar) * T::c(BAR / P_REF),
            ],
            r,
        }
    }

    fn status(&mut self, t_s: f64, faulted: u8, mut flags: u16, events: Events) -> Status {
        if faulted != 0 {
            flags |= health::SENSOR_FAULT;
        }
        flags |= self.decision.flags();
        // An optional channel's fault (the oil temperature, where the
        // filters estimate the viscosity themselves) is reported in flags
        // and events but does not take the verdict away. A required one's does.
        let required_fault = faulted & self.checker.required() != 0;
        // `healthy` is a claim that needs evidence (`Decision::conclusive`).
        let unsettled = health::WARMING_UP
            | health::TIME_NOT_INCREASING
            | health::FILTER_RESET
            | health::DATA_GAP;
        if self.bank.is_none() || flags & unsettled != 0 || !self.decision.conclusive() {
            flags |= health::INCONCLUSIVE;
        }
        let latched = self.decision.latched();
        let mut verdict = if required_fault {
            Verdict::SensorFault
        } else if !latched.is_empty() {
            Verdict::of_leaks(latched)
        } else if flags & health::INCONCLUSIVE != 0 {
            Verdict::Inconclusive
        } else {
            Verdict::Healthy
        };
        // After an accepted acknowledge, `healthy` (and the relay) waits
        // for the evidence period of conclusive healthy verdicts.
        let held = self.decision.ack_evidence(t_s, verdict == Verdict::Healthy);
        if held {
            flags |= health::ACK_EVIDENCE;
            if verdict == Verdict::Healthy {
                verdict = Verdict::Inconclusive;
                flags |= health::INCONCLUSIVE;
            }
        }
        let d = &self.decision;
        let estimating = self.bank.is_some() && flags & health::WARMING_UP == 0;
        let (size, sd) = d.leak_flows();
        let detect = d.detection_flows();
        let level = d.alarm_levels();
        Status {
            t_s,
            verdict,
            latched,
            leading: d.leading(),
            leak_internal_lpm: estimating.then_some(size.internal()),
            leak_external_lpm: estimating.then_some(size.external()),
            leak_internal_sd_lpm: estimating.then_some(sd.internal()),
            leak_external_sd_lpm: estimating.then_some(sd.external()),
            detect_internal_lpm: estimating.then_some(detect.internal()),
            detect_external_lpm: estimating.then_some(detect.external()),
            alarm_level_lpm: [level.internal(), level.external()],
            valve_gain_deviation: d.valve(),
            evidence_weight: self.quiet.weight().to_f32(),
            evidence: d.evidence(),
            faulted_channels: faulted,
            health: flags,
            noise_sigma: self.checker.noise_sigma(),
            events,
        }
    }

    /// The operating region of the last sample for the baseline and the
    /// alarm level: 0 retracting, 1 holding, 2 extending
    /// (`params::operating_region`; holding while the piston is at rest).
    pub fn region(&self) -> usize {
        self.region
    }

    /// Every filter's state, in bank order (healthy, internal, external,
    /// both), for diagnostics, calibration and tests; `None` while the bank
    /// is not running.
    pub fn filter_states(&self) -> Option<[FilterState<'_, T>; 4]> {
        let b = self.bank.as_ref()?;
        Some([
            FilterState::of(&b.healthy),
            FilterState::of(&b.internal),
            FilterState::of(&b.external),
            FilterState::of(&b.both),
        ])
    }
}

/// One filter's state, read-only.
#[derive(Clone, Copy, Debug)]
pub struct FilterState<'a, T> {
    /// The leak hypothesis this filter runs.
    pub hypothesis: Hypothesis,
    /// State estimate (scaled units; leak states in l/min at 10 bar).
    pub x: &'a [T],
    /// Covariance, `x.len()`² entries, column-major.
    pub p: &'a [T],
    /// The internal leak state, if the hypothesis has one (l/min at 10 bar).
    pub leak_internal: Option<T>,
    /// The external leak state, if the hypothesis has one (l/min at 10 bar).
    pub leak_external: Option<T>,
}

impl<'a, T: Real> FilterState<'a, T> {
    /// The healthy laminar-leakage factor the filter estimates, relative
    /// to what the temperature gives (1: as the parameters say).
    pub fn laminar_factor(&self) -> T {
        T::ONE + self.x[LAMINAR] * T::c(LAMINAR_REF)
    }

    fn of<const N: usize>(f: &'a HypothesisFilter<T, N>) -> Self {
        Self {
            hypothesis: f.hypothesis,
            x: f.ekf.x.as_slice(),
            p: f.ekf.p.as_slice(),
            leak_internal: internal_index(f.hypothesis).map(|i| f.ekf.x[i]),
            leak_external: external_index(f.hypothesis).map(|i| f.ekf.x[i]),
        }
    }
}

fn sq(v: f64) -> f64 {
    v * v
}

/// Inputs held over a sample interval.
#[derive(Clone, Copy, Debug, PartialEq)]
struct HeldInputs {
    p_supply_bar: f32,
    p_tank_bar: f32,
    u_valve: f32,
}

/// Filter start: position and pressures from the readings, at rest, spool
/// at the command.
fn initial_state<T: Real>(m: &Measurement<T>, u_valve: f32) -> [T; NX] {
    let [x, p3, p4] = m.z;
    [x, T::ZERO, T::from_f32(u_valve), T::ZERO, p3, p4]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::good_sample;

    /// A monitor whose retracting region alarms external leaks only from
    /// 0.68 l/min, run for 2 s with the command just past the dead zone
    /// toward retracting and the piston at `speed_m_s` from mid-stroke;
    /// returns the last sample's region and external alarm level.
    fn region_and_level_at(speed_m_s: f64) -> (usize, f32) {
        let mut p = Params::nominal();
        p.baseline.region_floor_external_lpm = [0.68, 0.0, 0.0];
        let u = p.hold_band().0 - 0.005;
        let mut m = Monitor::<f64>::new(&p).unwrap();
        let mut level = f32::NAN;
        for i in 0..2000 {
            let t = i as f64 * 1e-3;
            let mut s = good_sample(t);
            s.u_valve = Some(u);
            // Inside the 0.18 m stroke: a reading beyond it is a sensor
            // fault, and a faulted sample keeps the region it had.
            s.x_piston_m = Some((0.1 - speed_m_s * t) as f32);
            let status = m.step(&s);
            assert_eq!(status.faulted_channels, 0, "at {t} s");
            level = status.alarm_level_lpm[1];
        }
        (m.region(), level)
    }

    /// Learned states per filter: nuisance and leak (from `NX` on), up to
    /// five, zero-padded.
    type Learned = [([f64; 5], [[f64; 5]; 5]); 4];

    /// Every filter's nuisance and leak states and their covariance block.
    fn learned(m: &Monitor<f64>) -> Learned {
        let states = m.filter_states().expect("the bank runs");
        core::array::from_fn(|h| {
            let f = &states[h];
            let n = f.x.len();
            let mut x = [0.0; 5];
            let mut p = [[0.0; 5]; 5];
            for j in NX..n {
                x[j - NX] = f.x[j];
                for i in NX..n {
                    p[j - NX][i - NX] = f.p[j * n + i];
                }
            }
            (x, p)
        })
    }

    #[test]
    fn a_gap_restarts_the_plant_states_and_keeps_what_the_filters_learned() {
        let p = Params::nominal();
        let mut m = Monitor::<f64>::new(&p).unwrap();
        // At rest, with transmitter noise (readings that never change are
        // frozen: a sensor fault).
        let mut rng = crate::testutil::Lcg::new(7);
        let mut noisy = |t: f64, x: f32| {
            let mut s = good_sample(t);
            let mut jitter = |v: Option<f32>, sd: f64| v.map(|v| v + (sd * rng.gaussian()) as f32);
            s.p_supply_bar = jitter(s.p_supply_bar, 0.05);
            s.p_piston_bar = jitter(s.p_piston_bar, 0.05);
            s.p_rod_bar = jitter(s.p_rod_bar, 0.05);
            s.p_tank_bar = jitter(s.p_tank_bar, 0.02);
            s.x_piston_m = jitter(Some(x), 2e-5);
            s
        };
        for i in 0..3000 {
            let status = m.step(&noisy(i as f64 * 1e-3, 0.04));
            assert_eq!(status.faulted_channels, 0, "at sample {i}");
        }
        let before = learned(&m);
        // The leak states learned something: their variance fell below
        // the prior's a restart from scratch would give them.
        let prior = sq(p.filter.leak_prior_lpm);
        let external_var = before[3].1[4][4];
        assert!(external_var < 0.5 * prior, "{external_var} vs {prior}");
        // 2 s without samples.
        let status = m.step(&noisy(5.0, 0.0401));
        assert_ne!(status.health & health::DATA_GAP, 0);
        assert_eq!(learned(&m), before);
        let both = &m.filter_states().unwrap()[3];
        let n = both.x.len();
        assert!(
            (both.x[0] - 0.0401 / X_REF).abs() < 1e-3,
            "position restarted from the reading"
        );
        for j in 0..NX {
            for i in 0..n {
                if i != j {
                    assert_eq!(both.p[j * n + i], 0.0, "P[{i},{j}]");
                }
            }
        }
    }

    #[test]
    fn a_piston_at_rest_is_judged_at_the_holds_level_whatever_the_command() {
        // The loop holding a piston against an external leak opens the
        // valve past the dead zone to feed it: still a hold.
        let (region, level) = region_and_level_at(0.0);
        assert_eq!(region, HOLDING_REGION);
        assert!(level < 0.1, "level at rest {level}");
        // A retraction at 20 mm/s with the same command is a move.
        let (region, level) = region_and_level_at(0.02);
        assert_eq!(region, 0);
        assert!((level - 0.68).abs() < 1e-3, "level moving {level}");
    }
}
