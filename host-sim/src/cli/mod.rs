//! The command line: one module per subcommand, each with its arguments
//! and a short `run`.

mod calibrate;
mod decode;
mod docs;
mod eval;
mod events;
mod golden;
mod params;
mod plot;
mod record;
mod replay;
mod simulate;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Exit status of an error (unreadable input, bad options); `decode
/// --strict` uses 1 for protocol errors found in a readable log.
const EXIT_ERROR: u8 = 2;

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
    /// Record what the monitor sees from a device over its serial link
    /// (USB) into a recording for `calibrate` and `replay`; reports lost
    /// blocks.
    Record(record::Args),
    /// Upload or show the device's parameter set (only over the serial
    /// link, never over CAN).
    Params {
        #[command(subcommand)]
        action: params::Action,
    },
    /// The device's event memory (alarms, sensor faults, acknowledges,
    /// resets, parameter changes), kept in flash across resets.
    Events(events::Args),
    /// Shell completions (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(docs::CompletionArgs),
    /// The manual page (roff) on stdout: `host-sim man > host-sim.1`.
    Man,
    /// Golden cases for the on-target tests in QEMU (`golden/data`;
    /// regenerate them all with `scripts/golden.sh`). Developer only.
    #[command(hide = true)]
    Golden {
        #[command(subcommand)]
        action: golden::Action,
    },
}

/// Parse the command line, run it, report an error on stderr. A closed
/// pipe on stdout (`host-sim replay … | head -1`) ends the program quietly
/// with status 0, as for any reader that has seen enough.
pub fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            report(&e);
            ExitCode::from(EXIT_ERROR)
        }
    }
}

/// Print an error and its causes on stderr, each once.
fn report(e: &anyhow::Error) {
    eprintln!("error: {e:#}");
}

/// Did writing to stdout fail because the reader went away?
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    use std::io::ErrorKind::BrokenPipe;
    e.chain().any(|c| {
        let io = c.downcast_ref::<std::io::Error>().map(|io| io.kind());
        // serde_json wraps the I/O error of its writer.
        let json = c
            .downcast_ref::<serde_json::Error>()
            .and_then(serde_json::Error::io_error_kind);
        io == Some(BrokenPipe) || json == Some(BrokenPipe)
    })
}

/// Standard output for a subcommand's results: every write is checked (a
/// closed pipe ends the program quietly, see [`main`]).
fn stdout() -> std::io::StdoutLock<'static> {
    std::io::stdout().lock()
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Replay(a) => replay::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Decode(a) => decode::run(a),
        Command::Record(a) => record::run(a),
        Command::Params { action } => params::run(action),
        Command::Events(a) => events::run(a),
        Command::Completions(a) => docs::completions(a),
        Command::Man => docs::man(),
        Command::Golden { action } => golden::run(action),
    }
}
