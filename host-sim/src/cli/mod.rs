//! The command line: one module per subcommand, each with its arguments
//! and a short `run`.

mod calibrate;
mod decode;
mod eval;
mod golden;
mod plot;
mod replay;
mod simulate;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Leak monitor for hydraulic cylinders: desktop tools"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the monitor over recordings (same code as the firmware).
    Replay(replay::Args),
    /// Plot a recording and the monitor's view of it (SVG): pressures,
    /// motion, leak estimates against the alarm levels, probabilities.
    Plot(plot::Args),
    /// Fit an installation's parameters from a leak-free recording of it.
    Calibrate(calibrate::Args),
    /// Simulate the rig and write a recording.
    Simulate(simulate::Args),
    /// Evaluate the monitor on the independent test plant: rigs × supply ×
    /// temperature cells, each calibrated from its own healthy recording;
    /// healthy, leak, step-test, long-hold and fault runs; a Markdown
    /// report per rig set (development / held-out) against the targets.
    Eval(eval::Args),
    /// Decode the leak monitor's CAN frames in a candump log
    /// (`candump -l`: `(sec.usec) iface id#hex`), checking every frame's
    /// CRC and counter.
    Decode(decode::Args),
    /// Golden cases for the on-target tests in QEMU (`tests/golden/data`;
    /// regenerate them all with `scripts/golden.sh`).
    Golden {
        #[command(subcommand)]
        action: golden::Action,
    },
}

/// Parse the command line, run it, report an error on stderr.
pub fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Replay(a) => replay::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Decode(a) => decode::run(a),
        Command::Golden { action } => golden::run(action),
    }
}
