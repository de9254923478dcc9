//! `host-sim`: replay recordings through the leak monitor, simulate a rig,
//! calibrate an installation, evaluate, plot, decode the monitor's CAN
//! frames. The subcommands live in `cli/`, one module each.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
