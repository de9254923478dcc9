//! `host-sim decode`: the monitor's CAN frames in a candump log.

use anyhow::{Context, Result};
use host_sim::decode::decode_stream;
use monitor::protocol::Node;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// The log (`-` reads standard input; every frame is printed as soon
    /// as it is read, so `candump -L can0 | host-sim decode -` is live).
    log: PathBuf,
    /// One JSON object per frame instead of text.
    #[arg(long)]
    json: bool,
    /// Exit with status 1 if any frame has a bad CRC, a malformed
    /// field, a counter jump or a repeated counter, or if a line held a
    /// frame that is skipped (CAN error frame, CAN FD or XL, DLC above 8;
    /// each named on stderr).
    #[arg(long)]
    strict: bool,
    /// Decode only the frames of the monitor with this node number
    /// (0..=7, the parameters' `can.node`); without it every node's
    /// frames are decoded, and a node other than 0 is shown after the
    /// name (`LM_Status@3`).
    #[arg(long, value_parser = parse_node)]
    node: Option<Node>,
}

fn parse_node(s: &str) -> Result<Node, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Node::new)
        .ok_or_else(|| format!("`{s}` is not a node number (0..={})", Node::MAX))
}

/// Decode a candump log; the summary goes to stderr.
pub fn run(a: Args) -> Result<ExitCode> {
    let summary = if a.log.as_os_str() == "-" {
        decode(std::io::stdin().lock(), "<stdin>", &a)?
    } else {
        let name = a.log.display().to_string();
        let f = std::fs::File::open(&a.log).with_context(|| format!("{name}: cannot open"))?;
        decode(std::io::BufReader::new(f), &name, &a)?
    };
    eprintln!("{summary}");
    Ok(if a.strict && summary.has_errors() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

fn decode(input: impl BufRead, name: &str, a: &Args) -> Result<host_sim::decode::Summary> {
    let mut out = std::io::BufWriter::new(super::stdout());
    let mut stderr = std::io::stderr();
    let strict = a.strict.then_some(&mut stderr as &mut dyn Write);
    let summary = decode_stream(input, name, a.json, &mut out, strict, a.node)?;
    out.flush()?;
    Ok(summary)
}
