//! `host-sim decode`: the monitor's CAN frames in a candump log.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// The log (`-` reads standard input).
    log: PathBuf,
    /// One JSON object per frame instead of text.
    #[arg(long)]
    json: bool,
    /// Exit with status 1 if any frame has a bad CRC, a malformed
    /// field, a counter jump or a repeated counter.
    #[arg(long)]
    strict: bool,
}

/// Decode a candump log; the summary goes to stderr.
pub fn run(a: Args) -> Result<ExitCode> {
    let name = a.log.display().to_string();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let summary = if a.log.as_os_str() == "-" {
        host_sim::decode::decode_log(std::io::stdin().lock(), "<stdin>", a.json, &mut out)?
    } else {
        let f = std::fs::File::open(&a.log).with_context(|| format!("{name}: cannot open"))?;
        host_sim::decode::decode_log(std::io::BufReader::new(f), &name, a.json, &mut out)?
    };
    out.flush()?;
    eprintln!("{summary}");
    Ok(if a.strict && summary.has_errors() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
