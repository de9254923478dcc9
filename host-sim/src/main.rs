//! `host-sim`: replay recordings through the leak monitor, simulate a rig,
//! calibrate an installation, evaluate, plot, decode the monitor's CAN
//! frames.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_sim::eval::{self, SetChoice};
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
    /// Plot a recording and the monitor's view of it (SVG): pressures,
    /// motion, leak estimates against the alarm levels, probabilities.
    Plot {
        /// Recording (CSV per `recording-csv.md`, optionally gzipped).
        recording: PathBuf,
        /// Output SVG [default: the recording's name with `.svg`, in the
        /// current directory].
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Installation parameters (TOML, e.g. from `calibrate`).
        #[arg(long)]
        params: Option<PathBuf>,
    },
    /// Fit an installation's parameters from a leak-free recording of it.
    Calibrate {
        /// A recording of the installation known to be healthy (a minute or
        /// more of holds and moves in both directions).
        recording: PathBuf,
        /// Where to write the parameters (TOML).
        #[arg(short, long)]
        output: PathBuf,
        /// Start from these parameters instead of the reference rig's.
        #[arg(long)]
        params: Option<PathBuf>,
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
        /// Sample rate of the recording, Hz.
        #[arg(long, default_value_t = 1000.0)]
        rate: f64,
        /// White noise on every pressure reading, bar (1σ).
        #[arg(long)]
        pressure_noise: Option<f64>,
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
        /// Also write the simulated rig's true plant parameters (TOML) here.
        #[arg(long)]
        dump_rig: Option<PathBuf>,
    },
    /// Evaluate the monitor on the independent test plant: rigs × supply ×
    /// temperature cells, each calibrated from its own healthy recording;
    /// healthy, leak, step-test, long-hold and fault runs; a Markdown
    /// report per rig set (development / held-out) against the targets.
    Eval {
        /// Rig set: the development rigs, the held-out rigs (fixed in
        /// advance; report only, never tune on them), or both.
        #[arg(long, value_enum, default_value_t = SetChoice::Dev)]
        set: SetChoice,
        /// Only the first N rigs of each set.
        #[arg(long, value_name = "N")]
        rigs: Option<usize>,
        /// Supply pressures, bar.
        #[arg(long, value_delimiter = ',', default_values_t = [50.0, 100.0])]
        supply: Vec<f64>,
        /// Oil temperatures, °C.
        #[arg(long, value_delimiter = ',', default_values_t = [25.0, 40.0])]
        temp: Vec<f64>,
        /// The smaller development matrix (one condition per rig, fewer
        /// sizes, a 120 s hold, four faults).
        #[arg(long)]
        quick: bool,
        /// Worker threads [default: the available cores].
        #[arg(long, value_name = "N")]
        jobs: Option<usize>,
        /// Cache the simulated recordings here (keyed by the plant run): a
        /// re-run re-calibrates and re-replays but does not re-simulate.
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
        /// Write every cell's calibration and every run's result here (JSON).
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Write the Markdown report here [default: standard output].
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
        /// Parameters to calibrate from [default: the reference rig's].
        #[arg(long)]
        params: Option<PathBuf>,
        /// Give every cell the start parameters instead of calibrating it.
        #[arg(long)]
        no_calibration: bool,
    },
    /// Decode the leak monitor's CAN frames in a candump log
    /// (`candump -l`: `(sec.usec) iface id#hex`), checking every frame's
    /// CRC and counter.
    Decode {
        /// The log (`-` reads standard input).
        log: PathBuf,
        /// One JSON object per frame instead of text.
        #[arg(long)]
        json: bool,
        /// Exit with status 1 if any frame has a bad CRC, a malformed
        /// field, a counter jump or a repeated counter.
        #[arg(long)]
        strict: bool,
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

/// `run.csv.gz` → `run.svg` in the current directory.
fn default_plot_path(recording: &std::path::Path) -> PathBuf {
    let name = recording
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let stem = name
        .strip_suffix(".gz")
        .unwrap_or(&name)
        .trim_end_matches(".csv")
        .to_string();
    PathBuf::from(format!("{stem}.svg"))
}

/// Decode a candump log; the summary goes to stderr.
fn decode(log: &std::path::Path, json: bool, strict: bool) -> Result<ExitCode> {
    let name = log.display().to_string();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let summary = if log.as_os_str() == "-" {
        host_sim::decode::decode_log(std::io::stdin().lock(), "<stdin>", json, &mut out)?
    } else {
        let f = std::fs::File::open(log).with_context(|| format!("{name}: cannot open"))?;
        host_sim::decode::decode_log(std::io::BufReader::new(f), &name, json, &mut out)?
    };
    out.flush()?;
    eprintln!("{summary}");
    Ok(if strict && summary.has_errors() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// The `eval` subcommand's arguments.
struct EvalArgs {
    set: SetChoice,
    rigs: Option<usize>,
    supply: Vec<f64>,
    temp: Vec<f64>,
    quick: bool,
    jobs: Option<usize>,
    cache: Option<PathBuf>,
    json: Option<PathBuf>,
    output: Option<PathBuf>,
    params: Option<PathBuf>,
    no_calibration: bool,
}

/// `host-sim eval`: plan, execute with a progress bar on stderr, report.
fn run_eval(a: EvalArgs) -> Result<ExitCode> {
    anyhow::ensure!(
        !a.supply.is_empty() && a.supply.iter().all(|p| p.is_finite() && *p > 0.0),
        "--supply must be pressures > 0 bar"
    );
    anyhow::ensure!(
        !a.temp.is_empty() && a.temp.iter().all(|t| t.is_finite()),
        "--temp must be temperatures in °C"
    );
    anyhow::ensure!(a.rigs != Some(0), "--rigs must be at least 1");
    anyhow::ensure!(a.jobs != Some(0), "--jobs must be at least 1");
    let plan = eval::plan(&eval::PlanConfig {
        sets: a.set.sets(),
        rigs: a.rigs,
        supply_bar: a.supply,
        temp_c: a.temp,
        quick: a.quick,
        ..eval::PlanConfig::default()
    });
    let mut cfg = eval::ExecConfig {
        start: host_sim::load_params_or_nominal(a.params.as_deref())?,
        calibrate: !a.no_calibration,
        cache: a.cache,
        ..eval::ExecConfig::default()
    };
    if let Some(j) = a.jobs {
        cfg.jobs = j;
    }
    let total = plan.cells.len() + plan.runs();
    // Drawn on a terminal only (stderr); logs get the summary line below.
    let bar = indicatif::ProgressBar::new(total as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} calibrations and runs, {elapsed} (about {eta} left)",
        )?,
    );
    let progress = |done: usize, _total: usize| bar.set_position(done as u64);
    let ev = eval::run_plan(&plan, &cfg, &progress)?;
    bar.finish_and_clear();
    eprintln!(
        "{} cells, {} runs in {:.0} s on {} threads",
        ev.cells.len(),
        ev.runs.len(),
        ev.wall_s,
        ev.jobs
    );
    if let Some(path) = &a.json {
        let f = std::fs::File::create(path)
            .with_context(|| format!("{}: cannot create", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        serde_json::to_writer(&mut w, &ev)?;
        writeln!(w)?;
        w.flush()?;
    }
    let report = eval::report::markdown(&ev);
    match &a.output {
        Some(path) => std::fs::write(path, report)
            .with_context(|| format!("{}: cannot write", path.display()))?,
        None => print!("{report}"),
    }
    Ok(ExitCode::SUCCESS)
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Decode { log, json, strict } => decode(&log, json, strict),
        Command::Golden { action } => run_golden(action),
        Command::Replay {
            recordings,
            params,
            json,
            trace,
            trace_every,
            f64,
        } => {
            let params = host_sim::load_params_or_nominal(params.as_deref())?;
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
        Command::Plot {
            recording,
            output,
            params,
        } => {
            let params = host_sim::load_params_or_nominal(params.as_deref())?;
            let output = output.unwrap_or_else(|| default_plot_path(&recording));
            let reader = RecordingReader::open(&recording)?;
            let mut obs = host_sim::plot::PlotObserver::new(host_sim::plot::MAX_POINTS);
            let name = recording.display().to_string();
            let summary = replay::<f32, _>(reader, &name, &params, &mut obs)?;
            host_sim::plot::write_svg(&output, &summary, &obs, &params)?;
            println!(
                "{}: verdict {}; plot written to {}",
                name,
                summary.verdict,
                output.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate {
            recording,
            output,
            params,
        } => {
            let start = host_sim::load_params_or_nominal(params.as_deref())?;
            let (samples, period) = host_sim::read_all(&recording)?;
            // Calibrate at the recording's own rate, as `replay` runs it.
            let mut start = start;
            if let Some(p) = period {
                start.filter.sample_period_s = p;
            }
            let cal = match host_sim::calibrate::calibrate(&samples, &start) {
                Ok(cal) => cal,
                Err(e) => {
                    // What was found up to the refusal, then the reason.
                    if let Some(report) = e.report() {
                        print!("{report}");
                    }
                    return Err(e).with_context(|| format!("{}", recording.display()));
                }
            };
            print!("{}", cal.summary());
            for w in cal.warnings() {
                eprintln!("warning: {w}");
            }
            let text = cal.to_toml(&recording.display().to_string())?;
            std::fs::write(&output, text)
                .with_context(|| format!("{}: cannot write", output.display()))?;
            println!("parameters written to {}", output.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Eval {
            set,
            rigs,
            supply,
            temp,
            quick,
            jobs,
            cache,
            json,
            output,
            params,
            no_calibration,
        } => run_eval(EvalArgs {
            set,
            rigs,
            supply,
            temp,
            quick,
            jobs,
            cache,
            json,
            output,
            params,
            no_calibration,
        }),
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
            rate,
            pressure_noise,
            rig_seed,
            rig,
            no_truth,
            dump_rig,
        } => {
            let nominal = host_sim::load_params_or_nominal(rig.as_deref())?;
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
                sample_rate_hz: rate,
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
            anyhow::ensure!(
                (100.0..=20_000.0).contains(&rate),
                "--rate must be within 100..20000 Hz"
            );
            if let Some(n) = pressure_noise {
                anyhow::ensure!(n >= 0.0 && n.is_finite(), "--pressure-noise must be ≥ 0");
                scenario.sensors.pressure_noise_bar = n;
            }
            if let Some(path) = &dump_rig {
                let mut truth = rig_hw.plant.clone();
                truth.sensors.pressure_offsets_bar = scenario.sensors.pressure_offsets_bar;
                truth.sensors.position_offset_m = scenario.sensors.position_offset_m;
                let text = format!(
                    "# True plant of the simulated rig (edge gains P→A, B→T, P→B, A→T: {:?})\n{}",
                    rig_hw.edge_gain,
                    toml::to_string(&truth)?
                );
                std::fs::write(path, text)
                    .with_context(|| format!("{}: cannot write", path.display()))?;
            }
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
