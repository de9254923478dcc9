//! `host-sim`: replay recordings through the leak monitor, simulate a rig,
//! calibrate an installation, evaluate, plot.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_sim::eval::{self, Case, Nominal};
use host_sim::recording::{RecordingReader, RecordingWriter};
use host_sim::replay::{print_summary, replay, TraceWriter};
use host_sim::sim::{perturbed_rig, LeakLaw, Profile, Rig, Scenario, Simulation};
use monitor::Params;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Leak monitor for hydraulic cylinders: desktop tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the monitor over recordings (same code as the firmware).
    Replay {
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
    },
    /// Simulate the rig and write a recording.
    Simulate {
        /// Output recording.
        #[arg(short, long)]
        output: PathBuf,
        /// Motion profile.
        #[arg(long, value_enum, default_value_t = Profile::Thesis)]
        profile: Profile,
        /// Length, s.
        #[arg(long, default_value_t = 60.0)]
        duration: f64,
        /// Supply pressure, bar.
        #[arg(long, default_value_t = 50.0)]
        supply: f64,
        /// Oil temperature, °C.
        #[arg(long, default_value_t = 25.0)]
        temp: f64,
        /// Write the oil temperature column.
        #[arg(long)]
        with_temp: bool,
        /// Internal leak (piston seal), mean flow after onset, l/min.
        #[arg(long, default_value_t = 0.0)]
        internal: f64,
        /// External leak (rod side to tank), mean flow after onset, l/min.
        #[arg(long, default_value_t = 0.0)]
        external: f64,
        /// Leak onset time, s.
        #[arg(long, default_value_t = 0.0)]
        onset: f64,
        /// Flow law of both leaks.
        #[arg(long, value_enum, default_value_t = LeakLaw::Laminar)]
        law: LeakLaw,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Simulate a rig that differs from nominal (seeded variation of
        /// valve, friction, mass, air, dead volumes, sensor offsets).
        #[arg(long)]
        rig_seed: Option<u64>,
        /// Rig plant parameters (TOML) instead of nominal.
        #[arg(long)]
        rig: Option<PathBuf>,
        /// Omit the truth columns (q_internal_lpm, q_external_lpm).
        #[arg(long)]
        no_truth: bool,
    },
    /// Simulate a matrix of rigs, conditions and leaks and tabulate how the
    /// monitor does.
    Eval {
        /// Supply pressures, bar.
        #[arg(long, value_delimiter = ',', default_values_t = [50.0, 100.0])]
        supply: Vec<f64>,
        /// Oil temperatures, °C.
        #[arg(long, value_delimiter = ',', default_values_t = [25.0, 40.0])]
        temp: Vec<f64>,
        /// Leak kinds: healthy, internal, external, both.
        #[arg(long, value_delimiter = ',', default_values_t = ["healthy".to_string(), "internal".to_string(), "external".to_string(), "both".to_string()])]
        kinds: Vec<String>,
        /// Leak sizes, l/min.
        #[arg(long, value_delimiter = ',', default_values_t = [0.03, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0])]
        sizes: Vec<f64>,
        /// Leak onsets, s (0 = from the start).
        #[arg(long, value_delimiter = ',', default_values_t = [0.0, 30.0])]
        onsets: Vec<f64>,
        /// Number of rig variations.
        #[arg(long, default_value_t = 3)]
        rigs: u64,
        /// First rig seed.
        #[arg(long, default_value_t = 1)]
        first_rig: u64,
        /// Use the nominal rig as rig 0.
        #[arg(long)]
        nominal_rig: bool,
        /// Run length, s.
        #[arg(long, default_value_t = 60.0)]
        duration: f64,
        /// Motion profile.
        #[arg(long, default_value = "thesis")]
        profile: String,
        /// Leak flow law.
        #[arg(long, default_value = "laminar")]
        law: String,
        /// Monitor parameters for every rig (default nominal).
        #[arg(long)]
        params: Option<PathBuf>,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Write every run's result as JSON lines here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Golden cases for the on-target tests in QEMU (`tests/golden/data`;
    /// regenerate them all with `scripts/golden.sh`).
    Golden {
        #[command(subcommand)]
        action: GoldenAction,
    },
}

#[derive(Subcommand)]
enum GoldenAction {
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
        /// Filter warm-up, s (nominal: 10 s; shorter reaches the
        /// decision layer's evidence phase in a short case).
        #[arg(long, default_value_t = monitor::Params::NOMINAL.filter.warm_up_s)]
        warm_up: f64,
        /// Output prefix, e.g. tests/golden/data/healthy.
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
        /// Case prefix, e.g. tests/golden/data/both.
        prefix: PathBuf,
        /// Sample index (0-based).
        #[arg(long)]
        sample: u32,
    },
}

fn run_golden(action: GoldenAction) -> Result<ExitCode> {
    use host_sim::golden;
    match action {
        GoldenAction::Write {
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
            println!(
                "{}",
                golden::summary(&name.unwrap_or_default(), &spec, &case)
            );
            Ok(ExitCode::SUCCESS)
        }
        GoldenAction::Check { dir, root } => {
            let stale = golden::check(&dir, &root)?;
            if stale.is_empty() {
                println!("golden cases in {} are up to date", dir.display());
                Ok(ExitCode::SUCCESS)
            } else {
                for s in &stale {
                    eprintln!("stale: {s}");
                }
                eprintln!("regenerate with scripts/golden.sh and commit the result");
                Ok(ExitCode::FAILURE)
            }
        }
        GoldenAction::Show { prefix, sample } => {
            print!("{}", golden::show(&prefix, sample)?);
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Replay one recording and print its summary.
fn replay_one(
    recording: &std::path::Path,
    params: &Params,
    json: bool,
    trace: Option<&std::path::Path>,
    trace_every: u64,
    f64: bool,
) -> Result<()> {
    let reader = RecordingReader::open(recording)?;
    let name = recording.display().to_string();
    let start = std::time::Instant::now();
    let summary = match trace {
        Some(path) => {
            let f = std::fs::File::create(path)
                .with_context(|| format!("{}: cannot create", path.display()))?;
            let mut t = TraceWriter::new(std::io::BufWriter::new(f), trace_every)?;
            if f64 {
                replay::<f64, _>(reader, &name, params, &mut t)?
            } else {
                replay::<f32, _>(reader, &name, params, &mut t)?
            }
        }
        None if f64 => replay::<f64, _>(reader, &name, params, &mut ())?,
        None => replay::<f32, _>(reader, &name, params, &mut ())?,
    };
    let elapsed = start.elapsed().as_secs_f64();
    let mut out = std::io::stdout().lock();
    if json {
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

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Golden { action } => run_golden(action),
        Command::Replay {
            recordings,
            params,
            json,
            trace,
            trace_every,
            f64,
        } => {
            let params = match &params {
                Some(p) => host_sim::load_params(p)?,
                None => Params::nominal(),
            };
            anyhow::ensure!(
                trace.is_none() || recordings.len() == 1,
                "--trace takes a single recording"
            );
            for (i, recording) in recordings.iter().enumerate() {
                if i > 0 && !json {
                    println!();
                }
                replay_one(recording, &params, json, trace.as_deref(), trace_every, f64)?;
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Eval {
            supply,
            temp,
            kinds,
            sizes,
            onsets,
            rigs,
            first_rig,
            nominal_rig,
            duration,
            profile,
            law,
            params,
            threads,
            out,
        } => {
            let params = match &params {
                Some(p) => host_sim::load_params(p)?,
                None => Params::nominal(),
            };
            let kind_name = |k: &str| -> Result<&'static str> {
                Ok(match k {
                    "healthy" => "healthy",
                    "internal" => "internal",
                    "external" => "external",
                    "both" => "both",
                    _ => anyhow::bail!("unknown leak kind `{k}`"),
                })
            };
            let profile: &'static str = match profile.as_str() {
                "thesis" => "thesis",
                "random" => "random",
                "steps" => "steps",
                "hold" => "hold",
                p => anyhow::bail!("unknown profile `{p}`"),
            };
            let law: &'static str = if law == "orifice" {
                "orifice"
            } else {
                "laminar"
            };
            let mut cases = Vec::new();
            let mut seed = 1000;
            for rig in first_rig..first_rig + rigs {
                for &sup in &supply {
                    for &tc in &temp {
                        for k in &kinds {
                            let kind = kind_name(k)?;
                            let (sz, on): (&[f64], &[f64]) = if kind == "healthy" {
                                (&[0.0], &[0.0])
                            } else {
                                (&sizes, &onsets)
                            };
                            for &size in sz {
                                for &onset in on {
                                    seed += 1;
                                    cases.push(Case {
                                        rig,
                                        supply_bar: sup,
                                        temp_c: tc,
                                        kind,
                                        size_lpm: size,
                                        onset_s: onset,
                                        seed,
                                        law,
                                        profile,
                                        duration_s: duration,
                                    });
                                }
                            }
                        }
                    }
                }
            }
            let start = std::time::Instant::now();
            let progress = |d: usize, n: usize| {
                eprint!("\r{d}/{n} runs");
            };
            let results = eval::run_all(&cases, &Nominal(params), nominal_rig, threads, &progress);
            eprintln!(" in {:.0} s", start.elapsed().as_secs_f64());
            if let Some(path) = out {
                let mut f = std::io::BufWriter::new(std::fs::File::create(&path)?);
                for r in &results {
                    serde_json::to_writer(&mut f, r)?;
                    writeln!(f)?;
                }
            }
            print!("{}", eval::table(&results));
            Ok(ExitCode::SUCCESS)
        }
        Command::Simulate {
            output,
            profile,
            duration,
            supply,
            temp,
            with_temp,
            internal,
            external,
            onset,
            law,
            seed,
            rig_seed,
            rig,
            no_truth,
        } => {
            let nominal = match &rig {
                Some(p) => host_sim::load_params(p)?,
                None => Params::nominal(),
            };
            let mut scenario = Scenario {
                duration_s: duration,
                supply_bar: supply,
                temp_c: temp,
                write_temperature: with_temp,
                profile,
                internal_lpm: internal,
                external_lpm: external,
                internal_law: law,
                external_law: law,
                leak_onset_s: onset,
                seed,
                ..Scenario::default()
            };
            let rig_hw = match rig_seed {
                Some(s) => {
                    let (r, sensors) = perturbed_rig(&nominal, s);
                    scenario.sensors = sensors;
                    r
                }
                None => Rig {
                    plant: nominal,
                    ..Rig::nominal()
                },
            };
            anyhow::ensure!(
                duration > 0.0 && duration.is_finite(),
                "--duration must be > 0"
            );
            anyhow::ensure!(internal >= 0.0 && external >= 0.0, "leak flows must be ≥ 0");
            let meta = vec![
                ("sample_rate_hz", format!("{}", scenario.sample_rate_hz)),
                ("source", format!("host-sim {} simulate", env!("CARGO_PKG_VERSION"))),
                (
                    "note",
                    format!(
                        "{supply} bar, {temp} C, {profile:?} profile, internal {internal} l/min, external {external} l/min ({law:?}), onset {onset} s, seed {seed}{}",
                        rig_seed.map_or(String::new(), |s| format!(", rig seed {s}"))
                    ),
                ),
            ];
            let extra: &[&str] = if no_truth {
                &[]
            } else {
                &["q_internal_lpm", "q_external_lpm"]
            };
            let mut w = RecordingWriter::create(&output, &meta, with_temp, extra)
                .with_context(|| format!("{}: cannot create", output.display()))?;
            for row in Simulation::new(scenario, rig_hw) {
                let truth = [row.q_internal_lpm, row.q_external_lpm];
                w.write(&row.sample, if no_truth { &[] } else { &truth })?;
            }
            w.close()?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
