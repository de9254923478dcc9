//! A run: leak calibration (repeated physics passes), the measurement
//! chain, and the faults.

use serde::{Deserialize, Serialize};

use crate::leak::LeakLaw;
use crate::physics::{self, RunPhysics, Sample, AT_STOP_M};
use crate::rng::{stream, Rand};
use crate::scenario::Profile;
use crate::{faults, Row, Run, Truth};

/// Relative tolerance of the leak calibration.
const LEAK_TOLERANCE: f64 = 0.025;
/// Most physics passes for the leak calibration.
const MAX_PASSES: u32 = 6;

/// How a run's leaks came out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    /// Flow law of both leaks.
    pub law: LeakLaw,
    /// Internal leak coefficient, l/min at the law's reference drop
    /// (see [`LeakLaw::shape`]).
    pub internal_coeff_lpm: f64,
    /// External leak coefficient, l/min at the reference drop.
    pub external_coeff_lpm: f64,
    /// Realised mean internal leak after onset, l/min (signed mean, or the
    /// mean magnitude when `internal_by_magnitude`).
    pub realised_internal_lpm: f64,
    /// Realised mean external leak after onset, l/min (as above).
    pub realised_external_lpm: f64,
    /// The internal leak's signed mean was too small (the pressure across
    /// it changes sign): its mean magnitude was matched.
    pub internal_by_magnitude: bool,
    /// As `internal_by_magnitude`, for the external leak.
    pub external_by_magnitude: bool,
    /// Physics passes used.
    pub passes: u32,
    /// Oil temperature drift of the run, °C/s.
    pub temp_rate_c_s: f64,
}

/// The leak flow law of `run` (drawn from its noise seed).
pub fn leak_law(run: &Run) -> LeakLaw {
    LeakLaw::random(&mut Rand::new(run.noise_seed, stream::RUN_PHYSICS))
}

/// Oil temperature drift of `run`, °C/s (±3 °C per 10 min).
fn temp_rate(run: &Run) -> f64 {
    Rand::new(run.noise_seed, stream::RUN_PHYSICS + 1).uniform(-3.0, 3.0) / 600.0
}

/// Realised mean after onset: (value, by magnitude).
fn realised(
    samples: &[Sample],
    onset_s: f64,
    dt: f64,
    f: impl Fn(&Sample) -> f64,
) -> Option<(f64, bool)> {
    let k0 = (onset_s / dt).ceil().max(0.0) as usize;
    let tail = samples.get(k0..).filter(|s| !s.is_empty())?;
    let n = tail.len() as f64;
    let signed = tail.iter().map(&f).sum::<f64>() / n;
    let abs = tail.iter().map(|s| f(s).abs()).sum::<f64>() / n;
    if signed >= 0.3 * abs {
        Some((signed, false))
    } else {
        Some((abs, true))
    }
}

/// Simulate `run`: the rows and a report on its leaks.
pub fn simulate_with_report(run: &Run) -> (Vec<Row>, RunReport) {
    let motion = Motion::of(run);
    (measure(run, &motion.samples), motion.report)
}

/// Simulate `run`, taking its motion from `last` when `last` moved the
/// same way (a run that differs only in its faults or the temperature
/// column: the same physics, other readings), and leaving `run`'s motion
/// there for the next. The rows are those of [`crate::simulate`].
pub fn simulate_reusing(run: &Run, last: &mut Option<Motion>) -> Vec<Row> {
    let motion = match last.take() {
        Some(m) if m.fits(run) => m,
        _ => Motion::of(run),
    };
    let rows = measure(run, &motion.samples);
    *last = Some(motion);
    rows
}

/// What a run's physics gave, before the sensors: the true motion and how
/// its leaks came out.
#[derive(Clone, Debug)]
pub struct Motion {
    /// The run it belongs to, less what only the readings depend on.
    physics_of: Run,
    samples: Vec<Sample>,
    report: RunReport,
}

impl Motion {
    /// Whether `run` moves as this motion's run does.
    pub fn fits(&self, run: &Run) -> bool {
        self.physics_of == physics_part(run)
    }

    /// The physics passes of `run`.
    fn of(run: &Run) -> Self {
        let rig = &run.rig;
        let profile = Profile::new(&run.scenario);
        let law = leak_law(run);
        let dt = 1.0 / run.sample_rate_hz;
        let mut p = RunPhysics {
            law,
            c_int: 0.0,
            c_ext: 0.0,
            onset_s: run.leak.onset_s,
            temp_rate_c_s: temp_rate(run),
            sample_rate_hz: run.sample_rate_hz,
            quiet_step: true,
        };
        let targets = [run.leak.internal_lpm, run.leak.external_lpm];
        // First guess: the law at a third of the supply pressure.
        let fluidity =
            rig.fluid.viscosity_cst(crate::REFERENCE_TEMP_C) / rig.fluid.viscosity_cst(rig.temp_c);
        let unit = law.shape(0.3 * rig.supply_bar, fluidity);
        p.c_int = targets[0] / unit;
        p.c_ext = targets[1] / unit;
        let mut report = RunReport {
            law,
            internal_coeff_lpm: 0.0,
            external_coeff_lpm: 0.0,
            realised_internal_lpm: 0.0,
            realised_external_lpm: 0.0,
            internal_by_magnitude: false,
            external_by_magnitude: false,
            passes: 0,
            temp_rate_c_s: p.temp_rate_c_s,
        };
        let mut previous: [Option<(f64, f64)>; 2] = [None, None];
        let mut onset = None;
        let samples = loop {
            let (samples, at_onset) = physics::run(rig, profile.clone(), &p, onset.as_ref());
            onset = onset.or(at_onset);
            report.passes += 1;
            report.internal_coeff_lpm = p.c_int;
            report.external_coeff_lpm = p.c_ext;
            let ri = realised(&samples, p.onset_s, dt, |s| s.q_int);
            let re = realised(&samples, p.onset_s, dt, |s| s.q_ext);
            let mut done = true;
            for (i, (target, got, c)) in [
                (targets[0], ri, &mut p.c_int),
                (targets[1], re, &mut p.c_ext),
            ]
            .into_iter()
            .enumerate()
            {
                if let (true, Some((value, _))) = (target != 0.0, got) {
                    if (value / target - 1.0).abs() > LEAK_TOLERANCE {
                        done = false;
                        let next = next_coefficient(*c, value, target, previous[i]);
                        previous[i] = Some((*c, value));
                        *c = next;
                    }
                }
            }
            if let Some((v, m)) = ri {
                report.realised_internal_lpm = v;
                report.internal_by_magnitude = m;
            }
            if let Some((v, m)) = re {
                report.realised_external_lpm = v;
                report.external_by_magnitude = m;
            }
            if done || report.passes >= MAX_PASSES {
                break samples;
            }
        };
        Self {
            physics_of: physics_part(run),
            samples,
            report,
        }
    }
}

/// The next pass's leak coefficient after coefficient `c` realised `value`
/// (l/min) against `target`, with `previous` (coefficient, value) of the
/// pass before. Realised ≈ k·c^α: α from the last two passes (1 at first;
/// the leak moves the pressures it depends on).
fn next_coefficient(c: f64, value: f64, target: f64, previous: Option<(f64, f64)>) -> f64 {
    let alpha = match previous {
        Some((c0, v0)) if v0 > 0.0 && value > 0.0 && c0 != c => {
            ((value / v0).ln() / (c / c0).ln()).clamp(0.3, 2.0)
        }
        _ => 1.0,
    };
    c * if value.abs() > 1e-9 {
        (target / value).powf(1.0 / alpha).clamp(0.05, 20.0)
    } else {
        10.0
    }
}

/// `run` less what only the readings depend on: its faults and whether the
/// temperature column is written. (Everything else may move the plant: the
/// noise seed also draws the leak law and the temperature drift.)
fn physics_part(run: &Run) -> Run {
    Run {
        faults: Vec::new(),
        temp_column: false,
        ..run.clone()
    }
}

/// The recording of `samples` through the rig's sensors, with faults.
fn measure(run: &Run, samples: &[Sample]) -> Vec<Row> {
    let rig = &run.rig;
    let sens = &rig.sensors;
    let dt = 1.0 / run.sample_rate_hz;
    let series = |f: fn(&Sample) -> f64| samples.iter().map(f).collect::<Vec<f64>>();
    let ripple = series(|s| s.ripple);
    let truth_p = [
        series(|s| s.ps),
        series(|s| s.pa),
        series(|s| s.pb),
        series(|s| s.pt),
    ];
    let mut p_read = Vec::with_capacity(4);
    for (i, ch) in sens.pressure.iter().enumerate() {
        let mut r = Rand::new(run.noise_seed, stream::NOISE + i as u64);
        p_read.push(ch.measure(&truth_p[i], &ripple, dt, &mut r));
    }
    let x_read = {
        let mut r = Rand::new(run.noise_seed, stream::NOISE + 4);
        sens.position.measure(&series(|s| s.x), &ripple, dt, &mut r)
    };
    let mut rt = Rand::new(run.noise_seed, stream::NOISE + 5);
    let stroke = rig.cylinder.stroke_m;
    let mut rows: Vec<Row> = samples
        .iter()
        .enumerate()
        .map(|(k, s)| Row {
            t: k as f64 * dt,
            p_supply: Some(p_read[0][k]),
            p_piston: Some(p_read[1][k]),
            p_rod: Some(p_read[2][k]),
            p_tank: Some(p_read[3][k]),
            x_piston: Some(x_read[k]),
            u_valve: Some(s.u + sens.valve_command_offset),
            temp_oil: run.temp_column.then(|| {
                ((s.temp_c + sens.temperature_sigma_c * rt.normal()) * 10.0).round() / 10.0
            }),
            truth: Truth {
                internal_lpm: s.q_int,
                external_lpm: s.q_ext,
                x_m: s.x,
                v_m_s: s.v,
                p_chambers_bar: [s.pa, s.pb],
                at_end_stop: s.x <= AT_STOP_M || s.x >= stroke - AT_STOP_M,
                p_supply_bar: s.ps,
                p_tank_bar: s.pt,
                spool: s.spool,
                temp_c: s.temp_c,
                x_ref_m: s.x_ref,
            },
        })
        .collect();
    faults::apply(&mut rows, &run.faults, dt, run.noise_seed);
    rows
}
