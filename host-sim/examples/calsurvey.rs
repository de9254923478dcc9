//! How often does calibration refuse or fall back, and why? Calibrates
//! the further development rigs' cells (`eval --set wide`, full matrix;
//! never the held-out ones), each from the same 60 s healthy recording
//! `eval` calibrates it from, and prints one line per cell: status, the
//! refusal or the partial calibration's reason, and which fits were kept.
//!
//! `cargo run --release -p host-sim --example calsurvey -- FIRST LAST CACHE [PARAMS.toml]`
//! (the further rigs with seeds FIRST..=LAST, each at the four conditions
//! of the full matrix).
use anyhow::ensure;
use host_sim::eval::exec::{calibrate_cell, ExecConfig};
use host_sim::eval::plan::{plan, PlanConfig};
use host_sim::eval::{RigSet, WIDE_RIGS};
use host_sim::load_params_or_nominal;
use std::path::{Path, PathBuf};

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    ensure!(a.len() >= 4, "usage: FIRST LAST CACHE [PARAMS.toml]");
    let (first, last): (u64, u64) = (a[1].parse()?, a[2].parse()?);
    let start = load_params_or_nominal(a.get(4).map(Path::new))?;
    let cfg = ExecConfig {
        start,
        calibrate: true,
        jobs: 1,
        cache: Some(PathBuf::from(&a[3])),
    };
    ensure!(
        (first..=last).all(|seed| WIDE_RIGS.contains(&seed)),
        "rigs {first}..={last}: only further development rigs ({:?})",
        WIDE_RIGS
    );
    // The evaluation's own plan, so that each cell is calibrated from the
    // recording `eval --set wide` calibrates it from.
    let wide = plan(&PlanConfig {
        sets: vec![RigSet::Wide],
        ..PlanConfig::default()
    });
    let (mut refused, mut partial, mut total) = (0, 0, 0);
    // Partial calibrations by what they kept.
    let (mut valve_kept, mut load_kept) = (0, 0);
    for cp in wide
        .cells
        .iter()
        .filter(|cp| (first..=last).contains(&cp.cell.rig))
    {
        let r = calibrate_cell(cp, &cfg)?;
        let c = &r.calibration;
        total += 1;
        let why = match (
            &c.refused,
            c.warnings.iter().find(|w| w.starts_with("partial")),
        ) {
            (Some(e), _) => {
                refused += 1;
                e.replace('\n', " ")
            }
            (None, Some(w)) => {
                partial += 1;
                w.clone()
            }
            _ => String::new(),
        };
        let said = |what: &str| c.warnings.iter().any(|w| w.starts_with(what));
        valve_kept += usize::from(said("valve not fitted"));
        load_kept += usize::from(said("load not fitted"));
        let kept: Vec<&str> = c.fits.iter().map(|f| f.what.as_str()).collect();
        println!(
            "{:<22} {:<10} {} | fitted: {}",
            cp.cell.id(),
            c.status,
            why,
            kept.join(", ")
        );
    }
    println!(
        "{total} cells: {refused} refused, {partial} partial ({valve_kept} with the valve kept, {load_kept} with the load kept)"
    );
    Ok(())
}
