//! The regressions: valve from chamber continuity, load and friction from
//! the force balance, each on quasi-steady moves.

use super::Fit;
use monitor::physics::fluid::bulk_modulus_exact;
use monitor::physics::friction::stribeck_decay;
use monitor::physics::load::load_terms_exact;
use monitor::physics::units::{BAR, LPM_PER_M3S};
use monitor::physics::valve::{
    command_for, orifice, spool_at, MAX_LAND_EXPONENT, OPENING_ROUNDING,
};
use monitor::Params;

/// Samples each side of the centre for smoothing/differentiation.
pub const HALF_WINDOW: usize = 15;
/// Minimum piston speed of a steady sample, m/s.
const MIN_SPEED: f64 = 0.003;
/// How steady a moving sample must be, over ±90 ms around it.
#[derive(Clone, Copy, Debug)]
pub struct Steadiness {
    /// Largest piston acceleration, m/s².
    pub accel: f64,
    /// Largest change of the (smoothed) valve command, fraction of travel.
    pub command: f64,
    /// Largest change of a chamber pressure, bar.
    pub pressure_bar: f64,
}

/// The valve regression's samples. Continuity carries the oil's
/// compression, so the pressures may still move; a command that moves
/// more than this the spool follows with a lag the regression cannot see.
/// On the development rigs this gives 2–4 times the moves of
/// [`SETTLED`], and a hunting closed loop some at all.
pub const FLOWING: Steadiness = Steadiness {
    accel: 0.1,
    command: 0.03,
    pressure_bar: 2.0,
};
/// The force balance's samples: settled command, pressures and speed, as
/// all samples were before the valve's were widened. The balance has no
/// inertia term (an acceleration twice differentiated from the position,
/// times a crane's effective mass, is mostly noise); widened to [`FLOWING`]
/// with one, the force residual of development rig 4 at 100 bar, 25 °C
/// reached 176 N and its calibration was refused.
pub const SETTLED: Steadiness = Steadiness {
    accel: 0.02,
    command: 0.01,
    pressure_bar: 1.0,
};
/// Smallest dead zone the valve fit gives, fraction of travel: the null
/// region. Fitted as 0 (zero lap) instead, the development rigs' long
/// holds read phantom external leaks (rig 1, 50 bar, 25 °C: 1.8 l/min
/// after 126 s) and calibrated cells alarmed on 1 of 75 healthy runs;
/// with it, on none, and 7 more of 342 leak runs were detected.
const MIN_DEAD_ZONE: f64 = 0.005;
/// Largest underlap (negative dead zone) the valve fit takes as the
/// smallest dead zone, fraction of travel; beyond it the fit is refused.
const MAX_UNDERLAP: f64 = 0.015;
/// Every this many samples is a candidate steady sample.
const STRIDE: usize = 5;
/// Fewest steady samples (one per `STRIDE`) for a regression.
const MIN_POINTS: usize = 20;

/// Spread (σ) of the valve command over one direction's steady samples
/// below which flow gain and edge position cannot be told apart: with one
/// speed only, a larger gain with a later edge fits as well as the truth.
/// Then the edge is held at its previous value and only the gain fitted.
/// The thesis profile's moves of 10 and 25 mm/s give ≈ 0.03; one ramp at
/// one speed gives < 0.005 (from the load's variation along the stroke).
pub const MIN_COMMAND_SPREAD: f64 = 0.01;

mod lsq;
mod prepare;

pub use lsq::{line_fit, ratio_fit, solve};
use prepare::chamber_pressure_change;
pub use prepare::{prepare, prepare_pieces, Motion, Prepared};

/// Flow gain per edge, l/min/√bar, from m³/(s·√Pa).
fn kv_to_lpm(kv: f64) -> f64 {
    kv * LPM_PER_M3S * BAR.sqrt()
}

/// Quality figures of the regressions, for the refusal thresholds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Quality {
    /// Valve regression per direction [extend, retract]: R² (None when the
    /// edge was held, the command spread being too small for it).
    pub valve_r2: [Option<f64>; 2],
    /// Valve regression residual relative to the mean metering flow.
    pub valve_rel_residual: [Option<f64>; 2],
    /// Force-balance residual, N (rms).
    pub force_residual_n: Option<f64>,
    /// Its part explained by the pressure noise, N.
    pub force_noise_n: f64,
    /// Why the fit cannot be used (empty: usable).
    pub problems: Vec<String>,
}

impl Quality {
    /// Force residual beyond what the pressure noise explains, N.
    pub fn force_excess_n(&self) -> Option<f64> {
        self.force_residual_n.map(|r| {
            (r * r - self.force_noise_n * self.force_noise_n)
                .max(0.0)
                .sqrt()
        })
    }
}

/// Chamber continuity with the model's land, seal and rod-side leakage:
/// what the metering edges must deliver into chambers A and B, m³/s.
struct Continuity {
    /// Land leakage per covered edge, seal and rod side → tank, m³/(s·Pa).
    k_edge: f64,
    k_seal: f64,
    k_ext: f64,
    /// Piston and rod-side areas, m².
    a_p: f64,
    a_r: f64,
}

impl Continuity {
    fn of(p: &Params) -> Self {
        let per_pa = |lpm_per_bar: f64| lpm_per_bar / LPM_PER_M3S / BAR;
        Self {
            k_edge: per_pa(p.valve.edge_leak_lpm_per_bar),
            k_seal: per_pa(p.leakage.seal_lpm_per_bar),
            k_ext: per_pa(p.leakage.external_lpm_per_bar),
            a_p: p.cylinder.piston_area_m2,
            a_r: p.cylinder.rod_side_area_m2,
        }
    }

    /// Net flow the metering edges deliver into A and into B at supply,
    /// chamber and tank pressures `p2`…`p5` (Pa) and piston speed `v`
    /// (m/s), with `store` the flows compressing the oil in A and B.
    fn metering(&self, [p2, p3, p4, p5]: [f64; 4], v: f64, store: [f64; 2]) -> [f64; 2] {
        let seal = self.k_seal * (p3 - p4);
        [
            self.a_p * v + store[0] + seal - self.k_edge * (p2 + p5 - 2.0 * p3),
            -self.a_r * v + store[1] - seal - self.k_edge * (p2 + p5 - 2.0 * p4)
                + self.k_ext * (p4 - p5),
        ]
    }
}

/// Fit the valve's flow gains, edge ratios, dead zone and null.
pub fn fit_valve(
    d: &Prepared,
    p: &mut Params,
    fits: &mut Vec<Fit>,
    warnings: &mut Vec<String>,
    q: &mut Quality,
) {
    let c = &p.cylinder;
    let flows = Continuity::of(p);
    let delta = p.valve.laminar_dp_bar * BAR;
    let g = |dp: f64| orifice(dp, delta, delta.sqrt()).0;
    // Flow stored by compressing the oil in a chamber of volume `vol`, m³,
    // at gauge pressure `pa`, Pa, rising at `rate`, bar/s: m³/s.
    let fluid = p.fluid.clone();
    let compress = |vol: f64, pa: f64, rate: f64| vol / bulk_modulus_exact(&fluid, pa) * rate * BAR;
    let (vol_a0, vol_b0) = (c.dead_volume_piston_m3, c.dead_volume_rod_m3);
    let (mut ext_a, mut ext_b, mut ret_a, mut ret_b) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &i in &d.steady {
        let (p2, p3, p4, p5) = (d.p2[i] * BAR, d.p3[i] * BAR, d.p4[i] * BAR, d.p5[i] * BAR);
        let v = d.v[i];
        let x = d.x[i].clamp(0.0, c.stroke_m);
        let store_a = compress(vol_a0 + c.piston_area_m2 * x, p3, d.dp3[i]);
        let store_b = compress(vol_b0 + c.rod_side_area_m2 * (c.stroke_m - x), p4, d.dp4[i]);
        let [q_a, q_b] = flows.metering([p2, p3, p4, p5], v, [store_a, store_b]);
        let u = d.u[i];
        if v > 0.0 && p2 - p3 > 2.0 * BAR && p4 - p5 > 2.0 * BAR {
            ext_a.push((u, q_a / g(p2 - p3)));
            ext_b.push((u, -q_b / g(p4 - p5)));
        } else if v < 0.0 && p3 - p5 > 2.0 * BAR && p2 - p4 > 2.0 * BAR {
            ret_a.push((-u, -q_a / g(p3 - p5)));
            ret_b.push((-u, q_b / g(p2 - p4)));
        }
    }
    // Each direction: y = Kv·(±u − edge): slope Kv, edge = −a/b. The
    // edges of the starting parameters, in ±u: extend opens at dz − null,
    // retract (in −u) at dz + null.
    let (dz, null) = (p.valve.dead_zone, p.valve.null_offset);
    let start_edges = [command_for(dz, null), -command_for(-dz, null)];
    let spreads = {
        let m = Motion::of(d);
        [m.extend_spread, m.retract_spread]
    };
    let mut edges = [None, None];
    for (dir, a_pts, b_pts) in [(0, &ext_a, &ext_b), (1, &ret_a, &ret_b)] {
        let name = if dir == 0 {
            "extend (P→A, B→T)"
        } else {
            "retract (P→B, A→T)"
        };
        let short = if dir == 0 { "extend" } else { "retract" };
        if a_pts.len() < MIN_POINTS {
            q.problems.push(format!(
                "valve {name}: only {} quasi-steady samples with enough pressure drop, need {MIN_POINTS}",
                a_pts.len()
            ));
            continue;
        }
        let nominal = if dir == 0 {
            p.valve.flow_gain_extend_lpm_sqrt_bar
        } else {
            p.valve.flow_gain_retract_lpm_sqrt_bar
        };
        let mean_y = a_pts.iter().map(|p| p.1.abs()).sum::<f64>() / a_pts.len() as f64;
        let (b, edge, r2, rms) = if spreads[dir] >= MIN_COMMAND_SPREAD {
            let Some((a, b, r2, rms)) = line_fit(a_pts) else {
                q.problems
                    .push(format!("valve {name}: degenerate regression"));
                continue;
            };
            (b, -a / b, Some(r2), rms)
        } else {
            // One speed only: the gain with the edge where it was.
            let e0 = start_edges[dir];
            let shifted: Vec<(f64, f64)> = a_pts.iter().map(|(u, y)| (u - e0, *y)).collect();
            let Some((b, rms)) = ratio_fit(&shifted) else {
                q.problems
                    .push(format!("valve {name}: degenerate regression"));
                continue;
            };
            warnings.push(format!(
                "valve {name}: the moves span too few speeds (command σ {:.4} < {MIN_COMMAND_SPREAD}) to place the edge; edge held at {e0:+.4}, only the gain fitted",
                spreads[dir]
            ));
            (b, e0, None, rms)
        };
        let rel = rms / mean_y;
        q.valve_r2[dir] = r2;
        q.valve_rel_residual[dir] = Some(rel);
        let kv_lpm = kv_to_lpm(b);
        if !(kv_lpm > 0.5 * nominal && kv_lpm < 2.0 * nominal && edge > -0.05 && edge < 0.1) {
            q.problems.push(format!(
                "valve {name}: implausible fit (gain {kv_lpm:.3} l/min/√bar against {nominal:.3} before, edge at u = {edge:+.4})"
            ));
            continue;
        }
        // The rod side's own line where the moves span speeds enough to
        // place edges; else its ratio through the piston side's edge.
        let own = r2.and_then(|_| rod_side_line(b_pts, b, edge));
        let ratio = own.map(|(k, _)| k).or_else(|| {
            ratio_fit(
                &b_pts
                    .iter()
                    .map(|(u, y)| (u - edge, *y))
                    .collect::<Vec<_>>(),
            )
            .map(|(k, _)| k / b)
        });
        let offset = own.map_or(0.0, |(_, o)| o);
        if dir == 0 {
            p.valve.flow_gain_extend_lpm_sqrt_bar = kv_lpm;
        } else {
            p.valve.flow_gain_retract_lpm_sqrt_bar = kv_lpm;
        }
        if r2.is_some() {
            edges[dir] = Some(edge);
        }
        let rms_lpm = rms * LPM_PER_M3S * (30.0 * BAR).sqrt();
        fits.push(Fit {
            what: format!("valve flow gain, {short}"),
            value: format!(
                "{kv_lpm:.4} l/min/√bar ({:+.1} % of previous)",
                100.0 * (kv_lpm / nominal - 1.0)
            ),
            quality: format!(
                "{} samples, {}residual {:.1} % of the flow (≈ {rms_lpm:.3} l/min at 30 bar)",
                a_pts.len(),
                r2.map_or("edge held, ".to_string(), |r2| format!("R² {r2:.4}, ")),
                100.0 * rel
            ),
        });
        match ratio {
            Some(k) if plausible_rod_ratio(k) => {
                if dir == 0 {
                    p.valve.rod_edge_gain_extend = k;
                    p.valve.rod_edge_offset_extend = offset;
                } else {
                    p.valve.rod_edge_gain_retract = k;
                    p.valve.rod_edge_offset_retract = offset;
                }
                fits.push(Fit {
                    what: format!("rod/piston-side edge ratio, {short}"),
                    value: format!("{k:.4}, rod-side edge {offset:+.4} of travel later"),
                    quality: format!(
                        "{} samples{}",
                        b_pts.len(),
                        if own.is_some() {
                            ", its own line"
                        } else {
                            ", through the piston side's edge"
                        }
                    ),
                });
            }
            other => q.problems.push(format!(
                "valve {name}: rod-side/piston-side edge ratio {} implausible ({}–{} expected)",
                other.map_or("undetermined".into(), |k| format!("{k:.3}")),
                ROD_EDGE_RATIO.0,
                ROD_EDGE_RATIO.1,
            )),
        }
    }
    match edges {
        [Some(e_ext), Some(e_ret)] => {
            // Edges open at u = dz − null (extend) and u = −(dz + null).
            let fitted_dz = 0.5 * (e_ext + e_ret);
            let null = 0.5 * (e_ret - e_ext);
            // Within the null region a valve's flow is its land leakage,
            // not metering: the regressions' straight line, extrapolated
            // there, puts the edges of a smoothly opening valve too early
            // (even before null), and a model metering from the first
            // 0.1 % of travel reads the command's noise at every hold as
            // flow.
            let dz = if (-MAX_UNDERLAP..MIN_DEAD_ZONE).contains(&fitted_dz) {
                warnings.push(format!(
                    "valve edges fitted at u = {e_ext:+.4} / {:+.4}: dead zone {fitted_dz:.4} taken as {MIN_DEAD_ZONE} (the null region, where land leakage and not metering sets the flow)",
                    -e_ret
                ));
                MIN_DEAD_ZONE
            } else {
                fitted_dz
            };
            // At rest the valve passes no net flow, so the spool is where
            // the edges are covered: holds outside the fitted band mean the
            // moves' straight lines misplace the null, and the model would
            // meter flow at every hold.
            let (null, held) = match holds_outside(d, null, dz) {
                Some(u) => {
                    warnings.push(format!(
                        "valve null moved from {null:+.4} to {:+.4}: the piston holds at u = {u:+.4}, outside the dead zone of the edges fitted from the moves (u = {e_ext:+.4} / {:+.4}); the dead zone is centred on the holds",
                        -u,
                        -e_ret
                    ));
                    (-u, format!("; centred on the holds at u = {u:+.4}"))
                }
                None => (null, String::new()),
            };
            if (0.0..0.08).contains(&dz) && null.abs() < MAX_NULL {
                p.valve.dead_zone = dz;
                p.valve.null_offset = null;
                fits.push(Fit {
                    what: "valve dead zone and null".into(),
                    value: format!("dead zone {dz:.4}, null {null:+.4} (fraction of travel)"),
                    quality: format!("edges at u = {e_ext:+.4} / {:+.4}{held}", -e_ret),
                });
            } else {
                q.problems.push(format!(
                    "valve dead zone {dz:.4} / null {null:+.4} implausible (−{MAX_UNDERLAP}–0.08 / ±{MAX_NULL} expected)"
                ));
            }
        }
        _ => warnings.push(
            "valve dead zone and null need moves at several speeds in both directions; kept".into(),
        ),
    }
}

/// Largest plausible valve null offset, fraction of travel.
const MAX_NULL: f64 = 0.03;

/// Least time at rest, s, for [`hold_command`] to place the null.
const MIN_HOLD_COMMAND_S: f64 = 2.0;

/// Samples either side of a hold sample that must be at rest too.
const REST_SPAN: usize = 6 * HALF_WINDOW;

/// The samples of `d` (one per `STRIDE`) at a settled hold: the piston at
/// rest over ±`REST_SPAN` and the chamber pressures steady.
fn resting(d: &Prepared) -> impl Iterator<Item = usize> + '_ {
    let still = MIN_SPEED / 3.0;
    (REST_SPAN..d.u.len().saturating_sub(REST_SPAN))
        .step_by(STRIDE)
        .filter(move |&i| {
            [i - REST_SPAN, i, i + REST_SPAN]
                .iter()
                .all(|&j| d.v[j].abs() < still)
                && chamber_pressure_change(&d.p3, &d.p4, i, REST_SPAN) < SETTLED.pressure_bar
        })
}

/// The median valve command while the piston rests with steady chamber
/// pressures, if it rests for [`MIN_HOLD_COMMAND_S`] or more.
pub fn hold_command(d: &Prepared) -> Option<f64> {
    let mut u: Vec<f64> = resting(d)
        .map(|i| d.u[i])
        .filter(|u| u.is_finite())
        .collect();
    if (u.len() as f64) * d.stride_s < MIN_HOLD_COMMAND_S {
        return None;
    }
    u.sort_by(f64::total_cmp);
    Some(u[u.len() / 2])
}

/// The hold command ([`hold_command`]) when it puts the spool outside the
/// dead zone `dead_zone` around `null`: the piston holds where the valve
/// model would meter flow.
fn holds_outside(d: &Prepared, null: f64, dead_zone: f64) -> Option<f64> {
    hold_command(d).filter(|&u| spool_at(u, null).abs() > dead_zone)
}

/// With the valve otherwise kept (a partial calibration), place its null
/// where the piston holds: at rest the valve passes no net flow, so the
/// hold command must sit inside the dead zone, or the model meters flow
/// at every hold and weighs none of it as evidence. Needs only
/// [`MIN_HOLD_COMMAND_S`] at rest, not the moves the edges need. Returns
/// whether the null moved.
pub fn centre_null_on_holds(
    d: &Prepared,
    p: &mut Params,
    fits: &mut Vec<Fit>,
    warnings: &mut Vec<String>,
) -> bool {
    let v = &p.valve;
    let (old, dz) = (v.null_offset, v.dead_zone);
    match holds_outside(d, old, dz) {
        // Inside the plausible range the full fit allows.
        Some(u) if u.abs() < MAX_NULL => {
            p.valve.null_offset = -u;
            warnings.push(format!(
                "valve null moved from {old:+.4} to {:+.4} with the rest of the valve kept: the piston holds at u = {u:+.4}, outside the kept dead zone ±{dz:.4} around the null",
                -u
            ));
            fits.push(Fit {
                what: "valve null (from the holds)".into(),
                value: format!("null {:+.4} (fraction of travel)", -u),
                quality: format!("median command at rest, dead zone {dz:.4} kept"),
            });
            true
        }
        _ => false,
    }
}

/// Fit the load (gravity and moving-mass scale) and friction.
pub fn fit_load(d: &Prepared, p: &mut Params, fits: &mut Vec<Fit>, q: &mut Quality) {
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
    // Normal equations for y = s·G0(x) + F0 + Fc·φ(v) + B·v: a payload or
    // an unmodelled attachment changes both the level and the shape of the
    // gravity load, which the scale alone cannot follow.
    let mut ata = [[0.0; 4]; 4];
    let mut atb = [0.0; 4];
    let mut rows = Vec::new();
    let (mut up, mut down) = (0usize, 0usize);
    for &i in &d.settled {
        let v = d.v[i];
        let load = load_terms_exact(&geo, d.x[i].clamp(0.0, c.stroke_m));
        let y = d.p3[i] * BAR * c.piston_area_m2
            - d.p4[i] * BAR * c.rod_side_area_m2
            - load.c2_kg_m * p.load.inertia_scale * v * v;
        let decay = stribeck_decay(fr.stribeck_s_per_m * v.abs());
        let phi = v.signum() * ((1.0 - decay) + ratio * decay);
        let row = [load.gravity_n, 1.0, phi, v];
        for r in 0..4 {
            for k in 0..4 {
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
    // The pressure noise left in the 2h+1-sample averages, as force.
    q.force_noise_n =
        p.sensors.pressure_noise_bar * BAR * c.piston_area_m2.hypot(c.rod_side_area_m2)
            / ((2 * HALF_WINDOW + 1) as f64).sqrt();
    if up < MIN_POINTS || down < MIN_POINTS {
        q.problems.push(format!(
            "load and friction need steady moves up and down ({up} up, {down} down, need {MIN_POINTS} each)"
        ));
        return;
    }
    // Without the offset when the stroke does not separate it from the
    // scale (a nearly constant gravity load).
    let with_offset = solve(ata, atb).filter(|[s, f0, _, _]| {
        *s > 0.5
            && *s < 2.5
            && f0.abs() < 0.5 * load_terms_exact(&geo, 0.5 * c.stroke_m).gravity_n.abs()
    });
    let Some([s, f0, fc, b]) = with_offset.or_else(|| {
        let a3 = [
            [ata[0][0], ata[0][2], ata[0][3]],
            [ata[2][0], ata[2][2], ata[2][3]],
            [ata[3][0], ata[3][2], ata[3][3]],
        ];
        solve(a3, [atb[0], atb[2], atb[3]]).map(|[s, fc, b]| [s, 0.0, fc, b])
    }) else {
        q.problems
            .push("load and friction: ill-conditioned regression".into());
        return;
    };
    let rms = (rows
        .iter()
        .map(|(r, y)| (y - s * r[0] - f0 - fc * r[2] - b * r[3]).powi(2))
        .sum::<f64>()
        / rows.len() as f64)
        .sqrt();
    q.force_residual_n = Some(rms);
    if !(s > 0.5 && s < 2.5 && (0.0..5000.0).contains(&fc) && (0.0..100_000.0).contains(&b)) {
        q.problems.push(format!(
            "load and friction implausible (gravity ×{s:.3}, Coulomb {fc:.0} N, viscous {b:.0} N·s/m)"
        ));
        return;
    }
    p.load.gravity_scale = s;
    p.load.force_offset_n = f0;
    // The unaccounted mass moves with the crane: scale inertia alike.
    p.load.inertia_scale = s;
    p.friction.coulomb_n = fc;
    p.friction.breakaway_n = fc * ratio;
    p.friction.viscous_ns_per_m = b;
    fits.push(Fit {
        what: "load (gravity and moving mass scale)".into(),
        value: format!("× {s:.4}, offset {f0:+.0} N"),
        quality: format!(
            "{} samples ({up} up, {down} down), force residual {rms:.0} N ({:.0} N of it pressure noise)",
            rows.len(),
            q.force_noise_n
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

/// Least hold time (samples with the spool covered and the piston at
/// rest), s, for the covered-edge asymmetry; less keeps the edges as they
/// were.
pub const MIN_HOLD_S: f64 = 0.5;
/// Spread (σ) of the spool position over the hold samples, fraction of
/// travel, below which the spool's pressure gain is not fitted.
const MIN_HOLD_SPOOL_SPREAD: f64 = 5e-4;
/// Largest edge asymmetry |skew| the fit may give.
const MAX_SKEW: f64 = 0.9;
/// What the covered-edge fit is called in the report.
pub const EDGE_FIT: &str = "covered valve edges (land leakage asymmetry)";

/// Largest growth rate of the land leakage the model accepts for `valve`,
/// e-folds per unit of spool travel: `valve.edge_leak_spool_gain`'s range,
/// and × dead zone ≤ [`MAX_LAND_EXPONENT`] (validated).
pub fn growth_limit(valve: &monitor::params::Valve) -> f64 {
    let range = Params::bounds_of("valve.edge_leak_spool_gain")
        .expect("a parameter field")
        .range(0);
    (MAX_LAND_EXPONENT / valve.dead_zone).min(range.max)
}
/// Candidate growth rates of the land leakage (e-folds per unit of spool
/// travel) the fit tries between 1 and its largest, log-spaced.
const SPOOL_GAIN_CANDIDATES: usize = 64;

/// One hold sample for the covered-edge fit: the spool position and, in
/// units of the symmetric edge's leakage at the full supply-to-tank drop
/// k·(p2 − p5), each edge's pressure drop and the land flow each chamber's
/// continuity calls for.
#[derive(Clone, Copy, Debug)]
struct HoldRow {
    /// Spool position, fraction of travel.
    xv: f64,
    /// (p2 − p3, p3 − p5, p2 − p4, p4 − p5) / (p2 − p5).
    drop: [f64; 4],
    /// Land flow into A and into B / (k·(p2 − p5)).
    need: [f64; 2],
}

impl HoldRow {
    /// Land flow into A and B the edges give at growth `e` = e^(g·x_v)
    /// with skews 0 (`.0`), and how it changes per unit skew (`.1`).
    fn land(&self, e: f64) -> ([f64; 2], [f64; 2]) {
        let [a_in, a_out, b_in, b_out] = self.drop;
        (
            [e * a_in - a_out / e, b_in / e - e * b_out],
            [e * a_in + a_out / e, b_in / e + e * b_out],
        )
    }
}

/// The hold samples the covered-edge asymmetry is fitted from: piston at
/// rest, spool inside the dead zone, pressures steady.
pub struct EdgeHolds {
    rows: Vec<HoldRow>,
    /// Time they cover, s.
    hold_s: f64,
}

impl EdgeHolds {
    /// The holds of `d` under `p`'s cylinder, valve and healthy leakage.
    pub fn of(d: &Prepared, p: &Params) -> Self {
        let v = &p.valve;
        let flows = Continuity::of(p);
        // Covered: short of where the model's opening starts to round.
        let covered = v.dead_zone - OPENING_ROUNDING;
        let mut rows = Vec::new();
        if flows.k_edge > 0.0 && covered > 0.0 {
            for i in resting(d) {
                let vals = [d.p2[i], d.p3[i], d.p4[i], d.p5[i], d.u[i], d.v[i]];
                if !vals.iter().all(|x| x.is_finite()) {
                    continue;
                }
                let xv = spool_at(d.u[i], v.null_offset);
                let (p2, p3, p4, p5) = (d.p2[i] * BAR, d.p3[i] * BAR, d.p4[i] * BAR, d.p5[i] * BAR);
                if !(xv.abs() < covered && p2 - p5 > 5.0 * BAR) {
                    continue;
                }
                // At a hold the metering edges are covered: continuity asks
                // the land leakage for all the flow (`metering` is net of
                // the symmetric edges' share, added back).
                let ps = p2 - p5;
                let unit = flows.k_edge * ps;
                let [q_a, q_b] = flows.metering([p2, p3, p4, p5], d.v[i], [0.0; 2]);
                rows.push(HoldRow {
                    xv,
                    drop: [
                        (p2 - p3) / ps,
                        (p3 - p5) / ps,
                        (p2 - p4) / ps,
                        (p4 - p5) / ps,
                    ],
                    need: [
                        q_a / unit + (p2 + p5 - 2.0 * p3) / ps,
                        q_b / unit + (p2 + p5 - 2.0 * p4) / ps,
                    ],
                });
            }
        }
        let hold_s = rows.len() as f64 * d.stride_s;
        Self { rows, hold_s }
    }

    /// The skews of A and B that fit best at growth rate `g` (each a
    /// least-squares line through the origin, held to ±[`MAX_SKEW`]),
    /// and the RMS residual, in units of k·(p2 − p5).
    fn skews_at(&self, g: f64) -> ([f64; 2], f64) {
        // Each row's land flows at this growth, for the fit and its residual.
        let land: Vec<_> = self.rows.iter().map(|r| r.land((g * r.xv).exp())).collect();
        let (mut num, mut den) = ([0.0; 2], [0.0; 2]);
        for (r, (base, per_skew)) in self.rows.iter().zip(&land) {
            for c in 0..2 {
                num[c] += (r.need[c] - base[c]) * per_skew[c];
                den[c] += per_skew[c] * per_skew[c];
            }
        }
        let skew =
            [0, 1].map(|c| (num[c] / den[c].max(f64::MIN_POSITIVE)).clamp(-MAX_SKEW, MAX_SKEW));
        let sum_sq = self
            .rows
            .iter()
            .zip(&land)
            .map(|(r, (base, per_skew))| {
                (0..2)
                    .map(|c| (r.need[c] - base[c] - skew[c] * per_skew[c]).powi(2))
                    .sum::<f64>()
            })
            .sum::<f64>();
        (skew, (sum_sq / (2.0 * self.rows.len() as f64)).sqrt())
    }
}

/// Largest |offset| between the two metering edges of one direction
/// calibration accepts, fraction of travel. Overlaps differ by a few
/// thousandths between edges; laminar land leakage beside an opening edge
/// shifts its straight line by up to a few hundredths, but that leakage
/// follows the pressure drop, not the opening, and a larger offset applied
/// at openings the recording did not move at raised alarms before leaks
/// started (development rig 2, further rig 25: docs/evaluation.md).
pub const MAX_ROD_EDGE_OFFSET: f64 = 0.02;

/// Plausible rod-side/piston-side flow gain ratios of one direction
/// (exclusive bounds).
const ROD_EDGE_RATIO: (f64, f64) = (0.8, 1.25);

fn plausible_rod_ratio(k: f64) -> bool {
    k > ROD_EDGE_RATIO.0 && k < ROD_EDGE_RATIO.1
}

/// The rod-side edge's own straight line y = K_b·(u − edge_b), against the
/// piston side's slope `k_piston` and edge `edge_piston`: (gain ratio
/// K_b / K_piston, offset edge_b − edge_piston), or `None` when it is
/// degenerate or implausible (the ratio outside [`ROD_EDGE_RATIO`], the
/// offset beyond [`MAX_ROD_EDGE_OFFSET`]).
fn rod_side_line(pts: &[(f64, f64)], k_piston: f64, edge_piston: f64) -> Option<(f64, f64)> {
    let (a, b, _, _) = line_fit(pts)?;
    let (ratio, offset) = (b / k_piston, -a / b - edge_piston);
    (plausible_rod_ratio(ratio) && offset.abs() <= MAX_ROD_EDGE_OFFSET).then_some((ratio, offset))
}

/// How [`fit_edge_leak`] chooses the land leakage's growth rate
/// (`valve.edge_leak_spool_gain`, e-folds per unit of spool travel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Growth {
    /// The rate the holds fit best: log-spaced candidates from 1 up to
    /// what the model accepts ([`growth_limit`]). Needs the spool to move
    /// in the holds.
    Search,
    /// This rate (held to what the model accepts).
    Fixed(f64),
}

/// Fit the covered edges' land leakage from the holds: with the piston at
/// rest and the spool inside the dead zone, chamber continuity is the land
/// leakage alone, and where each chamber's pressure settles says how its
/// two edges divide the leakage (`valve.edge_leak_skew_a`, `_b`) and how
/// fast that shifts as the spool uncovers one of them
/// (`valve.edge_leak_spool_gain`): with the symmetric edges of one
/// coefficient the model can hold only one pressure pair, and the
/// filter's laminar state (or a leak state) makes up the rest.
///
/// At each growth rate the skews are a linear least-squares fit. Returns
/// the fit, or `None` when the holds are too short (with a warning, for
/// [`Growth::Search`]), the spool too still to search the rate, or the
/// fit sits at a bound (with a warning).
pub fn fit_edge_leak(
    holds: &EdgeHolds,
    p: &mut Params,
    growth: Growth,
    warnings: &mut Vec<String>,
) -> Option<Fit> {
    let (rows, hold_s) = (&holds.rows, holds.hold_s);
    if hold_s < MIN_HOLD_S {
        if growth == Growth::Search {
            warnings.push(format!(
                "covered valve edges kept symmetric: {hold_s:.2} s at rest with the spool inside the dead zone, need {MIN_HOLD_S} s"
            ));
        }
        return None;
    }
    let m = rows.len() as f64;
    let mx = rows.iter().map(|r| r.xv).sum::<f64>() / m;
    let spread = (rows.iter().map(|r| (r.xv - mx).powi(2)).sum::<f64>() / m).sqrt();
    let top = growth_limit(&p.valve);
    let (g, ([a, b], rms)) = match growth {
        Growth::Fixed(g) => (g.min(top), holds.skews_at(g.min(top))),
        Growth::Search if spread < MIN_HOLD_SPOOL_SPREAD => return None,
        Growth::Search => (0..SPOOL_GAIN_CANDIDATES)
            .map(|k| {
                let g = top.powf(k as f64 / (SPOOL_GAIN_CANDIDATES - 1) as f64);
                (g, holds.skews_at(g))
            })
            .min_by(|x, y| x.1 .1.total_cmp(&y.1 .1))?,
    };
    // A fit pressed against a bound is not determined by the holds (skew
    // and growth trade off when the spool barely moves).
    let searched_to_top = growth == Growth::Search && g >= top;
    if a.abs() >= MAX_SKEW || b.abs() >= MAX_SKEW || searched_to_top {
        warnings.push(format!(
            "covered valve edges: the fit from the holds at growth {g:.0} e-folds per travel sits at a bound (skew A {a:+.2}, B {b:+.2}; limits ±{MAX_SKEW}, {top:.0} e-folds): not used"
        ));
        return None;
    }
    p.valve.edge_leak_skew_a = a;
    p.valve.edge_leak_skew_b = b;
    p.valve.edge_leak_spool_gain = g;
    let folds = g * p.valve.dead_zone;
    Some(Fit {
        what: EDGE_FIT.into(),
        value: format!(
            "skew A {a:+.3}, B {b:+.3} (P→A/A→T {:.2}, P→B/B→T {:.2}), growth {g:.1} e-folds per travel ({folds:.2} over the dead zone)",
            (1.0 + a) / (1.0 - a),
            (1.0 + b) / (1.0 - b)
        ),
        quality: format!(
            "{hold_s:.1} s at rest, spool σ {spread:.4}, residual {rms:.3} of the edge leakage"
        ),
    })
}

#[cfg(test)]
mod tests;
