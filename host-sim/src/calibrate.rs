//! `host-sim calibrate`: fit one installation's parameters from a recording
//! of it known to be leak-free.
//!
//! Real installations differ from the reference rig: the valve's flow
//! coefficients, dead zone and null, the load, friction, the oil's air
//! content, sensor offsets. The fit proceeds in physically separable steps,
//! each a small least-squares problem with a quality figure, so that an
//! engineer can see what was fitted from what:
//!
//! 1. **Valve**, from quasi-steady moves in each direction: chamber
//!    continuity gives the metering flow of each edge from the piston
//!    velocity; regressing flow/√Δp on the command gives the flow gain
//!    (slope) and where the edge opens (intercept), hence the dead zone and
//!    the null bias, and the rod-side/piston-side edge ratio.
//! 2. **Load and friction**, from the force balance on the same samples:
//!    gravity scale (also taken as the moving-mass scale), Coulomb and
//!    viscous friction.
//! 3. **Oil**: the entrained-air fraction minimising the healthy filter's
//!    normalised innovations over the whole recording (golden-section
//!    search).
//! 4. **Healthy baseline**: the monitor runs over the recording with the
//!    fitted parameters; the mean leak coefficients its `both` filter still
//!    estimates become the installation's healthy seal and rod-side leakage,
//!    so the same installation reads zero leak. This absorbs what the model
//!    cannot represent (sensor offsets among it) into the baseline.

use monitor::load::load_terms_exact;
use monitor::model::{stribeck_decay, BAR, LEAK_UNIT, LPM_PER_M3S};
use monitor::valve::orifice;
use monitor::{Monitor, Params, Sample};

/// Why a recording cannot be used for calibration.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// Too little data.
    #[error("the recording is too short for calibration: {0:.1} s, need at least {1:.0} s of healthy operation")]
    TooShort(f64, f64),
    /// No quasi-steady moves in either direction.
    #[error("no quasi-steady moves found: calibration needs the cylinder to extend and retract at steady speeds")]
    NoMotion,
    /// The starting parameters are invalid.
    #[error("{0}")]
    Params(monitor::params::ParamError),
}

/// One fitted quantity with its fit quality.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Fit {
    /// What was fitted.
    pub what: String,
    /// The result, in the parameter's unit.
    pub value: String,
    /// Quality: samples used, R², residual.
    pub quality: String,
}

/// The outcome of a calibration.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// The fitted parameters.
    pub params: Params,
    /// What was fitted, one line each.
    pub fits: Vec<Fit>,
    /// Things the engineer should know (insufficient data, implausible
    /// results kept at their previous values).
    pub warnings: Vec<String>,
    /// Leak estimates on the calibration recording before and after
    /// (max |fast average| over the run, internal and external, l/min).
    pub leak_before_lpm: [f64; 2],
    /// As above, after calibration.
    pub leak_after_lpm: [f64; 2],
    /// Mean NIS of the healthy filter before and after (≈ 3 is a
    /// consistent model).
    pub nis_before: f64,
    /// As above, after.
    pub nis_after: f64,
}

/// Minimum recording length, s.
const MIN_DURATION_S: f64 = 20.0;
/// Samples each side of the centre for smoothing/differentiation.
const HALF_WINDOW: usize = 15;
/// Minimum piston speed of a steady sample, m/s.
const MIN_SPEED: f64 = 0.003;

/// Signals derived from a recording for the regressions.
struct Prepared {
    p2: Vec<f64>,
    p3: Vec<f64>,
    p4: Vec<f64>,
    p5: Vec<f64>,
    x: Vec<f64>,
    u: Vec<f64>,
    /// Indices of quasi-steady moving samples.
    steady: Vec<usize>,
    v: Vec<f64>,
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

fn prepare(samples: &[Sample]) -> Prepared {
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
    for i in h..n.saturating_sub(h) {
        v[i] = (x[i + h] - x[i - h]) / (t[i + h] - t[i - h]);
    }
    for i in 2 * h..n.saturating_sub(2 * h) {
        a[i] = (v[i + h] - v[i - h]) / (t[i + h] - t[i - h]);
    }
    let mut steady = Vec::new();
    let span = 6 * h;
    for i in (span..n.saturating_sub(span)).step_by(5) {
        let all_valid = [p2[i], p3[i], p4[i], p5[i], x[i], u[i]]
            .iter()
            .all(|v| v.is_finite());
        if !all_valid || v[i].abs() < MIN_SPEED || !(a[i].abs() < 0.02) {
            continue;
        }
        // Steady command and pressures over ±90 ms.
        let du = (u[i + span] - u[i - span]).abs();
        let dp = (p3[i + span] - p3[i - span])
            .abs()
            .max((p4[i + span] - p4[i - span]).abs());
        let same_direction =
            v[i - span].signum() == v[i].signum() && v[i + span].signum() == v[i].signum();
        if du < 0.01 && dp < 1.0 && same_direction {
            steady.push(i);
        }
    }
    Prepared {
        p2,
        p3,
        p4,
        p5,
        x,
        u,
        steady,
        v,
    }
}

/// Least squares y = a + b·x with weights; returns (a, b, r², rms).
fn line_fit(pts: &[(f64, f64)]) -> Option<(f64, f64, f64, f64)> {
    let n = pts.len() as f64;
    if pts.len() < 20 {
        return None;
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in pts {
        sxx += (x - mx) * (x - mx);
        sxy += (x - mx) * (y - my);
        syy += (y - my) * (y - my);
    }
    if !(sxx > 0.0) {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let rss: f64 = pts.iter().map(|(x, y)| (y - a - b * x).powi(2)).sum();
    let r2 = if syy > 0.0 { 1.0 - rss / syy } else { 0.0 };
    Some((a, b, r2, (rss / n).sqrt()))
}

/// Least squares through the origin y = k·x; returns k.
fn ratio_fit(pts: &[(f64, f64)]) -> Option<f64> {
    let (sxy, sxx) = pts
        .iter()
        .fold((0.0, 0.0), |s, (x, y)| (s.0 + x * y, s.1 + x * x));
    (pts.len() >= 20 && sxx > 0.0).then(|| sxy / sxx)
}

/// Solve the small normal equations A·θ = b by Gaussian elimination with
/// partial pivoting.
fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 1e-12) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..N {
            let f = a[r][c] / a[c][c];
            for k in c..N {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; N];
    for r in (0..N).rev() {
        let s: f64 = (r + 1..N).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// Flow gain per edge, l/min/√bar, from m³/(s·√Pa).
fn kv_to_lpm(kv: f64) -> f64 {
    kv * LPM_PER_M3S * BAR.sqrt()
}

fn fit_valve(d: &Prepared, p: &mut Params, fits: &mut Vec<Fit>, warnings: &mut Vec<String>) {
    let c = &p.cylinder;
    let k_edge = p.valve.edge_leak_lpm_per_bar / LPM_PER_M3S / BAR;
    let k_seal = p.leakage.seal_lpm_per_bar / LPM_PER_M3S / BAR;
    let k_ext = p.leakage.external_lpm_per_bar / LPM_PER_M3S / BAR;
    let delta = p.valve.laminar_dp_bar * BAR;
    let g = |dp: f64| orifice(dp, delta, delta.sqrt()).0;
    let (mut ext_a, mut ext_b, mut ret_a, mut ret_b) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &i in &d.steady {
        let (p2, p3, p4, p5) = (d.p2[i] * BAR, d.p3[i] * BAR, d.p4[i] * BAR, d.p5[i] * BAR);
        let v = d.v[i];
        let seal = k_seal * (p3 - p4);
        // Metering flow into A and into B from steady continuity.
        let q_a = c.piston_area_m2 * v + seal - k_edge * (p2 + p5 - 2.0 * p3);
        let q_b =
            -c.rod_side_area_m2 * v - seal - k_edge * (p2 + p5 - 2.0 * p4) + k_ext * (p4 - p5);
        let u = d.u[i];
        if v > 0.0 && p2 - p3 > 2.0 * BAR && p4 - p5 > 2.0 * BAR {
            ext_a.push((u, q_a / g(p2 - p3)));
            ext_b.push((u, -q_b / g(p4 - p5)));
        } else if v < 0.0 && p3 - p5 > 2.0 * BAR && p2 - p4 > 2.0 * BAR {
            ret_a.push((-u, -q_a / g(p3 - p5)));
            ret_b.push((-u, q_b / g(p2 - p4)));
        }
    }
    // Each direction: y = Kv·(±u − edge): slope Kv, edge = −a/b.
    let mut edges = [None, None];
    for (dir, a_pts, b_pts) in [(0, &ext_a, &ext_b), (1, &ret_a, &ret_b)] {
        let name = if dir == 0 {
            "extend (P→A, B→T)"
        } else {
            "retract (P→B, A→T)"
        };
        let Some((a, b, r2, rms)) = line_fit(a_pts) else {
            warnings.push(format!(
                "valve {name}: only {} quasi-steady samples; flow gain and edge kept",
                a_pts.len()
            ));
            continue;
        };
        let kv_lpm = kv_to_lpm(b);
        let nominal = if dir == 0 {
            p.valve.flow_gain_extend_lpm_sqrt_bar
        } else {
            p.valve.flow_gain_retract_lpm_sqrt_bar
        };
        let edge = -a / b;
        if !(kv_lpm > 0.5 * nominal
            && kv_lpm < 2.0 * nominal
            && edge > -0.05
            && edge < 0.1
            && r2 > 0.8)
        {
            warnings.push(format!(
                "valve {name}: implausible fit (gain {kv_lpm:.3} l/min/√bar, edge {edge:.4}, R² {r2:.3}); kept"
            ));
            continue;
        }
        let ratio = ratio_fit(
            &b_pts
                .iter()
                .map(|(u, y)| (u - edge, *y))
                .collect::<Vec<_>>(),
        )
        .map(|k| k / b);
        if dir == 0 {
            p.valve.flow_gain_extend_lpm_sqrt_bar = kv_lpm;
        } else {
            p.valve.flow_gain_retract_lpm_sqrt_bar = kv_lpm;
        }
        edges[dir] = Some(edge);
        let rms_lpm = rms * LPM_PER_M3S * (30.0 * BAR).sqrt();
        fits.push(Fit {
            what: format!("valve flow gain, {name}"),
            value: format!(
                "{kv_lpm:.4} l/min/√bar ({:+.1} % of previous)",
                100.0 * (kv_lpm / nominal - 1.0)
            ),
            quality: format!(
                "{} samples, R² {r2:.4}, residual ≈ {rms_lpm:.3} l/min at 30 bar",
                a_pts.len()
            ),
        });
        match ratio {
            Some(k) if k > 0.8 && k < 1.25 => {
                if dir == 0 {
                    p.valve.rod_edge_gain_extend = k;
                } else {
                    p.valve.rod_edge_gain_retract = k;
                }
                fits.push(Fit {
                    what: format!("rod-side edge / piston-side edge, {name}"),
                    value: format!("{k:.4}"),
                    quality: format!("{} samples", b_pts.len()),
                });
            }
            other => warnings.push(format!(
                "valve {name}: rod-side edge ratio {other:?} implausible; kept"
            )),
        }
    }
    match edges {
        [Some(e_ext), Some(e_ret)] => {
            // Edges open at u = dz − null (extend) and u = −(dz + null).
            let dz = 0.5 * (e_ext + e_ret);
            let null = 0.5 * (e_ret - e_ext);
            if (0.0..0.08).contains(&dz) && null.abs() < 0.03 {
                p.valve.dead_zone = dz;
                p.valve.null_offset = null;
                fits.push(Fit {
                    what: "valve dead zone and null".into(),
                    value: format!("dead zone {dz:.4}, null {null:+.4} (fraction of travel)"),
                    quality: format!("edges at u = {e_ext:+.4} / {:+.4}", -e_ret),
                });
            } else {
                warnings.push(format!(
                    "valve dead zone {dz:.4} / null {null:.4} implausible; kept"
                ));
            }
        }
        _ => warnings.push("dead zone and null need moves in both directions; kept".into()),
    }
}

fn fit_load(d: &Prepared, p: &mut Params, fits: &mut Vec<Fit>, warnings: &mut Vec<String>) {
    let c = &p.cylinder;
    let fr = &p.friction;
    let ratio = if fr.coulomb_n > 0.0 {
        fr.breakaway_n / fr.coulomb_n
    } else {
        1.0
    };
    let mut geo = p.load.clone();
    geo.gravity_scale = 1.0;
    geo.inertia_scale = 1.0;
    geo.force_offset_n = 0.0;
    // Normal equations for y = s·G0(x) + Fc·φ(v) + B·v.
    let mut ata = [[0.0; 3]; 3];
    let mut atb = [0.0; 3];
    let mut rows = Vec::new();
    let (mut up, mut down) = (0usize, 0usize);
    for &i in &d.steady {
        let v = d.v[i];
        let load = load_terms_exact(&geo, d.x[i].clamp(0.0, c.stroke_m));
        let y = d.p3[i] * BAR * c.piston_area_m2
            - d.p4[i] * BAR * c.rod_side_area_m2
            - load.c2_kg_m * p.load.inertia_scale * v * v;
        let decay = stribeck_decay(fr.stribeck_s_per_m * v.abs());
        let phi = v.signum() * ((1.0 - decay) + ratio * decay);
        let row = [load.gravity_n, phi, v];
        for r in 0..3 {
            for k in 0..3 {
                ata[r][k] += row[r] * row[k];
            }
            atb[r] += row[r] * y;
        }
        rows.push((row, y));
        if v > 0.0 {
            up += 1;
        } else {
            down += 1;
        }
    }
    if up < 20 || down < 20 {
        warnings.push(format!(
            "load and friction need steady moves up and down ({up} up, {down} down); kept"
        ));
        return;
    }
    let Some([s, fc, b]) = solve(ata, atb) else {
        warnings.push("load and friction: ill-conditioned fit; kept".into());
        return;
    };
    if !(s > 0.7 && s < 1.3 && (0.0..5000.0).contains(&fc) && (0.0..100_000.0).contains(&b)) {
        warnings.push(format!(
            "load and friction implausible (gravity ×{s:.3}, Coulomb {fc:.0} N, viscous {b:.0} N·s/m); kept"
        ));
        return;
    }
    let rms = (rows
        .iter()
        .map(|(r, y)| (y - s * r[0] - fc * r[1] - b * r[2]).powi(2))
        .sum::<f64>()
        / rows.len() as f64)
        .sqrt();
    p.load.gravity_scale = s;
    // The unaccounted mass moves with the crane: scale inertia alike.
    p.load.inertia_scale = s;
    p.friction.coulomb_n = fc;
    p.friction.breakaway_n = fc * ratio;
    p.friction.viscous_ns_per_m = b;
    fits.push(Fit {
        what: "load (gravity and moving mass scale)".into(),
        value: format!("× {s:.4}"),
        quality: format!(
            "{} samples ({up} up, {down} down), force residual {rms:.0} N",
            rows.len()
        ),
    });
    fits.push(Fit {
        what: "friction".into(),
        value: format!(
            "Coulomb {fc:.0} N, breakaway {:.0} N, viscous {b:.0} N·s/m",
            fc * ratio
        ),
        quality: "same regression".into(),
    });
}

/// Run the monitor over the recording; returns (mean healthy NIS, max |fast
/// leak averages| after warm-up, mean `both` leak coefficients over quiet
/// samples).
fn replay_stats(
    samples: &[Sample],
    p: &Params,
) -> Result<(f64, [f64; 2], [f64; 2]), CalibrationError> {
    let mut m: Monitor<f32> = Monitor::new(p).map_err(CalibrationError::Params)?;
    let (mut nis, mut n_nis) = (0.0, 0usize);
    let mut peak = [0.0f64; 2];
    let (mut sum, mut wsum) = ([0.0f64; 2], 0.0f64);
    for s in samples {
        let st = m.step(s);
        if st.health & monitor::status::health::WARMING_UP != 0 {
            continue;
        }
        nis += st.evidence[0].mean_nis as f64;
        n_nis += 1;
        if let (Some(i), Some(e)) = (st.detect_internal_lpm, st.detect_external_lpm) {
            peak[0] = peak[0].max((i as f64).abs());
            peak[1] = peak[1].max((e as f64).abs());
        }
        if let Some(b) = m.bank() {
            let w = st.evidence_weight as f64;
            let x = &b.both.ekf.x;
            sum[0] += w * x[monitor::bank::NB] as f64;
            sum[1] += w * x[monitor::bank::NB + 1] as f64;
            wsum += w;
        }
    }
    let mean = if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum]
    } else {
        [0.0; 2]
    };
    Ok((nis / n_nis.max(1) as f64, peak, mean))
}

/// Golden-section search of the air fraction minimising the healthy NIS.
/// The bulk modulus only shows in pressure transients, so a recording may
/// not determine it: the fit is kept only if the optimum lies inside the
/// search range and improves the NIS by at least 1 %.
fn fit_air(
    samples: &[Sample],
    p: &mut Params,
    fits: &mut Vec<Fit>,
    warnings: &mut Vec<String>,
) -> Result<(), CalibrationError> {
    let nis_at = |air: f64, p: &Params| -> Result<f64, CalibrationError> {
        let mut q = p.clone();
        q.fluid.air_fraction = air;
        Ok(replay_stats(samples, &q)?.0)
    };
    let (lo0, hi0) = (0.002f64.ln(), 0.06f64.ln());
    let (mut lo, mut hi) = (lo0, hi0);
    let r = 0.618_033_988_749_895;
    let mut a = hi - r * (hi - lo);
    let mut b = lo + r * (hi - lo);
    let mut fa = nis_at(a.exp(), p)?;
    let mut fb = nis_at(b.exp(), p)?;
    for _ in 0..8 {
        if fa < fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - r * (hi - lo);
            fa = nis_at(a.exp(), p)?;
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + r * (hi - lo);
            fb = nis_at(b.exp(), p)?;
        }
    }
    let (best, nis) = if fa < fb { (a, fa) } else { (b, fb) };
    let before = p.fluid.air_fraction;
    let nis_before = nis_at(before, p)?;
    let margin = 0.05 * (hi0 - lo0);
    let at_edge = best - lo0 < margin || hi0 - best < margin;
    if at_edge || nis > 0.99 * nis_before {
        warnings.push(format!(
            "entrained air not determined by this recording (best {:.2} %{}, NIS {nis:.3} vs {nis_before:.3}); kept {:.2} %",
            100.0 * best.exp(),
            if at_edge { " at the search limit" } else { "" },
            100.0 * before
        ));
        return Ok(());
    }
    p.fluid.air_fraction = best.exp();
    fits.push(Fit {
        what: "entrained air (effective bulk modulus)".into(),
        value: format!("{:.2} % (was {:.2} %)", 100.0 * best.exp(), 100.0 * before),
        quality: format!("healthy-filter mean NIS {nis:.3} (was {nis_before:.3})"),
    });
    Ok(())
}

/// Calibrate from a healthy recording, starting from `start`.
pub fn calibrate(samples: &[Sample], start: &Params) -> Result<Calibration, CalibrationError> {
    start.validate().map_err(CalibrationError::Params)?;
    let duration = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => b.t_s - a.t_s,
        _ => 0.0,
    };
    if duration < MIN_DURATION_S {
        return Err(CalibrationError::TooShort(duration, MIN_DURATION_S));
    }
    let mut p = start.clone();
    let mut fits = Vec::new();
    let mut warnings = Vec::new();
    let (nis_before, leak_before, _) = replay_stats(samples, &p)?;
    let d = prepare(samples);
    if d.steady.is_empty() {
        return Err(CalibrationError::NoMotion);
    }
    fit_valve(&d, &mut p, &mut fits, &mut warnings);
    fit_load(&d, &mut p, &mut fits, &mut warnings);
    fit_air(samples, &mut p, &mut fits, &mut warnings)?;
    // Healthy baseline: what the leak states still see becomes baseline.
    let (_, _, mean) = replay_stats(samples, &p)?;
    let per_bar = |theta: f64| theta * LEAK_UNIT * 1e5 * LPM_PER_M3S;
    let (di, de) = (per_bar(mean[0]), per_bar(mean[1]));
    let seal = (p.leakage.seal_lpm_per_bar + di).max(0.0);
    let ext = (p.leakage.external_lpm_per_bar + de).clamp(-0.009, 0.5);
    fits.push(Fit {
        what: "healthy leakage baseline".into(),
        value: format!(
            "seal {seal:.5} l/min/bar ({di:+.5}), rod side → tank {ext:.5} l/min/bar ({de:+.5})"
        ),
        quality: "mean leak coefficients of the both-filter over quiet samples".into(),
    });
    p.leakage.seal_lpm_per_bar = seal;
    p.leakage.external_lpm_per_bar = ext;
    p.validate().map_err(CalibrationError::Params)?;
    let (nis_after, leak_after, _) = replay_stats(samples, &p)?;
    Ok(Calibration {
        params: p,
        fits,
        warnings,
        leak_before_lpm: leak_before,
        leak_after_lpm: leak_after,
        nis_before,
        nis_after,
    })
}

impl Calibration {
    /// The report printed by `host-sim calibrate`.
    pub fn report(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        for f in &self.fits {
            let _ = writeln!(s, "{:<44} {}\n{:<44} ({})", f.what, f.value, "", f.quality);
        }
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        let _ = writeln!(
            s,
            "healthy-filter mean NIS {:.2} → {:.2} (≈ 3 when the model fits the data)",
            self.nis_before, self.nis_after
        );
        let _ = writeln!(
            s,
            "largest leak reading on this healthy recording: internal {:.3} → {:.3} l/min, external {:.3} → {:.3} l/min",
            self.leak_before_lpm[0], self.leak_after_lpm[0], self.leak_before_lpm[1], self.leak_after_lpm[1]
        );
        s
    }

    /// The installation's parameters as TOML, with the report as a comment
    /// header. The `[filter]` section is left out on purpose: filter tuning
    /// belongs to the monitor version, not to the installation, so a newer
    /// monitor's defaults apply to an existing installation file.
    pub fn to_toml(&self, source: &str) -> Result<String, toml::ser::Error> {
        let mut out =
            format!("# Installation parameters fitted by host-sim calibrate from {source}\n");
        for line in self.report().lines() {
            out += &format!("# {line}\n");
        }
        out += "\n";
        let mut table = toml::Table::try_from(&self.params)?;
        table.remove("filter");
        out += &toml::to_string(&table)?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_a_line() {
        let pts: Vec<(f64, f64)> = (0..50).map(|i| (i as f64, 2.0 + 0.5 * i as f64)).collect();
        let (a, b, r2, rms) = line_fit(&pts).unwrap();
        assert!((a - 2.0).abs() < 1e-9 && (b - 0.5).abs() < 1e-12 && r2 > 0.999_999 && rms < 1e-9);
    }

    #[test]
    fn solve_small_systems() {
        let x = solve(
            [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]],
            [3.0, 5.0, 5.0],
        )
        .unwrap();
        for (got, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((got - want).abs() < 1e-12);
        }
        assert!(solve([[1.0, 2.0], [2.0, 4.0]], [1.0, 2.0]).is_none());
    }
}
