//! The report's tables: leaks, healthy, step tests, faults, conditions, calibration.

use super::{histogram, kind_order, med_max, opt, pct, size_key};
use crate::eval::exec::{CellResult, RunResult};
use crate::eval::plan::ONSET_S;
use crate::eval::score::{max, median, HEALTHY, INCONCLUSIVE};
use crate::eval::{Category, FaultKind};
use std::collections::BTreeMap;
use std::fmt::Write;

/// (1) Leaks: kind × size.
pub fn leak_table(out: &mut String, runs: &[&RunResult]) {
    let leaks: Vec<&RunResult> = runs
        .iter()
        .copied()
        .filter(|r| matches!(r.spec.category, Category::Leak | Category::LeakAfterHold))
        .collect();
    let _ = writeln!(out, "### Leaks\n");
    if leaks.is_empty() {
        let _ = writeln!(out, "No leak runs.\n");
        return;
    }
    let key = |r: &RunResult| {
        (
            r.spec.category == Category::LeakAfterHold,
            kind_order(r.spec.leak_kind()),
            size_key(r.spec.leak_size_lpm()),
        )
    };
    let mut keys: Vec<_> = leaks.iter().map(|r| key(r)).collect();
    keys.sort_unstable();
    keys.dedup();
    let _ = writeln!(out, "| leak | l/min | runs | detected | isolated | false alarms | ended `healthy` | latency after onset s, median (max) | after flow ≥ alarm level s, median (max) | median size error |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    for k in keys {
        let rs: Vec<&RunResult> = leaks.iter().copied().filter(|r| key(r) == k).collect();
        let n = rs.len();
        let lat: Vec<f64> = rs.iter().filter_map(|r| r.latency_s()).collect();
        let flow: Vec<f64> = rs.iter().filter_map(|r| r.latency_flowing_s()).collect();
        let err: Vec<f64> = rs.iter().flat_map(|r| r.size_errors()).collect();
        let kind = rs[0].spec.leak_kind();
        let _ = writeln!(
            out,
            "| {kind}{} | {:.2} | {n} | {} | {} | {} | {} | {} | {} | {} |",
            if k.0 { ", after the hold" } else { "" },
            k.2 as f64 / 1e4,
            pct(rs.iter().filter(|r| r.detected()).count(), n),
            pct(rs.iter().filter(|r| r.isolated()).count(), n),
            pct(rs.iter().filter(|r| r.false_alarm()).count(), n),
            pct(rs.iter().filter(|r| r.verdict == HEALTHY).count(), n),
            med_max(&lat, 2),
            med_max(&flow, 2),
            median(&err).map_or("–".into(), |v| format!("{:.0} %", 100.0 * v)),
        );
    }
    let _ = writeln!(
        out,
        "\nLeaks start at {ONSET_S} s (0.3 l/min also from the start: detection, isolation and size counted, latency not); the after-the-hold leak starts once the piston has held for the hold's length (600 s; `--quick`: 120 s), located in the healthy twin's truth; the plant's work cycle resumes 1–8 s later and the run ends 8–15 s after the hold. Ended `healthy`: a leak run whose final verdict claims a healthy cylinder (a leak below this installation's detection level, or one the monitor did not see); `inconclusive` is not counted there.\n"
    );
}

/// (2) Healthy runs.
pub fn healthy_table(out: &mut String, runs: &[&RunResult]) {
    let _ = writeln!(out, "### Healthy runs\n");
    let _ = writeln!(out, "| run | runs | false alarms | healthy | inconclusive | other verdicts | largest leak reading l/min | leading mean NIS, median (max) |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for (cat, name) in [
        (Category::HealthyClosedLoop, "closed loop"),
        (Category::HealthyLongHold, "long hold"),
        (Category::HealthyStep, "step test"),
    ] {
        let rs: Vec<&RunResult> = runs
            .iter()
            .copied()
            .filter(|r| r.spec.category == cat)
            .collect();
        if rs.is_empty() {
            continue;
        }
        let n = rs.len();
        let nis: Vec<f64> = rs.iter().filter_map(|r| r.nis_leading_mean).collect();
        let _ = writeln!(
            out,
            "| {name} | {n} | {} | {} | {} | {} | {} | {} |",
            pct(rs.iter().filter(|r| r.false_alarm()).count(), n),
            pct(rs.iter().filter(|r| r.verdict == HEALTHY).count(), n),
            pct(rs.iter().filter(|r| r.inconclusive()).count(), n),
            histogram(
                rs.iter()
                    .map(|r| r.verdict.as_str())
                    .filter(|v| *v != HEALTHY && *v != INCONCLUSIVE)
            ),
            opt(
                max(&rs
                    .iter()
                    .map(|r| r.largest_reading_lpm())
                    .collect::<Vec<_>>()),
                3
            ),
            med_max(&nis, 2),
        );
    }
    let _ = writeln!(
        out,
        "\nLargest leak reading: the peak of the monitor's short detection average (what the alarm's CUSUM sees). Leading mean NIS: the leading hypothesis' windowed mean NIS averaged over the run after warm-up (≈ 3 when the model fits).\n"
    );
}

/// (3) Step tests.
pub fn step_table(out: &mut String, runs: &[&RunResult]) {
    let steps: Vec<&RunResult> = runs
        .iter()
        .copied()
        .filter(|r| matches!(r.spec.category, Category::HealthyStep | Category::StepLeak))
        .collect();
    let _ = writeln!(out, "### Step tests\n");
    if steps.is_empty() {
        let _ = writeln!(out, "No step tests.\n");
        return;
    }
    let key = |r: &RunResult| {
        (
            r.spec.has_leak(),
            kind_order(r.spec.leak_kind()),
            size_key(r.spec.leak_size_lpm()),
        )
    };
    let mut keys: Vec<_> = steps.iter().map(|r| key(r)).collect();
    keys.sort_unstable();
    keys.dedup();
    let _ = writeln!(
        out,
        "| step test | runs | amplitudes | false alarms | detected | isolated | final verdicts |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for k in keys {
        let rs: Vec<&RunResult> = steps.iter().copied().filter(|r| key(r) == k).collect();
        let n = rs.len();
        let amps: Vec<f64> = rs
            .iter()
            .filter_map(|r| match r.spec.scenario {
                plant::Scenario::StepTest { amplitude, .. } => Some(amplitude),
                _ => None,
            })
            .collect();
        let lo = amps.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = amps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let name = if k.0 {
            format!("{} {:.2} l/min", rs[0].spec.leak_kind(), k.2 as f64 / 1e4)
        } else {
            "healthy".into()
        };
        let _ = writeln!(
            out,
            "| {name} | {n} | {lo:+.2} … {hi:+.2} | {} | {} | {} | {} |",
            pct(rs.iter().filter(|r| r.false_alarm()).count(), n),
            if k.0 {
                pct(rs.iter().filter(|r| r.detected()).count(), n)
            } else {
                "–".into()
            },
            if k.0 {
                pct(rs.iter().filter(|r| r.isolated()).count(), n)
            } else {
                "–".into()
            },
            histogram(rs.iter().map(|r| r.verdict.as_str())),
        );
    }
    let _ = writeln!(
        out,
        "\n10 s open-loop tests, step at 3 s; leaks (internal on even rigs, external on odd) present from the start.\n"
    );
}

/// (4) Faults.
pub fn fault_table(out: &mut String, runs: &[&RunResult]) {
    let faults: Vec<&RunResult> = runs
        .iter()
        .copied()
        .filter(|r| r.spec.category == Category::Fault)
        .collect();
    let _ = writeln!(out, "### Faults\n");
    if faults.is_empty() {
        let _ = writeln!(out, "No fault runs.\n");
        return;
    }
    let _ = writeln!(out, "| fault | runs | expected | final verdicts | verdicts while active | leak alarms after (before) the fault | to sensor_fault s, median (max) | as expected |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for kind in FaultKind::ALL {
        let rs: Vec<&RunResult> = faults
            .iter()
            .copied()
            .filter(|r| r.spec.fault == Some(kind))
            .collect();
        if rs.is_empty() {
            continue;
        }
        let n = rs.len();
        let mut active: BTreeMap<&str, u64> = BTreeMap::new();
        for r in &rs {
            for (v, k) in &r.fault_verdicts {
                *active.entry(v.as_str()).or_insert(0) += k;
            }
        }
        let total: u64 = active.values().sum();
        let mut act: Vec<(&str, u64)> = active.into_iter().collect();
        act.sort_by_key(|b| std::cmp::Reverse(b.1));
        let act = act
            .iter()
            .map(|(v, k)| {
                let p = 100.0 * *k as f64 / total.max(1) as f64;
                if p < 0.5 {
                    format!("{v} <1 %")
                } else {
                    format!("{v} {p:.0} %")
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        let to_fault: Vec<f64> = rs
            .iter()
            .filter_map(|r| {
                let start = crate::eval::plan::fault_window(&r.spec.faults)?.0;
                Some(r.sensor_fault_verdict_s? - start)
            })
            .collect();
        let _ = writeln!(
            out,
            "| {} | {n} | {} | {} | {} | {} | {} | {} |",
            kind.name(),
            rs[0].expectation(),
            histogram(rs.iter().map(|r| r.verdict.as_str())),
            if act.is_empty() { "–".into() } else { act },
            {
                let after = rs
                    .iter()
                    .filter(|r| r.fault_leak_alarms().next().is_some())
                    .count();
                let before = rs
                    .iter()
                    .filter(|r| r.leak_alarms().count() > r.fault_leak_alarms().count())
                    .count();
                format!("{after} ({before})")
            },
            med_max(&to_fault, 2),
            pct(rs.iter().filter(|r| r.passes()).count(), n),
        );
    }
    let _ = writeln!(
        out,
        "\nHealthy plant (the first healthy closed-loop run's motion and noise seeds: identical to that run until the fault, so an alarm before the fault is that run's false alarm, counted in parentheses and not against the fault). Faults from 20 s (frozen ones at the first mid-move instant after 20 s); stuck and NaN time for 2 s; random noise the whole run. \"While active\": verdicts of the samples from 0.1 s after the fault starts to its end.\n"
    );
}

/// (5) Per operating condition.
pub fn condition_table(out: &mut String, runs: &[&RunResult]) {
    let key = |r: &RunResult| {
        (
            size_key(r.spec.cell.supply_bar),
            size_key(r.spec.cell.temp_c),
            r.spec.cell.temp_column,
        )
    };
    let mut keys: Vec<_> = runs.iter().map(|r| key(r)).collect();
    keys.sort_unstable();
    keys.dedup();
    let _ = writeln!(out, "### Per condition\n");
    let _ = writeln!(out, "| supply | oil | temp_oil | runs | false alarms | healthy closed loop inconclusive | leaks detected | leaks isolated | as expected |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for k in keys {
        let rs: Vec<&RunResult> = runs.iter().copied().filter(|r| key(r) == k).collect();
        let leaks: Vec<&RunResult> = rs
            .iter()
            .copied()
            .filter(|r| matches!(r.spec.category, Category::Leak | Category::LeakAfterHold))
            .collect();
        let hcl: Vec<&RunResult> = rs
            .iter()
            .copied()
            .filter(|r| r.spec.category == Category::HealthyClosedLoop)
            .collect();
        let _ = writeln!(
            out,
            "| {} bar | {} °C | {} | {} | {} | {} | {} | {} | {} |",
            k.0 as f64 / 1e4,
            k.1 as f64 / 1e4,
            if k.2 { "yes" } else { "no" },
            rs.len(),
            rs.iter().filter(|r| r.false_alarm()).count(),
            pct(hcl.iter().filter(|r| r.inconclusive()).count(), hcl.len()),
            pct(leaks.iter().filter(|r| r.detected()).count(), leaks.len()),
            pct(leaks.iter().filter(|r| r.isolated()).count(), leaks.len()),
            pct(rs.iter().filter(|r| r.passes()).count(), rs.len()),
        );
    }
    let _ = writeln!(out);
}

/// (6) Calibration per cell.
pub fn calibration_table(out: &mut String, cells: &[&CellResult], runs: &[&RunResult]) {
    let refused = cells
        .iter()
        .filter(|c| c.calibration.status == "refused")
        .count();
    let calibrated = cells
        .iter()
        .filter(|c| c.calibration.status == "calibrated")
        .count();
    let _ = writeln!(out, "### Calibration\n");
    let _ = writeln!(
        out,
        "{calibrated} of {} cells calibrated, {refused} refused (those cells ran with the nominal parameters, provisional){}.\n",
        cells.len(),
        if calibrated + refused < cells.len() {
            ", calibration off for the rest"
        } else {
            ""
        }
    );
    let _ = writeln!(out, "| rig | supply | oil | calibration | loop oscillating | healthy-filter NIS before → after | largest leak reading after, l/min | healthy runs' leading mean NIS, median (max) |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for c in cells {
        let cal = &c.calibration;
        let status = match &cal.refused {
            Some(why) => format!("refused: {}", why.replace('|', "/")),
            None if !cal.warnings.is_empty() => {
                format!(
                    "{} ({} warning{})",
                    cal.status,
                    cal.warnings.len(),
                    if cal.warnings.len() == 1 { "" } else { "s" }
                )
            }
            None => cal.status.to_string(),
        };
        let nis: Vec<f64> = runs
            .iter()
            .filter(|r| r.spec.cell == c.cell && r.spec.category.is_healthy())
            .filter_map(|r| r.nis_leading_mean)
            .collect();
        let _ = writeln!(
            out,
            "| {}{} | {} bar | {} °C | {status} | {} | {} | {} | {} |",
            c.cell.rig,
            if c.cell.temp_column {
                " (temp_oil)"
            } else {
                ""
            },
            c.cell.supply_bar,
            c.cell.temp_c,
            cal.loop_oscillation_share
                .map_or("–".into(), |s| format!("{:.0} %", 100.0 * s)),
            match (cal.nis_before, cal.nis_after) {
                (Some(a), Some(b)) => format!("{a:.2} → {b:.2}"),
                _ => "–".into(),
            },
            cal.leak_after_lpm
                .map_or("–".into(), |l| format!("{:.3}", l[0].max(l[1]))),
            med_max(&nis, 2),
        );
    }
    let _ = writeln!(
        out,
        "\nLoop oscillating: the share of the cell's calibration recording in which the position loop hunts (calibrate's `Loop oscillation`: a chamber pressure swinging ≥ 10 % of the supply with the valve command); no sample there counts as leak evidence, and from 50 % a refusal names it as the cause.\n"
    );
}
