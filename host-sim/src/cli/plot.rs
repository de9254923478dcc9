//! `host-sim plot`: a recording and the monitor's view of it as SVG.

use anyhow::Result;
use host_sim::recording::RecordingReader;
use host_sim::replay::replay;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Recording (CSV per `docs/recording-format.md`, optionally gzipped;
    /// `-` reads standard input).
    recording: PathBuf,
    /// Output SVG [default: the recording's name with `.svg`, in the
    /// current directory].
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Installation parameters (TOML, e.g. from `calibrate`; `-` reads
    /// standard input). Without them, the reference rig's as a
    /// provisional set: only gross leaks alarm, never `healthy`
    /// (`examples/reference-rig.toml` is the examples' own set).
    #[arg(long)]
    params: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<ExitCode> {
    host_sim::stdin_used_once(a.params.as_deref(), [a.recording.as_path()])?;
    let params = host_sim::load_params_or_provisional(a.params.as_deref())?;
    let output = a.output.unwrap_or_else(|| default_plot_path(&a.recording));
    let reader = RecordingReader::open(&a.recording)?;
    let mut obs = host_sim::plot::PlotObserver::new(host_sim::plot::MAX_POINTS);
    let name = a.recording.display().to_string();
    let summary = replay::<f32, _>(reader, &name, &params, &mut obs)?;
    host_sim::plot::write_svg(&output, &summary, &obs, &params)?;
    writeln!(
        super::stdout(),
        "{}: verdict {}; plot written to {}",
        name,
        summary.verdict,
        output.display()
    )?;
    Ok(ExitCode::SUCCESS)
}

/// `run.csv.gz` → `run.svg` in the current directory (`recording.svg`
/// for standard input).
fn default_plot_path(recording: &Path) -> PathBuf {
    let name = Some(recording)
        .filter(|r| r.as_os_str() != "-")
        .and_then(Path::file_name)
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let stem = name
        .strip_suffix(".gz")
        .unwrap_or(&name)
        .trim_end_matches(".csv")
        .to_string();
    PathBuf::from(format!("{stem}.svg"))
}
