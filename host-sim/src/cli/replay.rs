//! `host-sim replay`: the monitor over recordings.

use anyhow::{Context, Result};
use host_sim::recording::RecordingReader;
use host_sim::replay::{print_summary, replay, TraceWriter};
use monitor::Params;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Recordings (CSV per `recording-csv.md`, optionally gzipped). With
    /// `--json`, one JSON object per recording, one per line.
    #[arg(required = true)]
    recordings: Vec<PathBuf>,
    /// Installation parameters (TOML, e.g. from `calibrate`).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Print exactly one JSON object (`host-sim-cli.md`).
    #[arg(long)]
    json: bool,
    /// Write a per-sample trace of the monitor's status to this CSV.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Trace every n-th sample.
    #[arg(long, default_value_t = 10)]
    trace_every: u64,
    /// Run the f64 reference build of the filter instead of f32.
    #[arg(long)]
    f64: bool,
}

pub fn run(a: Args) -> Result<ExitCode> {
    let params = host_sim::load_params_or_nominal(a.params.as_deref())?;
    anyhow::ensure!(
        a.trace.is_none() || a.recordings.len() == 1,
        "--trace takes a single recording"
    );
    for (i, recording) in a.recordings.iter().enumerate() {
        if i > 0 && !a.json {
            println!();
        }
        replay_one(recording, &params, &a)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Replay one recording and print its summary.
fn replay_one(recording: &Path, params: &Params, a: &Args) -> Result<()> {
    let reader = RecordingReader::open(recording)?;
    let name = recording.display().to_string();
    let start = std::time::Instant::now();
    let summary = match &a.trace {
        Some(path) => {
            let f = std::fs::File::create(path)
                .with_context(|| format!("{}: cannot create", path.display()))?;
            let mut t = TraceWriter::new(std::io::BufWriter::new(f), a.trace_every)?;
            if a.f64 {
                replay::<f64, _>(reader, &name, params, &mut t)?
            } else {
                replay::<f32, _>(reader, &name, params, &mut t)?
            }
        }
        None if a.f64 => replay::<f64, _>(reader, &name, params, &mut ())?,
        None => replay::<f32, _>(reader, &name, params, &mut ())?,
    };
    let elapsed = start.elapsed().as_secs_f64();
    let mut out = std::io::stdout().lock();
    if a.json {
        serde_json::to_writer(&mut out, &summary)?;
        writeln!(out)?;
    } else {
        print_summary(&summary, &mut out)?;
        writeln!(
            out,
            "throughput  {:.0} samples/s",
            summary.samples as f64 / elapsed.max(1e-9)
        )?;
    }
    Ok(())
}
