//! `host-sim golden` (developer only): golden cases for the on-target
//! tests in QEMU.

use anyhow::Result;
use clap::Subcommand;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Subcommand)]
pub enum Action {
    /// Run the monitor over the first samples of a recording and write
    /// PREFIX.input.bin (the samples' exact bit patterns) and
    /// PREFIX.expected.bin (hash chains of every status and filter state).
    Write {
        /// Recording, as a path relative to the repository root (it is
        /// stored in the case and used by `check`).
        recording: PathBuf,
        /// Number of samples from the start.
        #[arg(long)]
        samples: u32,
        /// Filter warm-up, s (nominal: 2 s; shorter reaches the
        /// decision layer's evidence phase in a short case).
        #[arg(long, default_value_t = monitor::Params::NOMINAL.filter.warm_up_s)]
        warm_up: f64,
        /// Output prefix, e.g. golden/data/healthy.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Regenerate every case in DIR from the recording named in it and
    /// fail if a committed file differs.
    Check {
        /// Directory of the cases.
        dir: PathBuf,
        /// Repository root the recordings are relative to.
        #[arg(long, default_value = ".")]
        root: PathBuf,
    },
    /// Print the host's status and filter states at one sample of a case,
    /// in the format a failing QEMU test prints.
    Show {
        /// Case prefix, e.g. golden/data/both.
        prefix: PathBuf,
        /// Sample index (0-based).
        #[arg(long)]
        sample: u32,
    },
}

pub fn run(action: Action) -> Result<ExitCode> {
    use host_sim::golden;
    match action {
        Action::Write {
            recording,
            samples,
            warm_up,
            output,
        } => {
            anyhow::ensure!(
                recording.is_relative(),
                "give the recording relative to the repository root (it is stored in the case)"
            );
            let spec = golden::CaseSpec {
                source: recording.to_string_lossy().replace('\\', "/"),
                samples,
                warm_up_s: warm_up,
            };
            let case = golden::generate(std::path::Path::new("."), &spec)?;
            golden::write(&output, &case)?;
            let name = output.file_name().map(|n| n.to_string_lossy().into_owned());
            writeln!(
                super::stdout(),
                "{}",
                golden::summary(&name.unwrap_or_default(), &spec, &case)
            )?;
            Ok(ExitCode::SUCCESS)
        }
        Action::Check { dir, root } => {
            let stale = golden::check(&dir, &root)?;
            if stale.is_empty() {
                let dir = dir.display();
                writeln!(super::stdout(), "golden cases in {dir} are up to date")?;
                Ok(ExitCode::SUCCESS)
            } else {
                for s in &stale {
                    eprintln!("stale: {s}");
                }
                eprintln!("regenerate with scripts/golden.sh and commit the result");
                Ok(ExitCode::FAILURE)
            }
        }
        Action::Show { prefix, sample } => {
            write!(super::stdout(), "{}", golden::show(&prefix, sample)?)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
