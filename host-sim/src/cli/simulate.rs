//! `host-sim simulate`: the rig simulator writing a recording.

use anyhow::{Context, Result};
use host_sim::recording::RecordingWriter;
use host_sim::sim::{LeakLaw, Profile, Rig, Scenario, Simulation};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
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
    /// Simulate a rig that differs from the reference rig (seeded
    /// variation of valve, friction, mass, air, dead volumes, sensor
    /// offsets); with --rig, of that rig.
    #[arg(long)]
    rig_seed: Option<u64>,
    /// Simulate this rig instead of the reference rig: the simulator's own
    /// rig data (TOML, as --dump-rig writes it; a file needs only what
    /// differs from the reference rig). Not a monitor parameters file.
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    /// Omit the truth columns (q_internal_lpm, q_external_lpm).
    #[arg(long)]
    no_truth: bool,
    /// Also write the simulated rig's data here (TOML, the format --rig
    /// reads: with the same other options, --rig FILE simulates the same
    /// rig again).
    #[arg(long, value_name = "FILE")]
    dump_rig: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<ExitCode> {
    check(&a)?;
    let base = match a.rig.as_deref() {
        Some(path) => load_rig(path)?,
        None => Rig::reference(),
    };
    let mut scenario = scenario(&a);
    let rig_hw = match a.rig_seed {
        Some(s) => base.perturbed(s),
        None => base,
    };
    if let Some(n) = a.pressure_noise {
        scenario.sensors.pressure_noise_bar = n;
    }
    if let Some(path) = &a.dump_rig {
        dump_rig(path, &rig_hw)?;
    }
    write(&a, scenario, rig_hw)?;
    Ok(ExitCode::SUCCESS)
}

/// The options' ranges.
fn check(a: &Args) -> Result<()> {
    anyhow::ensure!(
        a.duration > 0.0 && a.duration.is_finite(),
        "--duration must be > 0"
    );
    anyhow::ensure!(
        a.internal >= 0.0 && a.external >= 0.0,
        "leak flows must be ≥ 0"
    );
    anyhow::ensure!(
        (100.0..=20_000.0).contains(&a.rate),
        "--rate must be within 100..20000 Hz"
    );
    if let Some(n) = a.pressure_noise {
        anyhow::ensure!(n >= 0.0 && n.is_finite(), "--pressure-noise must be ≥ 0");
    }
    Ok(())
}

fn scenario(a: &Args) -> Scenario {
    Scenario {
        duration_s: a.duration,
        supply_bar: a.supply,
        temp_c: a.temp,
        write_temperature: a.with_temp,
        profile: a.profile,
        internal_lpm: a.internal,
        external_lpm: a.external,
        internal_law: a.law,
        external_law: a.law,
        leak_onset_s: a.onset,
        seed: a.seed,
        sample_rate_hz: a.rate,
        ..Scenario::default()
    }
}

/// A rig file (the simulator's own rig data, TOML), validated.
fn load_rig(path: &std::path::Path) -> Result<Rig> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let rig: Rig = toml::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{}: not a rig file of the simulator (--rig takes what --dump-rig writes, not monitor parameters): {e}",
            path.display()
        )
    })?;
    rig.validate()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(rig)
}

/// The simulated rig's data as TOML, in the format `--rig` reads.
fn dump_rig(path: &std::path::Path, rig_hw: &Rig) -> Result<()> {
    let text = format!(
        "# Rig data of the simulated rig (host-sim simulate --rig reads it)\n{}",
        toml::to_string(rig_hw)?
    );
    std::fs::write(path, text).with_context(|| format!("{}: cannot write", path.display()))
}

/// Run the simulation into the output recording.
fn write(a: &Args, scenario: Scenario, rig_hw: Rig) -> Result<()> {
    let meta = vec![
        ("sample_rate_hz", format!("{}", scenario.sample_rate_hz)),
        ("source", format!("host-sim {} simulate", env!("CARGO_PKG_VERSION"))),
        (
            "note",
            format!(
                "{} bar, {} C, {:?} profile, internal {} l/min, external {} l/min ({:?}), onset {} s, seed {}{}",
                a.supply,
                a.temp,
                a.profile,
                a.internal,
                a.external,
                a.law,
                a.onset,
                a.seed,
                a.rig_seed.map_or(String::new(), |s| format!(", rig seed {s}"))
            ),
        ),
    ];
    let extra: &[&str] = if a.no_truth {
        &[]
    } else {
        &["q_internal_lpm", "q_external_lpm"]
    };
    let mut w = RecordingWriter::create(&a.output, &meta, a.with_temp, extra)
        .with_context(|| format!("{}: cannot create", a.output.display()))?;
    for row in Simulation::new(scenario, rig_hw) {
        let truth = [row.q_internal_lpm, row.q_external_lpm];
        w.write(
            &monitor::Sample::from(&row),
            if a.no_truth { &[] } else { &truth },
        )?;
    }
    w.close()?;
    Ok(())
}
