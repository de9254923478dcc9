//! `host-sim eval`: the monitor on the independent test plant.

use anyhow::{Context, Result};
use host_sim::eval::{self, RigSet, SetChoice};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Rig set: the development rigs, the held-out rigs (fixed in
    /// advance; report only, never tune on them), both, or the further
    /// development rigs (more of the population to find failures on).
    #[arg(long, value_enum, default_value_t = SetChoice::One(RigSet::Dev))]
    set: SetChoice,
    /// Only the first N rigs of each set.
    #[arg(long, value_name = "N")]
    rigs: Option<usize>,
    /// Supply pressures, bar.
    #[arg(long, value_delimiter = ',', default_values_t = [50.0, 100.0])]
    supply: Vec<f64>,
    /// Oil temperatures, °C.
    #[arg(long, value_delimiter = ',', default_values_t = [25.0, 40.0])]
    temp: Vec<f64>,
    /// The smaller development matrix (one condition per rig, fewer
    /// sizes, a 120 s hold, five faults).
    #[arg(long)]
    quick: bool,
    /// Worker threads [default: the available cores].
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Cache the simulated recordings here (keyed by the plant run): a
    /// re-run re-calibrates and re-replays but does not re-simulate.
    #[arg(long, value_name = "DIR")]
    cache: Option<PathBuf>,
    /// Write every cell's calibration and every run's result here (JSON).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write the Markdown report here [default: standard output].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Parameters to calibrate from [default: the reference rig's].
    #[arg(long)]
    params: Option<PathBuf>,
    /// Give every cell the start parameters instead of calibrating it.
    #[arg(long)]
    no_calibration: bool,
}

/// Plan, execute with a progress bar on stderr, report.
pub fn run(a: Args) -> Result<ExitCode> {
    check(&a)?;
    let plan = eval::plan(&eval::PlanConfig {
        sets: a.set.sets(),
        rigs: a.rigs,
        supply_bar: a.supply.clone(),
        temp_c: a.temp.clone(),
        quick: a.quick,
        ..eval::PlanConfig::default()
    });
    let mut cfg = eval::ExecConfig {
        start: host_sim::load_params_or_nominal(a.params.as_deref())?,
        calibrate: !a.no_calibration,
        cache: a.cache.clone(),
        ..eval::ExecConfig::default()
    };
    if let Some(j) = a.jobs {
        cfg.jobs = j;
    }
    let total = plan.cells.len() + plan.runs();
    // Drawn on a terminal only (stderr); logs get the summary line below.
    let bar = indicatif::ProgressBar::new(total as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} calibrations and runs, {elapsed} (about {eta} left)",
        )?,
    );
    let progress = |done: usize, _total: usize| bar.set_position(done as u64);
    let ev = eval::run_plan(&plan, &cfg, &progress)?;
    bar.finish_and_clear();
    eprintln!(
        "{} cells, {} runs in {:.0} s on {} threads",
        ev.cells.len(),
        ev.runs.len(),
        ev.wall_s,
        ev.jobs
    );
    write_outputs(&a, &ev)?;
    Ok(ExitCode::SUCCESS)
}

/// The options' ranges.
fn check(a: &Args) -> Result<()> {
    anyhow::ensure!(
        !a.supply.is_empty() && a.supply.iter().all(|p| p.is_finite() && *p > 0.0),
        "--supply must be pressures > 0 bar"
    );
    anyhow::ensure!(
        !a.temp.is_empty() && a.temp.iter().all(|t| t.is_finite()),
        "--temp must be temperatures in °C"
    );
    anyhow::ensure!(a.rigs != Some(0), "--rigs must be at least 1");
    anyhow::ensure!(a.jobs != Some(0), "--jobs must be at least 1");
    Ok(())
}

/// The JSON results and the Markdown report.
fn write_outputs(a: &Args, ev: &eval::Evaluation) -> Result<()> {
    if let Some(path) = &a.json {
        let f = std::fs::File::create(path)
            .with_context(|| format!("{}: cannot create", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        serde_json::to_writer(&mut w, ev)?;
        writeln!(w)?;
        w.flush()?;
    }
    let report = eval::report::markdown(ev);
    match &a.output {
        Some(path) => std::fs::write(path, report)
            .with_context(|| format!("{}: cannot write", path.display()))?,
        None => super::stdout().write_all(report.as_bytes())?,
    }
    Ok(())
}
