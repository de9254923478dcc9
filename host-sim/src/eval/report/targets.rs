//! The targets: one PASS/FAIL line per target, judged from the runs.

use super::{
    kind_order, med_max, opt, pct, size_key, INCONCLUSIVE_TARGET, LATENCY_TARGET_S,
    SIZE_ERROR_TARGET,
};
use crate::eval::exec::RunResult;
use crate::eval::plan::{AFTER_HOLD_LPM, ONSET_S};
use crate::eval::score::{max, median, HEALTHY, INCONCLUSIVE, SENSOR_FAULT};
use crate::eval::{Category, FaultKind};
use std::collections::BTreeMap;
use std::fmt::Write;

/// One target line.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// The target.
    pub name: String,
    /// Met (`None`: no runs to judge).
    pub pass: Option<bool>,
    /// The numbers.
    pub detail: String,
}

fn target(name: impl Into<String>, pass: Option<bool>, detail: impl Into<String>) -> Target {
    Target {
        name: name.into(),
        pass,
        detail: detail.into(),
    }
}

/// Count-based target: all of `n` runs must satisfy it.
fn all_of(name: &str, rs: &[&RunResult], ok: impl Fn(&RunResult) -> bool) -> Target {
    let k = rs.iter().filter(|r| ok(r)).count();
    let failing: Vec<&str> = rs
        .iter()
        .filter(|r| !ok(r))
        .take(3)
        .map(|r| r.spec.id.as_str())
        .collect();
    target(
        name,
        (!rs.is_empty()).then_some(k == rs.len()),
        format!(
            "{k}/{} runs{}",
            rs.len(),
            if failing.is_empty() {
                String::new()
            } else {
                format!(
                    "; failing e.g. {}{}",
                    failing.join(", "),
                    if rs.len() - k > failing.len() {
                        ", …"
                    } else {
                        ""
                    }
                )
            }
        ),
    )
}

/// Median-per-group target: every (kind, size) group's median ≤ `limit`.
fn medians_within(
    name: &str,
    rs: &[&RunResult],
    values: impl Fn(&RunResult) -> Vec<f64>,
    limit: f64,
    fmt: impl Fn(f64) -> String,
) -> Target {
    let mut groups: BTreeMap<(usize, u64), Vec<f64>> = BTreeMap::new();
    for r in rs {
        let key = (
            kind_order(r.spec.leak_kind()),
            size_key(r.spec.leak_size_lpm()),
        );
        groups.entry(key).or_default().extend(values(r));
    }
    let mut worst: Option<(f64, String)> = None;
    let mut missing = Vec::new();
    for ((k, s), v) in &groups {
        let kind = ["internal", "external", "both"]
            .get(*k)
            .copied()
            .unwrap_or("?");
        let label = format!("{kind} {:.2}", *s as f64 / 1e4);
        match median(v) {
            Some(m) => {
                if worst.as_ref().is_none_or(|(w, _)| m > *w) {
                    worst = Some((m, label));
                }
            }
            None => missing.push(label),
        }
    }
    let pass = if groups.is_empty() {
        None
    } else {
        Some(missing.is_empty() && worst.as_ref().is_none_or(|(w, _)| *w <= limit))
    };
    let mut detail = match &worst {
        Some((w, l)) => format!("largest median {} ({l} l/min)", fmt(*w)),
        None => "no values".into(),
    };
    if !missing.is_empty() {
        let _ = write!(detail, "; nothing to measure for {}", missing.join(", "));
    }
    target(name, pass, detail)
}

/// The targets of a set of runs.
pub fn target_list(runs: &[&RunResult]) -> Vec<Target> {
    let of = |f: &dyn Fn(&RunResult) -> bool| -> Vec<&RunResult> {
        runs.iter().copied().filter(|r| f(r)).collect()
    };
    let healthy = of(&|r| r.spec.category.is_healthy());
    let hcl = of(&|r| r.spec.category == Category::HealthyClosedLoop);
    let leaks = of(&|r| matches!(r.spec.category, Category::Leak | Category::LeakAfterHold));
    let cl_leaks = of(&|r| r.spec.category == Category::Leak);
    let mid = of(&|r| r.spec.category == Category::Leak && r.spec.leak.onset_s > 0.0);
    let sized = of(&|r| r.spec.category == Category::Leak && r.spec.leak_size_lpm() >= 0.2 - 1e-9);
    let fast = of(&|r| {
        r.spec.category == Category::Leak
            && r.spec.leak.onset_s > 0.0
            && r.spec.leak_size_lpm() >= 0.3 - 1e-9
    });
    let step_h = of(&|r| r.spec.category == Category::HealthyStep);
    let step_l =
        of(&|r| r.spec.category == Category::StepLeak && r.spec.leak_size_lpm() >= 0.5 - 1e-9);
    let sensor = of(&|r| r.spec.fault.is_some_and(FaultKind::expects_sensor_fault));
    let unsure = of(&|r| r.spec.fault.is_some_and(|f| !f.expects_sensor_fault()));
    let hold = of(&|r| r.spec.category == Category::HealthyLongHold);
    let unfaulted = of(&|r| r.spec.fault.is_none());
    let after = of(&|r| r.spec.category == Category::LeakAfterHold);

    let mut t = vec![
        all_of(
            "healthy runs (closed loop, long hold, step tests): no alarm",
            &healthy,
            |r| r.alarms.is_empty(),
        ),
        all_of(
            "healthy runs end `healthy` (`inconclusive` counted by the next line)",
            &healthy,
            |r| r.verdict == HEALTHY || r.inconclusive(),
        ),
    ];
    let inc = hcl.iter().filter(|r| r.inconclusive()).count();
    t.push(target(
        format!(
            "healthy closed-loop runs ending `inconclusive` ≤ {:.0} %",
            100.0 * INCONCLUSIVE_TARGET
        ),
        (!hcl.is_empty()).then_some(inc as f64 <= INCONCLUSIVE_TARGET * hcl.len() as f64),
        pct(inc, hcl.len()),
    ));
    t.push(all_of(
        "leak runs: no alarm before the onset",
        &leaks,
        |r| !r.false_alarm(),
    ));
    // A sensor declared faulty on a sound machine drops the relay too.
    t.push(all_of(
        "runs without an injected fault: no sensor fault",
        &unfaulted,
        |r| r.sensor_faults.is_empty(),
    ));
    t.push(all_of(
        "leak runs detected (closed loop, 0.1–1.0 l/min)",
        &cl_leaks,
        |r| r.detected(),
    ));
    t.push(all_of(
        "leak runs isolated (final verdict names exactly the true leaks)",
        &cl_leaks,
        |r| r.isolated(),
    ));
    t.push(medians_within(
        &format!(
            "median size error ≤ {:.0} % per kind and size (≥ 0.2 l/min)",
            100.0 * SIZE_ERROR_TARGET
        ),
        &sized,
        |r| r.size_errors(),
        SIZE_ERROR_TARGET,
        |v| format!("{:.0} %", 100.0 * v),
    ));
    t.push(medians_within(
        &format!(
            "median latency after onset ≤ {LATENCY_TARGET_S} s per kind and size (≥ 0.3 l/min)"
        ),
        &fast,
        |r| r.latency_s().into_iter().collect(),
        LATENCY_TARGET_S,
        |v| format!("{v:.2} s"),
    ));
    t.push(medians_within(
        &format!(
            "median latency after the flow reaches the alarm level ≤ {LATENCY_TARGET_S} s (≥ 0.3 l/min)"
        ),
        &fast,
        |r| r.latency_flowing_s().into_iter().collect(),
        LATENCY_TARGET_S,
        |v| format!("{v:.2} s"),
    ));
    t.push(all_of(
        "step tests, healthy: no alarm, `healthy`",
        &step_h,
        |r| r.passes(),
    ));
    t.push(all_of(
        "step tests with ≥ 0.5 l/min leak: detected",
        &step_l,
        |r| r.detected(),
    ));
    t.push(all_of(
        "faults (spikes, open wires incl. valve command, frozen): `sensor_fault`, no leak alarm after the fault",
        &sensor,
        |r| r.passes(),
    ));
    t.push(all_of(
        "faults (stuck/NaN time, random noise): never `healthy` nor a leak while active",
        &unsure,
        |r| r.passes(),
    ));
    t.push(all_of("long hold: no false alarm", &hold, |r| {
        !r.false_alarm()
    }));
    // After the hold: within the latency range of the same kind's 30 s onsets.
    let mut ok = 0;
    let mut details = Vec::new();
    for r in &after {
        let kind = r.spec.leak_kind();
        let same: Vec<&&RunResult> = mid
            .iter()
            .filter(|m| m.spec.leak_kind() == kind && (m.spec.leak.onset_s - ONSET_S).abs() < 1e-9)
            .collect();
        let nearest = same
            .iter()
            .map(|m| size_key(m.spec.leak_size_lpm()))
            .min_by_key(|s| s.abs_diff(size_key(AFTER_HOLD_LPM)));
        let refs: Vec<f64> = same
            .iter()
            .filter(|m| Some(size_key(m.spec.leak_size_lpm())) == nearest)
            .filter_map(|m| m.latency_s())
            .collect();
        let lat = r.latency_s();
        let pass = match (lat, max(&refs)) {
            (Some(l), Some(m)) => l <= m,
            _ => false,
        };
        if pass {
            ok += 1;
        }
        details.push(format!(
            "rig {} {kind}: {} s vs {} s",
            r.spec.cell.rig,
            opt(lat, 2),
            med_max(&refs, 2)
        ));
    }
    t.push(target(
        "leak after the long hold: detected within the 30 s-onset latency (≤ the largest of the same kind and size)",
        (!after.is_empty()).then_some(ok == after.len()),
        format!(
            "{ok}/{}; {}",
            after.len(),
            if details.is_empty() {
                "–".into()
            } else {
                details.join("; ")
            }
        ),
    ));
    t
}

/// (7) The targets.
pub fn targets(out: &mut String, runs: &[&RunResult]) {
    let _ = writeln!(out, "### Targets\n");
    for t in target_list(runs) {
        let tag = match t.pass {
            Some(true) => "PASS",
            Some(false) => "FAIL",
            None => "n/a ",
        };
        let _ = writeln!(out, "- **{tag}** {}: {}", t.name, t.detail);
    }
    let _ = writeln!(
        out,
        "\nThe 10 % size-error and 2 s latency thresholds are the detection targets (docs/evaluation.md); `{SENSOR_FAULT}` and `{INCONCLUSIVE}` are compared by name.\n"
    );
}
