//! The leak-free installation's holding command: the valve command with
//! which its position loop holds the piston at rest.
//!
//! At a hold the loop must feed any leak through the valve, whatever the
//! filters make of that flow (a land-leakage state may take it in), so a
//! holding command that moves away from the calibrated one withholds
//! `healthy` (`baseline.hold_command`, `hold_command_tolerance`,
//! `health::HOLD_COMMAND_SHIFTED`). The calibrated `valve.null_offset` is
//! no such reference: it is where the model's edges open, fitted from the
//! moves, and healthy holds stood more than 0.003 from it on 18 of 40
//! ninth-survey cells.
//!
//! `fit::hold_command` (the median command at rest in the fit's decimated
//! data, 2 s needed) places a kept valve's null; the reference here is
//! taken from the very samples the decision judges ([`quiet_hold`] on
//! the monitor's own region and evidence weight), so that reference and
//! judgement see the same holds.

use monitor::params::Params;
use monitor::status::quiet_hold;
use monitor::{Monitor, Sample};

use super::{Calibration, Fit};
use crate::replay::sample_period;

/// How far the holding command may move from the calibrated one,
/// normalised. On the ninth and eighth survey's calibrated cells the quiet
/// holds of the healthy closed-loop runs stood beyond it in 2 of 40 and
/// 0 of 36, those of runs with a 0.2 l/min internal leak in 37 of 40 and
/// 29 of 36.
pub const HOLD_COMMAND_TOLERANCE: f64 = 0.003;

/// How far apart, in tolerances, the 10 % and 90 % quantiles of the
/// holding command may lie for one command to describe the holds. A loop
/// that stops its piston inside the valve's dead zone holds it where the
/// approach left the spool (`host-sim simulate`'s rig 5: +0.018 after
/// extending, −0.014 after retracting): one command then describes no
/// hold. The survey rigs' loops hold at one command (ninth survey: 10–90 %
/// spread median 0.0016, above 0.006 in 1 of 40 cells).
const MAX_SPREAD_TOLERANCES: f64 = 2.0;

/// Quiet holds needed to take the median from, samples (0.2 s at the
/// 1 kHz sample rate).
const MIN_HOLD_SAMPLES: usize = 200;

/// The start of the recording left out, s: the monitor's warm-up and the
/// first settling.
const SKIP_S: f64 = 5.0;

/// Sets `cal`'s holding command and tolerance from the quiet holds of
/// `samples` replayed with its parameters, and says so in its fits; with
/// too few quiet holds, leaves the tolerance at 0 (not followed) and says
/// that.
pub(super) fn follow_the_holding_command(samples: &[Sample], cal: &mut Calibration) {
    let mut us = quiet_hold_commands(samples, &cal.params);
    let period_s = samples
        .first()
        .and_then(|first| sample_period(None, first, samples.get(1)))
        .unwrap_or(1e-3);
    let secs = us.len() as f64 * period_s;
    if us.len() < MIN_HOLD_SAMPLES {
        let n = us.len();
        let why = format!(
            "the recording held the piston quietly for {secs:.2} s ({n} samples, {MIN_HOLD_SAMPLES} needed)"
        );
        return not_followed(cal, &why);
    }
    us.sort_by(f64::total_cmp);
    let median = us[us.len() / 2];
    let (lo, hi) = (us[us.len() / 10], us[us.len() * 9 / 10]);
    let limit = MAX_SPREAD_TOLERANCES * HOLD_COMMAND_TOLERANCE;
    if hi - lo > limit {
        let why = format!(
            "the loop held the piston with different commands at different holds (10–90 % {lo:+.4} … {hi:+.4}, more than {limit:.3} apart)"
        );
        return not_followed(cal, &why);
    }
    cal.params.baseline.hold_command = median;
    cal.params.baseline.hold_command_tolerance = HOLD_COMMAND_TOLERANCE;
    cal.fits.push(Fit {
        what: "holding command".into(),
        value: format!("{median:+.4} ± {HOLD_COMMAND_TOLERANCE}"),
        quality: format!("median of {secs:.1} s of quiet holds, 10–90 % {lo:+.4} … {hi:+.4}"),
    });
}

/// Leaves the holding command unfollowed (tolerance 0) in `cal`, and a
/// note saying `why`.
fn not_followed(cal: &mut Calibration, why: &str) {
    cal.params.baseline.hold_command = 0.0;
    cal.params.baseline.hold_command_tolerance = 0.0;
    cal.baseline_notes.push(format!(
        "{why}: the holding command is not followed (baseline.hold_command_tolerance 0)"
    ));
}

/// The valve commands (normalised) read at the quiet holds of `samples`
/// replayed with `params` ([`quiet_hold`], as the monitor judges them),
/// after [`SKIP_S`].
fn quiet_hold_commands(samples: &[Sample], params: &Params) -> Vec<f64> {
    let (Ok(mut m), Some(first)) = (Monitor::<f32>::new(params), samples.first()) else {
        return Vec::new();
    };
    let mut us = Vec::new();
    for s in samples {
        let status = m.step(s);
        if s.t_s - first.t_s > SKIP_S && quiet_hold(m.region(), status.evidence_weight) {
            us.extend(s.u_valve.map(f64::from));
        }
    }
    us
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::exec::row_sample;
    use crate::eval::plan::{plan, PlanConfig};

    /// The 60 s healthy recording development rig 2 at 100 bar, 25 °C is
    /// calibrated from in `host-sim eval`.
    fn calibration_recording() -> Vec<Sample> {
        let cell = plan(&PlanConfig::default())
            .cells
            .into_iter()
            .find(|c| c.cell.rig == 2 && c.cell.supply_bar == 100.0 && c.cell.temp_c == 25.0)
            .expect("a development cell");
        plant::simulate(&cell.calibration.run())
            .iter()
            .map(row_sample)
            .collect()
    }

    #[test]
    fn the_holding_command_is_the_median_at_quiet_holds_and_needs_enough_of_them() {
        let samples = calibration_recording();
        let mut cal = Calibration {
            params: Params::nominal(),
            ..Calibration::default()
        };
        follow_the_holding_command(&samples, &mut cal);
        let b = &cal.params.baseline;
        assert_eq!(b.hold_command_tolerance, HOLD_COMMAND_TOLERANCE);
        let fit = cal
            .fits
            .iter()
            .find(|f| f.what == "holding command")
            .expect("a fit line");
        // The loop holds the piston inside the dead zone, near the null.
        assert!(
            b.hold_command.abs() < 0.05,
            "{} ({:?})",
            b.hold_command,
            fit
        );
        // The first 5 s are left out: nothing to take the median from.
        let mut short = Calibration {
            params: cal.params.clone(),
            ..Calibration::default()
        };
        follow_the_holding_command(&samples[..5_000], &mut short);
        let b = &short.params.baseline;
        assert_eq!((b.hold_command, b.hold_command_tolerance), (0.0, 0.0));
        assert!(short.fits.is_empty());
        assert!(
            short
                .baseline_notes
                .iter()
                .any(|n| n.contains("holding command is not followed")),
            "{:?}",
            short.baseline_notes
        );
    }
}
