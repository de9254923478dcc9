//! The regressions' data: smoothed signals, quasi-steady samples, and what motion they hold.

use super::{Steadiness, FLOWING, HALF_WINDOW, MIN_SPEED, SETTLED, STRIDE};
use monitor::Sample;

/// Signals derived from a recording for the regressions.
pub struct Prepared {
    pub(super) p2: Vec<f64>,
    pub(super) p3: Vec<f64>,
    pub(super) p4: Vec<f64>,
    pub(super) p5: Vec<f64>,
    pub(super) x: Vec<f64>,
    pub(super) u: Vec<f64>,
    /// Indices of quasi-steady moving samples ([`FLOWING`]): the valve's.
    pub steady: Vec<usize>,
    /// The settled ones among them ([`SETTLED`]): the force balance's.
    pub settled: Vec<usize>,
    pub(super) v: Vec<f64>,
    /// Rates of the chamber pressures, bar/s (piston, rod).
    pub(super) dp3: Vec<f64>,
    pub(super) dp4: Vec<f64>,
    /// Time each steady sample stands for, s.
    pub stride_s: f64,
    /// Time at rest (smoothed speed below `MIN_SPEED`), s.
    pub hold_s: f64,
    /// Time moving out / in (smoothed speed at least `MIN_SPEED`), s.
    pub moving_s: [f64; 2],
}

fn moving_average(y: &[f64], h: usize) -> Vec<f64> {
    let n = y.len();
    let mut prefix = vec![0.0; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + y[i];
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(h);
            let hi = (i + h + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// `prepare` each contiguous piece of a recording, as one data set.
pub fn prepare_pieces(pieces: &[&[Sample]]) -> Prepared {
    let mut all = prepare(&[]);
    let (mut period_sum, mut n_sum) = (0.0, 0usize);
    for piece in pieces {
        let d = prepare(piece);
        let offset = all.p2.len();
        all.steady.extend(d.steady.iter().map(|i| i + offset));
        all.settled.extend(d.settled.iter().map(|i| i + offset));
        for (to, from) in [
            (&mut all.p2, d.p2),
            (&mut all.p3, d.p3),
            (&mut all.p4, d.p4),
            (&mut all.p5, d.p5),
            (&mut all.x, d.x),
            (&mut all.u, d.u),
            (&mut all.v, d.v),
            (&mut all.dp3, d.dp3),
            (&mut all.dp4, d.dp4),
        ] {
            to.extend(from);
        }
        all.hold_s += d.hold_s;
        all.moving_s[0] += d.moving_s[0];
        all.moving_s[1] += d.moving_s[1];
        period_sum += d.stride_s * piece.len() as f64;
        n_sum += piece.len();
    }
    all.stride_s = period_sum / n_sum.max(1) as f64;
    all
}

/// Smooth the recording and find its quasi-steady moves.
pub fn prepare(samples: &[Sample]) -> Prepared {
    let get = |f: fn(&Sample) -> Option<f32>| -> Vec<f64> {
        samples
            .iter()
            .map(|s| f(s).unwrap_or(f32::NAN) as f64)
            .collect()
    };
    let t: Vec<f64> = samples.iter().map(|s| s.t_s).collect();
    let h = HALF_WINDOW;
    let p2 = moving_average(&get(|s| s.p_supply_bar), h);
    let p3 = moving_average(&get(|s| s.p_piston_bar), h);
    let p4 = moving_average(&get(|s| s.p_rod_bar), h);
    let p5 = moving_average(&get(|s| s.p_tank_bar), h);
    let x = moving_average(&get(|s| s.x_piston_m), h);
    let u = moving_average(&get(|s| s.u_valve), h);
    let n = samples.len();
    let mut v = vec![0.0; n];
    let mut a = vec![f64::NAN; n];
    let (mut dp3, mut dp4) = (vec![0.0; n], vec![0.0; n]);
    for i in h..n.saturating_sub(h) {
        let dt = t[i + h] - t[i - h];
        v[i] = (x[i + h] - x[i - h]) / dt;
        dp3[i] = (p3[i + h] - p3[i - h]) / dt;
        dp4[i] = (p4[i + h] - p4[i - h]) / dt;
    }
    for i in 2 * h..n.saturating_sub(2 * h) {
        a[i] = (v[i + h] - v[i - h]) / (t[i + h] - t[i - h]);
    }
    let (mut steady, mut settled) = (Vec::new(), Vec::new());
    let span = 6 * h;
    for i in (span..n.saturating_sub(span)).step_by(STRIDE) {
        let all_valid = [p2[i], p3[i], p4[i], p5[i], x[i], u[i]]
            .iter()
            .all(|v| v.is_finite());
        let same_direction =
            v[i - span].signum() == v[i].signum() && v[i + span].signum() == v[i].signum();
        if !all_valid || v[i].abs() < MIN_SPEED || !same_direction {
            continue;
        }
        let du = (u[i + span] - u[i - span]).abs();
        let dp = chamber_pressure_change(&p3, &p4, i, span);
        let within =
            |lim: Steadiness| a[i].abs() < lim.accel && du < lim.command && dp < lim.pressure_bar;
        if within(FLOWING) {
            steady.push(i);
        }
        if within(SETTLED) {
            settled.push(i);
        }
    }
    let period = if n > 1 {
        (t[n - 1] - t[0]) / (n - 1) as f64
    } else {
        0.0
    };
    let inner = v.get(h..n.saturating_sub(h)).unwrap_or(&[]);
    let time_where = |f: fn(f64) -> bool| inner.iter().filter(|&&v| f(v)).count() as f64 * period;
    Prepared {
        hold_s: time_where(|v| v.abs() < MIN_SPEED),
        moving_s: [
            time_where(|v| v >= MIN_SPEED),
            time_where(|v| v <= -MIN_SPEED),
        ],
        p2,
        p3,
        p4,
        p5,
        x,
        u,
        steady,
        settled,
        v,
        dp3,
        dp4,
        stride_s: STRIDE as f64 * period,
    }
}

/// The larger change of the two (smoothed) chamber pressures `p3`, `p4`
/// from `span` samples before `i` to `span` after, bar.
pub(super) fn chamber_pressure_change(p3: &[f64], p4: &[f64], i: usize, span: usize) -> f64 {
    (p3[i + span] - p3[i - span])
        .abs()
        .max((p4[i + span] - p4[i - span]).abs())
}

/// What motion a recording holds, for the engineer and the refusal.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Motion {
    /// Quasi-steady extending moves, s.
    pub extend_s: f64,
    /// Quasi-steady retracting moves, s.
    pub retract_s: f64,
    /// Spread (σ) of the command over the steady extending samples.
    pub extend_spread: f64,
    /// As above, retracting (of −u).
    pub retract_spread: f64,
    /// Time at rest, s.
    pub hold_s: f64,
    /// Time moving out / in at [`MIN_SPEED`] or faster, steady or not
    /// (a stick-slipping or hunting piston moves without being steady), s.
    pub moving_s: [f64; 2],
}

impl Motion {
    /// Measure the motion of prepared data.
    pub fn of(d: &Prepared) -> Self {
        let sd = |pts: Vec<f64>| {
            let n = pts.len() as f64;
            if pts.len() < 2 {
                return 0.0;
            }
            let m = pts.iter().sum::<f64>() / n;
            (pts.iter().map(|u| (u - m).powi(2)).sum::<f64>() / n).sqrt()
        };
        let ext: Vec<f64> = d
            .steady
            .iter()
            .filter(|&&i| d.v[i] > 0.0)
            .map(|&i| d.u[i])
            .collect();
        let ret: Vec<f64> = d
            .steady
            .iter()
            .filter(|&&i| d.v[i] < 0.0)
            .map(|&i| d.u[i])
            .collect();
        Self {
            extend_s: ext.len() as f64 * d.stride_s,
            retract_s: ret.len() as f64 * d.stride_s,
            extend_spread: sd(ext),
            retract_spread: sd(ret),
            hold_s: d.hold_s,
            moving_s: d.moving_s,
        }
    }
}
