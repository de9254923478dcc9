//! Setpoint profiles of the scenarios: piecewise-linear position setpoints
//! (holds and constant-speed moves), and the open-loop step.

use crate::rng::{stream, Rand};
use crate::Scenario;

/// Lowest and highest setpoints of a work cycle, m.
pub const WORK_RANGE_M: [f64; 2] = [0.01, 0.17];

/// A piecewise-linear setpoint: knots (t s, x m), held after the last.
#[derive(Clone, Debug)]
pub(crate) struct Profile {
    knots: Vec<(f64, f64)>,
    cursor: usize,
    /// Run length, s.
    pub duration_s: f64,
    /// Open-loop step: (time s, command).
    pub step: Option<(f64, f64)>,
}

/// Build moves: hold 1–8 s, then move at slow (5–30 mm/s) or fast
/// (30–100 mm/s) speed to a new target in the work range, until `until`.
fn work_cycle(r: &mut Rand, knots: &mut Vec<(f64, f64)>, until: f64) {
    loop {
        let &(t, x) = knots.last().expect("a start knot");
        if t >= until {
            return;
        }
        let hold = r.uniform(1.0, 8.0);
        knots.push((t + hold, x));
        let mut target = r.uniform(WORK_RANGE_M[0], WORK_RANGE_M[1]);
        if (target - x).abs() < 0.01 {
            target = if x > 0.09 { x - 0.03 } else { x + 0.03 };
        }
        let speed = if r.chance(0.5) {
            r.uniform(0.005, 0.03)
        } else {
            r.uniform(0.03, 0.1)
        };
        knots.push((t + hold + (target - x).abs() / speed, target));
    }
}

impl Profile {
    pub(crate) fn new(scenario: &Scenario) -> Self {
        match *scenario {
            Scenario::ClosedLoop { duration_s, seed } => {
                let mut r = Rand::new(seed, stream::PROFILE);
                let mut knots = vec![(0.0, r.uniform(0.04, 0.14))];
                work_cycle(&mut r, &mut knots, duration_s);
                Self {
                    knots,
                    cursor: 0,
                    duration_s,
                    step: None,
                }
            }
            Scenario::LongHold { hold_s, seed } => {
                let mut r = Rand::new(seed, stream::PROFILE);
                let mut knots = vec![(0.0, r.uniform(0.04, 0.14))];
                let pre = r.uniform(8.0, 15.0);
                work_cycle(&mut r, &mut knots, pre);
                let &(t, x) = knots.last().expect("knots");
                let xh = r.uniform(0.06, 0.12);
                let t1 = t + 1.0 + (xh - x).abs() / 0.02;
                knots.push((t + 1.0, x));
                knots.push((t1, xh));
                knots.push((t1 + hold_s, xh));
                let t_end = t1 + hold_s + r.uniform(8.0, 15.0);
                work_cycle(&mut r, &mut knots, t_end);
                Self {
                    knots,
                    cursor: 0,
                    duration_s: t_end,
                    step: None,
                }
            }
            Scenario::StepTest {
                duration_s,
                step_at_s,
                amplitude,
            } => Self {
                knots: vec![(0.0, 0.09)],
                cursor: 0,
                duration_s,
                step: Some((step_at_s, amplitude)),
            },
        }
    }

    /// Setpoint (m) and its speed (m/s) at `t` (s); `t` must not decrease
    /// between calls (a cursor walks the knots).
    pub(crate) fn at(&mut self, t: f64) -> (f64, f64) {
        let k = &self.knots;
        if t <= k[0].0 {
            return (k[0].1, 0.0);
        }
        while self.cursor + 1 < k.len() && k[self.cursor + 1].0 <= t {
            self.cursor += 1;
        }
        let i = self.cursor;
        if i + 1 >= k.len() {
            return (k[i].1, 0.0);
        }
        let (t0, x0) = k[i];
        let (t1, x1) = k[i + 1];
        let v = (x1 - x0) / (t1 - t0);
        (x0 + v * (t - t0), v)
    }

    /// The first setpoint, m.
    pub(crate) fn start(&self) -> f64 {
        self.knots[0].1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(p: &mut Profile, dt: f64) -> Vec<(f64, f64)> {
        let n = (p.duration_s / dt) as usize;
        (0..n).map(|k| p.at(k as f64 * dt)).collect()
    }

    #[test]
    fn work_cycles_stay_in_range_move_both_ways_at_the_drawn_speeds() {
        for seed in 0..20 {
            let mut p = Profile::new(&Scenario::ClosedLoop {
                duration_s: 120.0,
                seed,
            });
            let s = sample(&mut p, 0.01);
            assert!(s
                .iter()
                .all(|&(x, _)| (WORK_RANGE_M[0]..=WORK_RANGE_M[1]).contains(&x)));
            let vmax = s.iter().map(|&(_, v)| v.abs()).fold(0.0, f64::max);
            assert!(vmax <= 0.1 + 1e-9, "{vmax}");
            assert!(s.iter().any(|&(_, v)| v > 0.004));
            assert!(s.iter().any(|&(_, v)| v < -0.004));
            let moving = s.iter().filter(|&&(_, v)| v != 0.0).count();
            assert!(moving > 0 && moving < s.len());
        }
    }

    #[test]
    fn a_long_hold_holds_mid_stroke_for_its_length() {
        for seed in 0..5 {
            let mut p = Profile::new(&Scenario::LongHold {
                hold_s: 600.0,
                seed,
            });
            let s = sample(&mut p, 0.1);
            // The longest run of a constant setpoint.
            let (mut best, mut run) = (0, 0);
            for w in s.windows(2) {
                run = if w[1].0 == w[0].0 { run + 1 } else { 0 };
                best = best.max(run);
            }
            // The hold, then the first 1–8 s hold of the moves after it.
            let held = best as f64 * 0.1;
            assert!((599.8..=608.2).contains(&held), "{held}");
            assert!(p.duration_s > 616.0 && p.duration_s < 640.0);
            let x_hold = s[s.len() / 2].0;
            assert!((0.06..=0.12).contains(&x_hold));
        }
    }
}
