//! `host-sim calibrate`: an installation's parameters from a leak-free
//! recording of it.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// A recording of the installation known to be healthy (a minute or
    /// more of holds and moves in both directions; `-` reads standard
    /// input).
    recording: PathBuf,
    /// Where to write the parameters (TOML).
    #[arg(short, long)]
    output: PathBuf,
    /// Start from these parameters instead of the reference rig's (`-`
    /// reads standard input).
    #[arg(long)]
    params: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<ExitCode> {
    host_sim::stdin_used_once(a.params.as_deref(), [a.recording.as_path()])?;
    let mut start = host_sim::load_params_or_nominal(a.params.as_deref())?;
    let (samples, period) = host_sim::read_all(&a.recording)?;
    // Calibrate at the recording's own rate, as `replay` runs it.
    if let Some(p) = period {
        start.filter.sample_period_s = p;
    }
    let cal = match host_sim::calibrate::calibrate(&samples, &start) {
        Ok(cal) => cal,
        Err(e) => {
            // What was found up to the refusal, then the reason: both
            // diagnostics, on stderr (stdout stays empty on failure).
            if let Some(report) = e.report() {
                eprint!("{report}");
            }
            // What the installation gets meanwhile.
            eprintln!(
                "note: no parameter file written; without an installation's set the monitor runs provisional: never `healthy`, leaks alarm above {} l/min only (docs/calibration.md)",
                monitor::params::PROVISIONAL_FLOOR_LPM
            );
            return Err(e).with_context(|| format!("{}", a.recording.display()));
        }
    };
    // The report without warnings on stdout, the warnings on stderr.
    write!(super::stdout(), "{}", cal.summary())?;
    for w in cal.warnings() {
        eprintln!("warning: {w}");
    }
    let text = cal.to_toml(&a.recording.display().to_string())?;
    std::fs::write(&a.output, text)
        .with_context(|| format!("{}: cannot write", a.output.display()))?;
    writeln!(
        super::stdout(),
        "parameters written to {}",
        a.output.display()
    )?;
    Ok(ExitCode::SUCCESS)
}
