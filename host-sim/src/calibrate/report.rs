//! The calibration's report, summary and TOML.

use super::{Calibration, CalibrationError, MAX_VALIDATION_NIS};
use monitor::status::VALVE_GAIN_MISFIT;
use monitor::Params;

impl Calibration {
    /// The calibration if its parameters pass [`Params::validate`](monitor::Params::validate) (the
    /// monitor's own check, as `replay` and the firmware build apply it);
    /// else refused, naming the field: a fit that leaves the physical
    /// bounds is never written.
    pub fn checked(mut self) -> Result<Self, CalibrationError> {
        match self.params.validate() {
            Ok(()) => Ok(self),
            Err(error) => {
                self.refused = Some(format!("the fitted parameters fail validation: {error}"));
                Err(CalibrationError::InvalidFit {
                    error: Box::new(error),
                    report: self.report(),
                })
            }
        }
    }

    /// The whole report: fits, noise, validation, warnings, verdict (the
    /// TOML header).
    pub fn report(&self) -> String {
        self.render(true)
    }

    /// The report without the warnings (`host-sim calibrate` prints those
    /// to stderr).
    pub fn summary(&self) -> String {
        self.render(false)
    }

    fn render(&self, with_warnings: bool) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Recording {:.1} s. Validation fit on {:.1} s, checked on the {} third, t = {:.1}–{:.1} s (not used for the fit); the parameters written are the refit on the whole recording.",
            self.duration_s,
            self.fit_s,
            self.held_name,
            self.held_s.0,
            self.held_s.1
        );
        let m = &self.motion;
        let _ = writeln!(
            s,
            "Quasi-steady moves: extending {:.1} s (command σ {:.3}), retracting {:.1} s (command σ {:.3}); moving at all: extending {:.1} s, retracting {:.1} s; at rest {:.1} s.",
            m.extend_s,
            m.extend_spread,
            m.retract_s,
            m.retract_spread,
            m.moving_s[0],
            m.moving_s[1],
            m.hold_s
        );
        if !self.fits.is_empty() {
            let _ = writeln!(s, "\nFitted:");
        }
        for f in &self.fits {
            let _ = writeln!(s, "  {:<38} {:<52} {}", f.what, f.value, f.quality);
        }
        for n in &self.refit_notes {
            let _ = writeln!(s, "  whole-recording refit vs validated fit: {n}");
        }
        if !self.noise.is_empty() {
            let _ = writeln!(
                s,
                "\nSensor noise (1σ; white from second differences at holds and slow moves, ripple beyond it around a 20 ms average):"
            );
            for c in &self.noise {
                let _ = writeln!(
                    s,
                    "  {:<10} white {:.3e} {u}, ripple {:.3e} {u}, quantisation step {:.2e} {u} ({} samples)",
                    c.name,
                    c.white,
                    c.coloured,
                    c.step,
                    c.samples,
                    u = c.unit
                );
            }
            let _ = writeln!(
                s,
                "  for the monitor: sensors.pressure_noise_bar = {:.4} (larger chamber, white ⊕ ripple), sensors.position_noise_m = {:.2e}",
                self.params.sensors.pressure_noise_bar, self.params.sensors.position_noise_m
            );
        }
        if let Some(o) = &self.oscillation {
            let what = if o.share > 0.0 {
                o.describe()
            } else {
                "none".into()
            };
            let _ = writeln!(
                s,
                "\nLoop oscillation ({} windows of {} s judged): {what}.",
                o.windows,
                monitor::signal::oscillation::WINDOW_S
            );
        }
        if let Some(v) = &self.validation {
            let alarm = self.params.alarm.alarm_lpm;
            let _ = writeln!(
                s,
                "\nValidation on the held-out {} third, t = {:.1}–{:.1} s ({:.1} s counted after warm-up), monitor with the parameters fitted on the rest:",
                self.held_name,
                self.held_s.0,
                self.held_s.1,
                v.counted_s,
            );
            let _ = writeln!(
                s,
                "  mean NIS of the leading hypothesis {:.2} (≈ 3 consistent; fails above {MAX_VALIDATION_NIS})",
                v.leading_nis
            );
            let _ = writeln!(
                s,
                "  largest |leak| reading (the monitor's own, per-region baseline subtracted): internal {:.3} l/min, external {:.3} l/min (alarm level {alarm} l/min)",
                v.leak_max_lpm[0], v.leak_max_lpm[1]
            );
            let _ = writeln!(
                s,
                "  evidence weight > 0.5 for {:.0} % of the time; valve flow gains more than {:.0} % off the fit (no evidence unless learned within it first) for {:.0} %; alarms: {}",
                100.0 * v.evidence_fraction,
                100.0 * VALVE_GAIN_MISFIT,
                100.0 * v.valve_misfit_fraction,
                if v.alarms.is_empty() {
                    "none".to_string()
                } else {
                    v.alarms
                        .iter()
                        .map(|(t, k)| format!("{} at {t:.1} s", k.name()))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            );
        }
        if self.refused.is_none() {
            let _ = writeln!(
                s,
                "\nWhole recording, before → after calibration: healthy-filter mean NIS {:.2} → {:.2}; largest 0.25 s detection reading internal {:.3} → {:.3} l/min, external {:.3} → {:.3} l/min",
                self.nis_before,
                self.nis_after,
                self.leak_before_lpm[0],
                self.leak_after_lpm[0],
                self.leak_before_lpm[1],
                self.leak_after_lpm[1]
            );
        }
        if with_warnings {
            for w in self.warnings() {
                let _ = writeln!(s, "warning: {w}");
            }
        }
        match &self.refused {
            None => {
                let _ = writeln!(s, "\nVerdict: accepted.");
            }
            Some(why) => {
                let why = self
                    .oscillation
                    .as_ref()
                    .map_or_else(|| why.clone(), |o| o.refusal(why));
                let _ = writeln!(s, "\nVerdict: refused because {why}. Nothing written.");
            }
        }
        s
    }

    /// Everything the engineer should know beyond the figures.
    pub fn warnings(&self) -> impl Iterator<Item = &String> {
        self.warnings.iter().chain(&self.baseline_notes)
    }

    /// The installation's parameters as TOML, with the report as a comment
    /// header. The `[filter]` section is left out on purpose: filter tuning
    /// belongs to the monitor version, not to the installation, so a newer
    /// monitor's defaults apply to an existing installation file. Only the
    /// laminar factor's settings that calibration chose for this
    /// installation are written.
    pub fn to_toml(&self, source: &str) -> Result<String, toml::ser::Error> {
        let mut out =
            format!("# Installation parameters fitted by host-sim calibrate from {source}\n");
        for line in self.report().lines() {
            out += &format!("# {line}\n");
        }
        out += "\n";
        let mut table = toml::Table::try_from(&self.params)?;
        // The filter tuning belongs to the monitor version, not to the
        // installation; the exceptions are the laminar factor's bound
        // and freedom, which calibration sets for this installation (a
        // relaxed bound; held where the oil temperature is read).
        table.remove("filter");
        let (f, nominal) = (&self.params.filter, Params::nominal().filter);
        let mut filter = toml::Table::new();
        for (key, value, default) in [
            (
                "laminar_factor_min",
                f.laminar_factor_min,
                nominal.laminar_factor_min,
            ),
            ("q_laminar", f.q_laminar, nominal.q_laminar),
            ("laminar_prior", f.laminar_prior, nominal.laminar_prior),
        ] {
            if value != default {
                filter.insert(key.into(), value.into());
            }
        }
        if !filter.is_empty() {
            table.insert("filter".into(), filter.into());
        }
        out += &toml::to_string(&table)?;
        Ok(out)
    }
}
