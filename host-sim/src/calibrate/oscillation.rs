//! Does the machine's position loop oscillate, and how much of a
//! recording?
//!
//! A position loop tuned at one supply pressure can hunt at a higher one;
//! no sample of such a stretch counts as leak evidence, and calibration
//! finds few quasi-steady moves in it — a refusal that names the missing
//! moves sends the engineer to record more of the same. The oscillation is
//! measured here so that the report names it, with its frequency and
//! swing. Each window is judged as the device judges it
//! (`monitor::signal::oscillation`, which also raises
//! `health::LOOP_OSCILLATING`): this meter adds the share of a whole
//! recording, the frequency and the means the report gives.

use monitor::signal::oscillation::{self, HUNTING_SHARE, WINDOW_S};
use monitor::Sample;

/// Share of the recording from which the report warns: the monitor then
/// has no evidence for that share of the machine's work.
pub const WARN_SHARE: f64 = 0.15;
/// Does an oscillating share of a recording warrant a warning
/// ([`WARN_SHARE`])? Calibration's report and `replay`'s summary (which
/// keeps only the share) ask the same question.
pub fn share_worth_a_warning(share: f64) -> bool {
    share >= WARN_SHARE
}

/// How much of a recording the position loop oscillates, and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Oscillation {
    /// Share of the judged windows that oscillate, 0–1.
    pub share: f64,
    /// Windows judged (complete readings, at least [`MIN_WINDOW_SAMPLES`]).
    pub windows: usize,
    /// Oscillation frequency over the oscillating windows (the command's
    /// cycles per second), Hz; 0 if none oscillates.
    pub frequency_hz: f64,
    /// Mean chamber-pressure swing (rms about the window's trend) over
    /// the oscillating windows, bar.
    pub chamber_swing_bar: f64,
    /// Mean valve-command swing (rms about the trend) over the
    /// oscillating windows.
    pub command_swing: f64,
    /// Mean supply pressure over the oscillating windows, bar (0 if none).
    pub supply_bar: f64,
}

impl Oscillation {
    /// The report's sentence: what oscillates, how much, how often.
    pub fn describe(&self) -> String {
        format!(
            "the position loop oscillates at ≈ {:.0} Hz during {:.0} % of the recording (chamber pressures {:.0} bar rms about their trend, {:.0} % of the {:.0} bar supply; valve command {:.3} rms)",
            self.frequency_hz,
            100.0 * self.share,
            self.chamber_swing_bar,
            100.0 * self.chamber_swing_bar / self.supply_bar,
            self.supply_bar,
            self.command_swing
        )
    }

    /// The report warns about it ([`share_worth_a_warning`]).
    pub fn worth_a_warning(&self) -> bool {
        share_worth_a_warning(self.share)
    }

    /// A refusal names it as the cause: it oscillates for at least the
    /// share from which the device says the loop hunts ([`HUNTING_SHARE`]:
    /// 8 tuning cells whose loops hunt 71–95 % of the time were refused for
    /// want of quasi-steady moves or of evidence; the calibrated cells
    /// that hunt do so for at most 59 %).
    pub fn is_the_cause(&self) -> bool {
        self.share >= HUNTING_SHARE
    }

    /// A refusal's reason `why`, with the oscillation named first where it
    /// is the cause: what the engineer must change before the recording
    /// can say more.
    pub fn refusal(&self, why: &str) -> String {
        if self.is_the_cause() {
            format!(
                "{}: stabilise the loop, then record again; as it is, {why}",
                self.describe()
            )
        } else {
            why.to_string()
        }
    }
}

/// Whole cycles of `r` (at times `t`) and the time they took, s: between
/// the first and the last upward crossing through ±`band` (a crossing
/// counts once the signal went below −band and then above +band, at the
/// same phase every cycle; the window's partial cycles at either end do
/// not bias the frequency).
fn cycles(t: &[f64], r: impl Iterator<Item = f64>, band: f64) -> (usize, f64) {
    let mut below = false;
    let mut ups = 0usize;
    let (mut first, mut last) = (0.0, 0.0);
    for (&ti, x) in t.iter().zip(r) {
        if x < -band {
            below = true;
        } else if x > band && below {
            below = false;
            if ups == 0 {
                first = ti;
            }
            last = ti;
            ups += 1;
        }
    }
    (ups.saturating_sub(1), last - first)
}

/// One window: its running sums (the monitor's, which judge it), and the
/// times and commands, kept for the command's cycles.
#[derive(Default)]
struct Window {
    sums: oscillation::Window<f64>,
    t: Vec<f64>,
    command: Vec<f64>,
    /// A reading was missing or not finite: the window is not judged.
    gap: bool,
}

impl Window {
    fn clear(&mut self) {
        self.sums = oscillation::Window::default();
        self.t.clear();
        self.command.clear();
        self.gap = false;
    }

    fn push(&mut self, s: &Sample) {
        let finite = |v: Option<f32>| v.filter(|v| v.is_finite()).map(f64::from);
        match (
            finite(s.p_supply_bar),
            finite(s.p_piston_bar),
            finite(s.p_rod_bar),
            finite(s.u_valve),
        ) {
            (Some(ps), Some(a), Some(b), Some(u)) => {
                let t0 = self.t.first().copied().unwrap_or(s.t_s);
                self.sums.add(s.t_s - t0, ps, a, b, u);
                self.t.push(s.t_s);
                self.command.push(u);
            }
            _ => self.gap = true,
        }
    }
}

/// Measures the loop's oscillation sample by sample, in bounded memory
/// (one window of readings): `calibrate` over its recording, `replay`
/// over a recording of any length.
#[derive(Default)]
pub struct Meter {
    window: Window,
    judged: usize,
    oscillating: usize,
    cycles: usize,
    cycles_s: f64,
    /// Sums over the oscillating windows: chamber swing, command swing,
    /// supply pressure.
    sums: [f64; 3],
}

impl Meter {
    /// Take one sample (in time order).
    pub fn push(&mut self, s: &Sample) {
        if self
            .window
            .t
            .first()
            .is_some_and(|&t0| s.t_s - t0 >= WINDOW_S)
        {
            self.judge();
        }
        self.window.push(s);
    }

    /// Judge the window and start the next.
    fn judge(&mut self) {
        let w = &self.window;
        if let Some(j) = w.sums.judge().filter(|_| !w.gap) {
            self.judged += 1;
            if j.oscillates {
                // The command less its line; half a σ of hysteresis: noise
                // on the command adds no cycles.
                let t0 = w.t[0];
                let residuals =
                    w.t.iter()
                        .zip(&w.command)
                        .map(|(&t, &u)| u - j.command_line.at(t - t0));
                let (n, span) = cycles(&w.t, residuals, 0.5 * j.command_swing);
                self.oscillating += 1;
                self.cycles += n;
                self.cycles_s += span;
                let judged = [j.chamber_swing_bar, j.command_swing, j.supply_bar];
                for (sum, v) in self.sums.iter_mut().zip(judged) {
                    *sum += v;
                }
            }
        }
        self.window.clear();
    }

    /// What was measured; `None` before a single complete window.
    pub fn finish(mut self) -> Option<Oscillation> {
        self.judge();
        if self.judged == 0 {
            return None;
        }
        let mean = |sum: f64| sum / self.oscillating.max(1) as f64;
        Some(Oscillation {
            share: self.oscillating as f64 / self.judged as f64,
            windows: self.judged,
            frequency_hz: if self.cycles_s > 0.0 {
                self.cycles as f64 / self.cycles_s
            } else {
                0.0
            },
            chamber_swing_bar: mean(self.sums[0]),
            command_swing: mean(self.sums[1]),
            supply_bar: mean(self.sums[2]),
        })
    }
}

/// Measure the loop's oscillation over `samples`; `None` without a single
/// complete window (supply, chamber pressures and command all read).
pub fn measure(samples: &[Sample]) -> Option<Oscillation> {
    let mut m = Meter::default();
    for s in samples {
        m.push(s);
    }
    m.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// 60 s at 100 bar: the loop hunts at `hz` (±30 bar, command ±0.04)
    /// while `hunting(t)`, otherwise it moves smoothly; pump ripple of
    /// ±2 bar at 150 Hz throughout, with the command untouched by it.
    fn recording(hz: f64, hunting: impl Fn(f64) -> bool) -> Vec<Sample> {
        (0..60_000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let move_ = 20.0 * (0.3 * t).sin();
                let ripple = 2.0 * (2.0 * PI * 150.0 * t).sin();
                let (dp, du) = if hunting(t) {
                    let s = (2.0 * PI * hz * t).sin();
                    (30.0 * s, 0.04 * s)
                } else {
                    (0.0, 0.0)
                };
                Sample {
                    t_s: t,
                    p_supply_bar: Some((100.0 + ripple) as f32),
                    p_piston_bar: Some((50.0 + move_ + dp + ripple) as f32),
                    p_rod_bar: Some((40.0 - move_ - dp + ripple) as f32),
                    p_tank_bar: Some(1.0),
                    x_piston_m: Some((0.1 + 0.05 * (0.3 * t).sin()) as f32),
                    u_valve: Some((0.1 * (0.3 * t).cos() + du) as f32),
                    temp_oil_c: None,
                }
            })
            .collect()
    }

    #[test]
    fn a_hunting_loop_is_measured_with_its_frequency_swing_and_share() {
        let o = measure(&recording(18.0, |t| t < 45.0)).unwrap();
        assert!((o.share - 0.75).abs() < 0.02, "{o:?}");
        assert!((o.frequency_hz - 18.0).abs() < 1.0, "{o:?}");
        // ±30 bar of sine is 21 bar 1σ.
        assert!(
            (o.chamber_swing_bar - 30.0 / 2f64.sqrt()).abs() < 1.5,
            "{o:?}"
        );
        assert!(
            (o.command_swing - 0.04 / 2f64.sqrt()).abs() < 0.003,
            "{o:?}"
        );
        assert!(o.worth_a_warning() && o.is_the_cause());
        let said = o.describe();
        assert!(said.contains("≈ 18 Hz") && said.contains("75 %"), "{said}");
    }

    #[test]
    fn smooth_moves_and_pump_ripple_are_no_oscillation() {
        let o = measure(&recording(18.0, |_| false)).unwrap();
        assert_eq!(o.share, 0.0, "{o:?}");
        assert!(!o.worth_a_warning());
    }

    #[test]
    fn a_short_spell_warns_without_being_the_cause() {
        let o = measure(&recording(25.0, |t| (20.0..32.0).contains(&t))).unwrap();
        assert!((o.share - 0.2).abs() < 0.02, "{o:?}");
        assert!(o.worth_a_warning() && !o.is_the_cause(), "{o:?}");
    }

    #[test]
    fn missing_readings_leave_their_windows_unjudged() {
        let mut s = recording(18.0, |_| true);
        for x in &mut s[..30_000] {
            x.u_valve = None;
        }
        let o = measure(&s).unwrap();
        assert!((o.windows as f64 - 150.0).abs() <= 1.0, "{o:?}");
        assert!(o.share > 0.99, "{o:?}");
        for x in &mut s {
            x.p_supply_bar = None;
        }
        assert_eq!(measure(&s), None);
    }
}
