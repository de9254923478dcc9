//! The procedure: noise, the validation fit on two thirds, the held-out check, the refit.

use super::fit::{self, Motion};
use super::steps::{fit_plant, missing_motion, HeldOut};
use super::{
    check, noise, Calibration, CalibrationError, HoldLand, Mechanics, Oscillation, FLOOR_MARGIN,
    MAX_DETECTION_FLOOR_LPM, MAX_REFIT_GAIN_CHANGE_PCT, MAX_VALIDATION_NIS, MIN_DURATION_S,
    MIN_EVIDENCE_FRACTION, MIN_STEADY_FIT_S, MIN_STEADY_S, WARN_VALVE_MISFIT_FRACTION,
};
use monitor::params::{EXTENDING_REGION, RETRACTING_REGION};
use monitor::status::VALVE_GAIN_MISFIT;
use monitor::{Params, Sample};

/// The calibration, with the valve and load regressions judged as
/// `mechanics` says.
pub(super) fn calibrate_with(
    samples: &[Sample],
    start: &Params,
    mechanics: Mechanics,
    holds: HoldLand,
    oscillation: Option<&Oscillation>,
) -> Result<Calibration, CalibrationError> {
    start.validate().map_err(CalibrationError::Params)?;
    // What calibration fits and writes describes this installation: it is
    // not provisional, whatever set it started from.
    let mut own = start.clone();
    own.baseline.provisional_floor_lpm = 0.0;
    let start = &own;
    let (t0, duration) = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => (a.t_s, b.t_s - a.t_s),
        _ => (0.0, 0.0),
    };
    if duration < MIN_DURATION_S {
        return Err(CalibrationError::TooShort(duration, MIN_DURATION_S));
    }
    let mut cal = Calibration {
        params: start.clone(),
        duration_s: duration,
        ..Calibration::default()
    };
    let before = check::run(samples, start)?;
    cal.nis_before = before.healthy_nis;
    cal.leak_before_lpm = before.detect_max_lpm;

    // 0. Noise, from the whole recording (nothing to over-fit).
    cal.noise = noise::estimate(samples);
    let mut p = start.clone();
    let pressure = cal.noise[1..=2]
        .iter()
        .map(|c| c.floored().hypot(c.coloured))
        .fold(0.0, f64::max);
    let position = cal.noise[4].floored();
    if pressure > 0.0 && position > 0.0 {
        p.sensors.pressure_noise_bar = pressure;
        p.sensors.position_noise_m = position;
    } else {
        cal.warnings
            .push("sensor noise not measurable (constant readings?); configured noise kept".into());
    }
    // A reading near 0 bar (tank) must not leave the plausible range by
    // noise alone: the lower limit is at least 7σ below zero (a false
    // sensor fault less than once in 10¹¹ samples; a broken 4–20 mA loop
    // still reads tens of bar below).
    let sigma_max = cal.noise[..4].iter().map(|c| c.white).fold(0.0, f64::max);
    let low = &mut p.sensors.pressure_range_bar[0];
    if *low > -7.0 * sigma_max {
        cal.warnings.push(format!(
            "pressure noise up to {sigma_max:.2} bar: plausible pressure range widened from {low} to {:.1} bar so that noise on a tank reading is not a sensor fault",
            -7.0 * sigma_max
        ));
        *low = -7.0 * sigma_max;
    }
    cal.params = p.clone();
    cal.oscillation = oscillation.cloned();
    if let Some(o) = oscillation.filter(|o| o.worth_a_warning()) {
        cal.warnings.push(format!(
            "{}: the monitor counts none of that as leak evidence, so on this machine it judges leaks only where the loop is settled, and says `inconclusive` where that is too little; stabilise the loop (lower its gain at this supply pressure) for full monitoring",
            o.describe()
        ));
    }

    // Motion: the whole recording, then the validation fit's part.
    let refuse = |mut cal: Calibration, why: String| {
        cal.refused = Some(why);
        cal
    };
    // The held-out third: the last, unless the other two thirds then lack
    // moves in one direction (a work cycle may retract only late); then
    // the middle, then the first.
    cal.motion = Motion::of(&fit::prepare(samples));
    let mut missing = missing_motion(&cal.motion, MIN_STEADY_S, "the recording");
    let mut held = None;
    if mechanics != Mechanics::Strict {
        // A partial calibration: the last third is held out.
        missing = None;
        held = Some(HeldOut::third(samples, 2, "last"));
    } else if missing.is_none() {
        for (k, name) in [(2, "last"), (1, "middle"), (0, "first")] {
            let h = HeldOut::third(samples, k, name);
            let m = Motion::of(&fit::prepare_pieces(&h.fit_pieces(samples)));
            match missing_motion(&m, MIN_STEADY_FIT_S, "the first two thirds of the recording (none of its other two-thirds parts does better for the validation fit)") {
                None => {
                    held = Some(h);
                    break;
                }
                Some(why) if k == 2 => missing = Some(why),
                Some(_) => {}
            }
        }
        if held.is_some() {
            missing = None;
        }
    }
    let held = match (missing, held) {
        (None, Some(h)) => h,
        (missing, _) => {
            let missing = missing.unwrap_or_default();
            let cal = refuse(cal, format!("not enough motion: {missing}"));
            return Err(CalibrationError::NotEnoughMotion {
                missing,
                report: cal.report(),
            });
        }
    };
    cal.held_s = held.t;
    cal.held_name = held.name;
    let fit_pieces = held.fit_pieces(samples);
    cal.fit_s = duration - (held.t.1 - held.t.0);

    // 1–5 on the first two thirds, then validation on the last third.
    let part = fit_plant(&fit_pieces, &p, true, mechanics, holds)?;
    cal.quality[0] = part.quality.clone();
    if !part.quality.problems.is_empty() {
        let why = format!(
            "{} (fitted on all but the {} third)",
            part.quality.problems.join("; "),
            held.name
        );
        cal.fits = part.fits;
        cal.warnings.extend(part.warnings);
        let cal = refuse(cal, why.clone());
        return Err(CalibrationError::PoorFit {
            why,
            report: cal.report(),
        });
    }
    let v = check::run_pieces(&[samples], &part.params, held.t)?;
    cal.validation = Some(v.clone());
    let mut failed = Vec::new();
    if v.leading_nis > MAX_VALIDATION_NIS {
        failed.push(format!(
            "mean NIS {:.1} > {MAX_VALIDATION_NIS} (≈ 3 expected: the model or the noise levels do not describe this data)",
            v.leading_nis
        ));
    }
    // Alarms on the held-out part are judged with the floor the fit part
    // alone would set: the floor is how the monitor lives with the model
    // error it measured.
    let part_run = check::run_pieces(
        &fit_pieces,
        &part.params,
        (f64::NEG_INFINITY, f64::INFINITY),
    )?;
    let part_floor = Floors::of(&[&part_run], part.params.alarm.alarm_lpm);
    let mut floored = part.params.clone();
    part_floor.set(&mut floored);
    let vf = check::run_pieces(&[samples], &floored, held.t)?;
    if let Some((t, verdict)) = vf.alarms.first() {
        failed.push(format!(
            "a leak alarm ({}) at t = {t:.1} s on a recording declared healthy, with the detection floor of the fit part (up to {:.2} / {:.2} l/min)",
            verdict.name(),
            part_floor.highest(0),
            part_floor.highest(1)
        ));
    }
    // What the leak-free installation still reads on the held-out part
    // decides the detection floor (below); a floor no leak monitor can
    // work with is a refusal.
    for (k, name) in ["internal", "external"].iter().enumerate() {
        let floor = FLOOR_MARGIN * v.detect_max_lpm[k];
        if floor > MAX_DETECTION_FLOOR_LPM {
            failed.push(format!(
                "healthy {name} detection reading up to {:.3} l/min on the held-out part: the model does not describe this installation well enough to tell leaks below {floor:.2} l/min (limit {MAX_DETECTION_FLOOR_LPM})",
                v.detect_max_lpm[k]
            ));
        }
    }
    if v.evidence_fraction < MIN_EVIDENCE_FRACTION {
        failed.push(format!(
            "the monitor weighed only {:.0} % of the held-out part as evidence (need {:.0} %): too little quasi-steady operation to judge",
            100.0 * v.evidence_fraction,
            100.0 * MIN_EVIDENCE_FRACTION
        ));
    }
    if v.valve_misfit_fraction >= WARN_VALVE_MISFIT_FRACTION {
        cal.warnings.push(format!(
            "the monitor's valve flow gains stood more than {:.0} % off the fitted valve for {:.0} % of the held-out part: those samples are no evidence, and where they dominate the verdict is `inconclusive`; record the moves the machine makes at the speeds it makes them, or check the valve",
            100.0 * VALVE_GAIN_MISFIT,
            100.0 * v.valve_misfit_fraction
        ));
    }
    let held_len = held.t.1 - held.t.0;
    // The monitor warms up for filter.warm_up_s when the first third is
    // held out.
    let expect_s = held_len - (start.filter.warm_up_s - (held.t.0 - t0)).max(0.0);
    if v.counted_s < 0.5 * expect_s {
        failed.push(format!(
            "the monitor estimated during only {:.1} s of the {:.1} s held out ({} sensor faults, {} filter restarts over the recording)",
            v.counted_s,
            held_len,
            v.faults,
            v.restarts
        ));
    }
    if !failed.is_empty() {
        let why = failed.join("; ");
        cal.fits = part.fits;
        cal.warnings.extend(part.warnings);
        let cal = refuse(cal, why.clone());
        return Err(CalibrationError::ValidationFailed {
            why,
            report: cal.report(),
        });
    }

    // The written fit: 1, 2, 4, 5 again on the whole recording; the air
    // content (10 monitor runs to search, rarely determined) is the
    // validated fit's.
    let mut q = p.clone();
    q.fluid.air_fraction = part.params.fluid.air_fraction;
    let full = fit_plant(&[samples], &q, false, mechanics, holds)?;
    cal.quality[1] = full.quality.clone();
    cal.fits = full.fits;
    // The air content is the validated fit's: its line and warning.
    let air = |what: &str| what.starts_with("entrained air");
    if let Some(f) = part.fits.iter().find(|f| air(&f.what)) {
        let mut f = f.clone();
        f.quality += &format!(" (all but the {} third)", held.name);
        cal.fits.push(f);
    }
    cal.warnings
        .extend(part.warnings.iter().filter(|w| air(w)).cloned());
    cal.warnings.extend(full.warnings);
    cal.baseline_notes = full.baseline_notes;
    if !full.quality.problems.is_empty() {
        let why = format!("{} (whole recording)", full.quality.problems.join("; "));
        let cal = refuse(cal, why.clone());
        return Err(CalibrationError::PoorFit {
            why,
            report: cal.report(),
        });
    }
    let (a, b) = (&part.params.valve, &full.params.valve);
    let rel = |x: f64, y: f64| 100.0 * (y / x - 1.0);
    cal.refit_notes.push(format!(
        "flow gains {:+.1} % / {:+.1} %, gravity scale {:+.1} %, Coulomb friction {:+.1} %",
        rel(
            a.flow_gain_extend_lpm_sqrt_bar,
            b.flow_gain_extend_lpm_sqrt_bar
        ),
        rel(
            a.flow_gain_retract_lpm_sqrt_bar,
            b.flow_gain_retract_lpm_sqrt_bar
        ),
        rel(
            part.params.load.gravity_scale,
            full.params.load.gravity_scale
        ),
        rel(
            part.params.friction.coulomb_n,
            full.params.friction.coulomb_n
        ),
    ));
    let drift = [
        rel(
            a.flow_gain_extend_lpm_sqrt_bar,
            b.flow_gain_extend_lpm_sqrt_bar,
        ),
        rel(
            a.flow_gain_retract_lpm_sqrt_bar,
            b.flow_gain_retract_lpm_sqrt_bar,
        ),
    ];
    if drift.iter().any(|d| d.abs() > MAX_REFIT_GAIN_CHANGE_PCT) {
        cal.warnings.push(format!(
            "the refit's valve flow gains differ from the validated fit's by {:+.1} % / {:+.1} % (> {MAX_REFIT_GAIN_CHANGE_PCT} %): the valve changed during the recording, or one part lacks moves; check the held-out third's figures",
            drift[0], drift[1]
        ));
    }
    let after = check::run(samples, &full.params)?;
    cal.nis_after = after.healthy_nis;
    cal.leak_after_lpm = after.detect_max_lpm;
    cal.laminar_factor_max = after.laminar_factor_max;
    cal.params = full.params;
    // The detection floor: what this leak-free installation still reads,
    // with a margin, wherever it exceeds the user's alarm level.
    let alarm = cal.params.alarm.alarm_lpm;
    let mut floors = Floors::of(&[&after, &v], alarm);
    for (name, spread) in floors.cover_narrow_moves(&cal.motion) {
        cal.warnings.push(format!(
            "{name} moves at few speeds (command σ {spread:.3} < {NARROW_MOVE_SPREAD}): leaks alarm there from {NARROW_MOVE_FLOOR_LPM} l/min at least, since the model was not seen at the other openings; record the moves the machine makes at the speeds it makes them"
        ));
    }
    floors.set(&mut cal.params);
    if floors.region.iter().flatten().any(|f| *f > 0.0) {
        let show = |k: usize| {
            let f = floors.region[k].map(|f| alarm.max(f));
            format!("{:.2} / {:.2} / {:.2}", f[0], f[1], f[2])
        };
        cal.warnings.push(format!(
            "detection floor: this installation's leak-free readings reach {:.3} / {:.3} l/min (internal / external); leaks alarm from internal {} and external {} l/min (retracting / holding / extending) instead of the alarm level {alarm} l/min",
            after.detect_max_lpm[0].max(v.detect_max_lpm[0]),
            after.detect_max_lpm[1].max(v.detect_max_lpm[1]),
            show(0),
            show(1),
        ));
    }
    cal.checked()
}

/// Command spread (σ) of a direction's quasi-steady moves below which
/// they are taken to have visited few openings.
const NARROW_MOVE_SPREAD: f64 = 0.04;
/// The moves' detection floor, l/min, in a direction whose moves spanned
/// few speeds.
const NARROW_MOVE_FLOOR_LPM: f64 = 0.15;

/// The detection floors the leak-free runs of an installation call for.
struct Floors {
    /// Per leak and region (`check::REGIONS`), l/min: [`FLOOR_MARGIN`] ×
    /// the largest detection reading seen in that region, rounded up to
    /// 0.01 l/min (a figure an engineer reads) where it exceeds the alarm
    /// level, else 0; at most [`MAX_DETECTION_FLOOR_LPM`].
    region: [[f64; 3]; 2],
}

impl Floors {
    fn of(runs: &[&check::Run], alarm_lpm: f64) -> Self {
        let region = core::array::from_fn(|k| {
            core::array::from_fn(|r| {
                let seen = runs
                    .iter()
                    .map(|run| run.detect_region_max_lpm[k][r])
                    .fold(0.0, f64::max);
                let f = FLOOR_MARGIN * seen;
                if f > alarm_lpm {
                    ((f * 100.0).ceil() / 100.0).min(MAX_DETECTION_FLOOR_LPM)
                } else {
                    0.0
                }
            })
        });
        Self { region }
    }

    /// The highest floor of leak `k` over the regions, l/min.
    fn highest(&self, k: usize) -> f64 {
        self.region[k].iter().copied().fold(0.0, f64::max)
    }

    /// A direction whose quasi-steady moves spanned few speeds (command
    /// σ below [`NARROW_MOVE_SPREAD`]) says little of the openings the
    /// recording did not visit: its moves' floor, both leaks, is at least
    /// [`NARROW_MOVE_FLOOR_LPM`]. (Survey rig 73, 100 bar, 40 °C, retracted
    /// at one speed, σ 0.03: a retraction three times as fast read
    /// external flow above the floor of 0.08 l/min its recording set.)
    /// Returns the directions so covered, with their spread.
    fn cover_narrow_moves(&mut self, motion: &Motion) -> Vec<(&'static str, f64)> {
        let mut covered = Vec::new();
        for (region, spread) in [
            (RETRACTING_REGION, motion.retract_spread),
            (EXTENDING_REGION, motion.extend_spread),
        ] {
            if spread < NARROW_MOVE_SPREAD {
                for leak in &mut self.region {
                    leak[region] = leak[region].max(NARROW_MOVE_FLOOR_LPM);
                }
                covered.push((check::REGIONS[region], spread));
            }
        }
        covered
    }

    /// Into `p`'s baseline: the lowest region's floor everywhere, the
    /// regions' above it.
    fn set(&self, p: &mut Params) {
        let lowest = |k: usize| self.region[k].iter().copied().fold(f64::INFINITY, f64::min);
        let b = &mut p.baseline;
        b.detection_floor_lpm = [lowest(0), lowest(1)];
        b.region_floor_internal_lpm = self.region[0];
        b.region_floor_external_lpm = self.region[1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_at_few_speeds_get_a_floor_the_others_keep_theirs() {
        let mut floors = Floors {
            region: [[0.0, 0.12, 0.3], [0.0, 0.0, 0.0]],
        };
        let motion = Motion {
            retract_spread: 0.5 * NARROW_MOVE_SPREAD,
            extend_spread: 2.0 * NARROW_MOVE_SPREAD,
            ..Motion::default()
        };
        let covered = floors.cover_narrow_moves(&motion);
        assert_eq!(covered, [("retracting", 0.5 * NARROW_MOVE_SPREAD)]);
        let f = NARROW_MOVE_FLOOR_LPM;
        assert_eq!(floors.region, [[f, 0.12, 0.3], [f, 0.0, 0.0]]);
    }
}
