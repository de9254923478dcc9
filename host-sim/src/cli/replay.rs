//! `host-sim replay`: the monitor over recordings.

use anyhow::{Context, Result};
use host_sim::recording::RecordingReader;
use host_sim::replay::{print_summary, replay, TraceWriter};
use monitor::{Channel, Params};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Recordings (CSV per `docs/recording-format.md`, optionally gzipped;
    /// `-` reads standard input). With `--json`, one JSON object per
    /// recording, one per line. A recording that cannot be read is
    /// reported on stderr and the others are still replayed; the exit
    /// status is then 2. Limits: lines of 64 KiB, 16 GiB of text.
    #[arg(required = true)]
    recordings: Vec<PathBuf>,
    /// Installation parameters (TOML, e.g. from `calibrate`; `-` reads
    /// standard input). Without them, the reference rig's as a
    /// provisional set: only gross leaks alarm, never `healthy`
    /// (`examples/reference-rig.toml` is the examples' own set).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Print exactly one JSON object per recording (`docs/cli.md`).
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
    host_sim::stdin_used_once(
        a.params.as_deref(),
        a.recordings.iter().map(PathBuf::as_path),
    )?;
    let params = host_sim::load_params_or_provisional(a.params.as_deref())?;
    anyhow::ensure!(
        a.trace.is_none() || a.recordings.len() == 1,
        "--trace takes a single recording"
    );
    let mut failed = 0;
    let mut printed = 0;
    for recording in &a.recordings {
        match replay_one(recording, &params, &a, printed > 0) {
            Ok(()) => printed += 1,
            Err(e) if super::is_broken_pipe(&e) => return Err(e),
            Err(e) => {
                super::report(&e);
                failed += 1;
            }
        }
    }
    if failed == 0 {
        return Ok(ExitCode::SUCCESS);
    }
    if a.recordings.len() > 1 {
        eprintln!(
            "error: {failed} of {} recordings could not be replayed",
            a.recordings.len()
        );
    }
    Ok(ExitCode::from(super::EXIT_ERROR))
}

/// Replay one recording and print its summary (after a blank line if
/// `separate` and the output is for people).
fn replay_one(recording: &Path, params: &Params, a: &Args, separate: bool) -> Result<()> {
    let reader = RecordingReader::open(recording)?;
    let name = recording.display().to_string();
    if params.laminar_factor_held() && !reader.has_channel(Channel::TempOil) {
        eprintln!(
            "warning: {name}: no temp_oil column, but the parameters hold the laminar leakage \
             factor (filter.q_laminar = 0, calibrated where the oil temperature is read): the \
             temperature is a required reading, so every sample is a sensor fault; calibrate \
             from a recording of this installation without temp_oil for a file that does not \
             need it"
        );
    }
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
    let mut out = super::stdout();
    if separate && !a.json {
        writeln!(out)?;
    }
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
    out.flush()?;
    Ok(())
}
