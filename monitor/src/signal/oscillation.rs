//! Does the machine's position loop hunt?
//!
//! A position loop tuned at one supply pressure can hunt at a higher one
//! (the valve's flow gain grows with √Δp): the valve command swings a few
//! per cent of its travel at 10–30 Hz and the chamber pressures with it by
//! tens of bar. No sample of such a stretch counts as leak evidence (the
//! evidence weight falls with the chamber pressures' rate), so the verdict
//! stays `inconclusive`; this says why, on the device
//! ([`health::LOOP_OSCILLATING`](crate::status::health::LOOP_OSCILLATING))
//! as in calibration's and replay's reports (`host-sim`, which judges its
//! windows with [`window_oscillates`] too).
//!
//! Time is cut into [`WINDOW_S`] windows; in each, the chamber pressures
//! and the valve command are taken about their least-squares line (a
//! steady move or a pressure ramp leaves nothing). A window oscillates
//! when a chamber pressure swings (rms) at least [`CHAMBER_SWING_SHARE`]
//! of the window's supply pressure while the command swings at least
//! [`COMMAND_SWING`]: pump ripple moves the pressures without the
//! command, a noisy command reading moves no pressure.

use crate::real::Real;
use crate::signal::Conditioned;

/// Length of the windows, s: several periods of a 10–30 Hz oscillation.
pub const WINDOW_S: f64 = 0.2;
/// Chamber-pressure swing (rms about the window's trend), relative to the
/// supply pressure, from which a window oscillates. On the tuning rigs'
/// 60 s calibration recordings, loops that hunt swing the chambers by
/// 26–46 bar at 100 bar; at 50 bar a settled loop's valve steps move them
/// by 4–6 bar.
pub const CHAMBER_SWING_SHARE: f64 = 0.10;
/// Valve-command swing (rms about the window's trend) from which a window
/// oscillates: 0.5 % of the travel; the hunting loops above, 2–6 %.
pub const COMMAND_SWING: f64 = 0.005;
/// Share of the recent windows ([`RECENT_WINDOWS`]) that oscillate from
/// which the loop is said to hunt; calibration names the oscillation as
/// the cause of a refusal from the same share of its recording (the
/// calibrated tuning cells hunt at most 59 % of the time, the refused ones
/// 71–95 %).
pub const HUNTING_SHARE: f64 = 0.5;
/// The flag goes off again below this share (hysteresis).
pub const SETTLED_SHARE: f64 = 0.25;
/// Windows over which the recent share is averaged (exponentially): 2 s.
pub const RECENT_WINDOWS: f64 = 10.0;

/// Does a window oscillate: its supply pressure `supply_bar`, the larger
/// chamber-pressure swing `chamber_swing_bar` and the command's swing
/// (both rms about the window's least-squares line)?
pub fn window_oscillates<T: Real>(supply_bar: T, chamber_swing_bar: T, command_swing: T) -> bool {
    supply_bar > T::ZERO
        && chamber_swing_bar >= T::c(CHAMBER_SWING_SHARE) * supply_bar
        && command_swing >= T::c(COMMAND_SWING)
}

/// Running sums of one signal `y` over the window's time τ: Σy, Στy, Σy².
#[derive(Clone, Copy, Debug, Default)]
struct Sums<T> {
    y: T,
    ty: T,
    yy: T,
}

impl<T: Real> Sums<T> {
    #[inline(always)]
    fn add(&mut self, tau: T, y: T) {
        self.y += y;
        self.ty += tau * y;
        self.yy += y * y;
    }
}

/// The least-squares line of a signal over a window: its value at the
/// window's mean time and its slope.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line<T> {
    /// Mean time τ̄ of the window, s (from its start).
    pub tau_mean: T,
    /// The signal's mean (the line's value at τ̄).
    pub mean: T,
    /// Slope, per s.
    pub slope: T,
}

impl<T: Real> Line<T> {
    /// The line's value at time `tau` into the window.
    pub fn at(&self, tau: T) -> T {
        self.mean + self.slope * (tau - self.tau_mean)
    }
}

/// One window judged ([`Window::judge`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Judged<T> {
    /// Mean supply pressure, bar.
    pub supply_bar: T,
    /// The larger chamber-pressure swing about its line (rms), bar.
    pub chamber_swing_bar: T,
    /// The command's swing about its line (rms).
    pub command_swing: T,
    /// The command's line (its residuals give the oscillation's cycles).
    pub command_line: Line<T>,
    /// [`window_oscillates`] for the above.
    pub oscillates: bool,
}

/// One window's running sums over its time τ (s from the window's start):
/// constant memory, one pass. The device's [`LoopWatch`] and calibration's
/// meter (`host-sim`, which also counts the command's cycles) judge their
/// windows with it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Window<T> {
    /// Samples, Στ, Στ².
    n: T,
    t: T,
    tt: T,
    supply: T,
    piston: Sums<T>,
    rod: Sums<T>,
    command: Sums<T>,
}

impl<T: Real> Window<T> {
    /// Take the readings at `tau` s into the window: supply, piston and
    /// rod chamber pressures (bar) and the valve command.
    #[inline(always)]
    pub fn add(&mut self, tau: T, supply_bar: T, piston_bar: T, rod_bar: T, command: T) {
        self.n += T::ONE;
        self.t += tau;
        self.tt += tau * tau;
        self.supply += supply_bar;
        self.piston.add(tau, piston_bar);
        self.rod.add(tau, rod_bar);
        self.command.add(tau, command);
    }

    /// Judge the window; `None` with fewer than [`MIN_WINDOW_SAMPLES`].
    pub fn judge(&self) -> Option<Judged<T>> {
        let n = self.n;
        if n < T::c(MIN_WINDOW_SAMPLES as f64) {
            return None;
        }
        let tau_mean = self.t / n;
        let stt = self.tt - self.t * tau_mean;
        // Slope and variance about the line, from the centred sums.
        let fit = |s: &Sums<T>| {
            let mean = s.y / n;
            let syy = s.yy - s.y * mean;
            let sty = s.ty - self.t * mean;
            let (slope, explained) = if stt > T::ZERO {
                (sty / stt, sty * sty / stt)
            } else {
                (T::ZERO, T::ZERO)
            };
            let swing = ((syy - explained) / n).max(T::ZERO).sqrt();
            (
                Line {
                    tau_mean,
                    mean,
                    slope,
                },
                swing,
            )
        };
        let (_, piston) = fit(&self.piston);
        let (_, rod) = fit(&self.rod);
        let (command_line, command_swing) = fit(&self.command);
        let supply_bar = self.supply / n;
        let chamber_swing_bar = piston.max(rod);
        Some(Judged {
            supply_bar,
            chamber_swing_bar,
            command_swing,
            command_line,
            oscillates: window_oscillates(supply_bar, chamber_swing_bar, command_swing),
        })
    }
}

/// Watches the loop sample by sample in constant memory: one window's
/// running sums, and the recent share of oscillating windows.
#[derive(Clone, Debug, Default)]
pub struct LoopWatch<T> {
    /// Time into the window, s.
    tau: T,
    window: Window<T>,
    /// Exponential share of the recent windows that oscillated.
    share: T,
    hunting: bool,
}

/// Fewest readings a window needs to be judged.
pub const MIN_WINDOW_SAMPLES: usize = 20;

impl<T: Real> LoopWatch<T> {
    /// Take one conditioned sample, `dt_s` after the previous one; returns
    /// whether the loop hunts (the recent share of oscillating windows
    /// reached [`HUNTING_SHARE`] and has not fallen below
    /// [`SETTLED_SHARE`] since).
    pub fn update(&mut self, dt_s: T, c: &Conditioned) -> bool {
        self.tau += dt_s;
        if self.tau >= T::c(WINDOW_S) {
            self.judge();
        }
        self.window.add(
            self.tau,
            T::from_f32(c.p_supply_bar),
            T::from_f32(c.p_piston_bar),
            T::from_f32(c.p_rod_bar),
            T::from_f32(c.u_valve),
        );
        self.hunting
    }

    /// A reading was missing (a fault, a gap): the window is not judged;
    /// the recent share is kept.
    pub fn break_window(&mut self) {
        self.tau = T::ZERO;
        self.window = Window::default();
    }

    /// Judge the window that just ended and start the next one.
    fn judge(&mut self) {
        if let Some(j) = self.window.judge() {
            let a = T::c(1.0 / RECENT_WINDOWS);
            let x = if j.oscillates { T::ONE } else { T::ZERO };
            self.share += a * (x - self.share);
            self.hunting = if self.hunting {
                self.share >= T::c(SETTLED_SHARE)
            } else {
                self.share >= T::c(HUNTING_SHARE)
            };
        }
        self.break_window();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    /// A sample at `t` s, 100 bar supply: hunting at `hz` (chambers ±30
    /// bar, command ±0.04) or moving smoothly, with ±2 bar of pump ripple
    /// at 150 Hz that does not move the command.
    fn sample(t: f64, hunting: Option<f64>) -> Conditioned {
        let move_ = 20.0 * (0.3 * t).sin();
        let ripple = 2.0 * (2.0 * PI * 150.0 * t).sin();
        let (dp, du) = match hunting {
            Some(hz) => {
                let s = (2.0 * PI * hz * t).sin();
                (30.0 * s, 0.04 * s)
            }
            None => (0.0, 0.0),
        };
        Conditioned {
            p_supply_bar: 100.0,
            p_piston_bar: (50.0 + move_ + ripple + dp) as f32,
            p_rod_bar: (40.0 - move_ + ripple - dp) as f32,
            p_tank_bar: 1.0,
            x_piston_m: 0.09,
            u_valve: (0.02 * (0.3 * t).cos() + du) as f32,
            temp_oil_c: None,
        }
    }

    /// Run `secs` s at 1 kHz from `t0`, returning the flag at the end and
    /// whether it was ever set.
    fn run(w: &mut LoopWatch<f32>, t0: f64, secs: f64, hunting: Option<f64>) -> (bool, bool) {
        let mut ever = false;
        let mut now = false;
        for k in 0..(secs * 1000.0) as usize {
            now = w.update(0.001, &sample(t0 + k as f64 * 1e-3, hunting));
            ever |= now;
        }
        (now, ever)
    }

    #[test]
    fn a_loop_that_hunts_is_flagged_within_two_seconds_and_released_when_it_settles() {
        let mut w = LoopWatch::<f32>::default();
        assert_eq!(
            run(&mut w, 0.0, 10.0, None),
            (false, false),
            "settled, ripple only"
        );
        let (now, _) = run(&mut w, 10.0, 2.0, Some(17.0));
        assert!(now, "hunting at 17 Hz for 2 s");
        let (_, ever) = run(&mut w, 12.0, 1.0, None);
        assert!(ever, "hysteresis: not dropped at the first settled window");
        let (now, _) = run(&mut w, 13.0, 5.0, None);
        assert!(!now, "settled again for 5 s");
    }

    #[test]
    fn ripple_without_command_and_command_noise_without_pressure_are_no_hunting() {
        let mut w = LoopWatch::<f32>::default();
        // Pressures swinging ±30 bar with a still command (pump ripple).
        let mut hunting = false;
        for k in 0..10_000 {
            let t = k as f64 * 1e-3;
            let mut c = sample(t, Some(17.0));
            c.u_valve = 0.01;
            hunting |= w.update(0.001, &c);
        }
        assert!(!hunting);
        // A command swinging ±0.04 that moves no pressure.
        let mut w = LoopWatch::<f32>::default();
        for k in 0..10_000 {
            let t = k as f64 * 1e-3;
            let mut c = sample(t, None);
            c.u_valve = (0.04 * (2.0 * PI * 17.0 * t).sin()) as f32;
            hunting |= w.update(0.001, &c);
        }
        assert!(!hunting);
    }

    #[test]
    fn a_steady_ramp_leaves_no_swing() {
        // Pressures and command on straight lines: nothing about the line.
        let mut w = LoopWatch::<f32>::default();
        for k in 0..10_000 {
            let t = k as f64 * 1e-3;
            let c = Conditioned {
                p_supply_bar: 100.0,
                p_piston_bar: (10.0 + 8.0 * t) as f32,
                p_rod_bar: (90.0 - 8.0 * t) as f32,
                p_tank_bar: 1.0,
                x_piston_m: 0.09,
                u_valve: (0.3 * t - 1.0).clamp(-1.0, 1.0) as f32,
                temp_oil_c: None,
            };
            assert!(!w.update(0.001, &c), "{t}");
        }
    }

    #[test]
    fn a_broken_window_is_not_judged_but_the_recent_share_stays() {
        let mut w = LoopWatch::<f32>::default();
        let (hunting, _) = run(&mut w, 0.0, 3.0, Some(17.0));
        assert!(hunting);
        let share = w.share;
        // Gaps every 15 samples: no window gets 20 readings.
        let mut hunting = false;
        for k in 0..5_000 {
            if k % 15 == 0 {
                w.break_window();
            }
            hunting = w.update(0.001, &sample(3.0 + k as f64 * 1e-3, None));
        }
        assert_eq!(w.share, share);
        assert!(hunting);
    }
}
