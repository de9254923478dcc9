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
    /// Also write the simulated rig's hardware (the simulator's rig data,
    /// TOML) here.
    #[arg(long)]
    dump_rig: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<ExitCode> {
    check(&a)?;
    let base = match a.rig.as_deref() {
        Some(path) => rig_of(&host_sim::load_params(path)?),
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

/// A rig with the plant of monitor parameters `p` (interim, until `--rig`
/// reads the simulator's own format): sensor offsets and supply lines are
/// the reference rig's.
fn rig_of(p: &monitor::Params) -> Rig {
    let mut r = Rig::reference();
    let c = &p.cylinder;
    r.cylinder.piston_area_m2 = c.piston_area_m2;
    r.cylinder.rod_side_area_m2 = c.rod_side_area_m2;
    r.cylinder.stroke_m = c.stroke_m;
    r.cylinder.dead_volume_piston_m3 = c.dead_volume_piston_m3;
    r.cylinder.dead_volume_rod_m3 = c.dead_volume_rod_m3;
    let l = &p.load;
    r.load.gravity_scale = l.gravity_scale;
    r.load.inertia_scale = l.inertia_scale;
    let g = &mut r.load.pantograph;
    g.theta1_fit_deg = l.theta1_fit_deg;
    g.theta2_fit_deg = l.theta2_fit_deg;
    g.base_to_r21_y_m = l.base_to_r21_y_m;
    g.r21_to_r1_m = l.r21_to_r1_m;
    g.r21_to_r3_m = l.r21_to_r3_m;
    g.r21_to_cg21_m = l.r21_to_cg21_m;
    g.r1_to_cg1_m = l.r1_to_cg1_m;
    g.r1_to_r22_m = l.r1_to_r22_m;
    g.r22_to_cg22_m = l.r22_to_cg22_m;
    g.r3_to_cg3_m = l.r3_to_cg3_m;
    g.masses_kg = l.masses_kg;
    g.inertias_kg_m2 = l.inertias_kg_m2;
    g.force_offset_n = l.force_offset_n;
    g.gravity_m_s2 = l.gravity_m_s2;
    let v = &p.valve;
    r.valve.natural_frequency_rad_s = v.natural_frequency_rad_s;
    r.valve.damping_ratio = v.damping_ratio;
    r.valve.flow_gain_extend_lpm_sqrt_bar = v.flow_gain_extend_lpm_sqrt_bar;
    r.valve.flow_gain_retract_lpm_sqrt_bar = v.flow_gain_retract_lpm_sqrt_bar;
    r.valve.edge_gain = [1.0, v.rod_edge_gain_extend, v.rod_edge_gain_retract, 1.0];
    r.valve.dead_zone = v.dead_zone;
    r.valve.null_offset = v.null_offset;
    r.valve.edge_leak_lpm_per_bar = v.edge_leak_lpm_per_bar;
    r.valve.laminar_dp_bar = v.laminar_dp_bar;
    let f = &p.fluid;
    r.fluid.reference_temperature_c = f.reference_temperature_c;
    r.fluid.oil.viscosity_ratio_25_40 = (f.viscosity_temperature_coeff_per_c * 15.0).exp();
    r.fluid.oil.bulk_modulus_bar = f.bulk_modulus_bar;
    r.fluid.oil.air_fraction = f.air_fraction;
    r.fluid.oil.polytropic_exponent = f.adiabatic_index;
    let fr = &p.friction;
    r.friction.coulomb_n = fr.coulomb_n;
    r.friction.breakaway_n = fr.breakaway_n;
    r.friction.stribeck_s_per_m = fr.stribeck_s_per_m;
    r.friction.viscous_ns_per_m = fr.viscous_ns_per_m;
    r.leakage.seal_lpm_per_bar = p.leakage.seal_lpm_per_bar;
    r.leakage.external_lpm_per_bar = p.leakage.external_lpm_per_bar;
    r
}

/// The simulated rig's hardware as TOML.
fn dump_rig(path: &std::path::Path, rig_hw: &Rig) -> Result<()> {
    let text = format!(
        "# The simulated rig (host-sim simulate)\n{}",
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
