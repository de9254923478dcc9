//! Controlled experiments on the independent plant: switch one effect at a
//! time to what the monitor assumes and see what the leak readings do.
//! `cargo run --release -p host-sim --example ablate -- RIG [SUPPLY] [TEMP]`
use host_sim::eval::exec::row_sample;
use monitor::{Monitor, Params};
use plant::{Leak, RigSpec, Run, Scenario};

fn run(rig: &RigSpec, leak: Leak, params: &Params) -> String {
    let r = Run {
        rig: rig.clone(),
        scenario: Scenario::ClosedLoop {
            duration_s: 60.0,
            seed: rig.seed,
        },
        leak,
        faults: vec![],
        temp_column: false,
        sample_rate_hz: 1000.0,
        noise_seed: 17,
    };
    let rows = plant::simulate(&r);
    let mut m = Monitor::<f32>::new(params).unwrap();
    let (mut peak, mut alarm, mut nis, mut n) = ([0f32; 2], None, 0.0, 0);
    let mut last = [0f32; 2];
    let mut verdict = "";
    let mut faults = String::new();
    for row in &rows {
        let s = m.step(&row_sample(row));
        verdict = s.verdict.name();
        for e in &s.events {
            if let monitor::Event::SensorFault(c) = e {
                faults.push_str(&format!("{:?}@{:.1} ", c, s.t_s));
            }
        }
        if let (Some(i), Some(e)) = (s.detect_internal_lpm, s.detect_external_lpm) {
            peak = [peak[0].max(i), peak[1].max(e)];
        }
        if let (Some(i), Some(e)) = (s.leak_internal_lpm, s.leak_external_lpm) {
            last = [i, e];
            nis += s.evidence[s.leading as usize].mean_nis;
            n += 1;
        }
        for e in &s.events {
            if let monitor::Event::AlarmRaised(v) = e {
                alarm.get_or_insert((s.t_s, v.name()));
            }
        }
    }
    format!(
        "peak {:.3} {:.3} end {:.3} {:.3} nis {:.1} alarm {:?} {verdict} {faults}",
        peak[0],
        peak[1],
        last[0],
        last[1],
        nis / n.max(1) as f32,
        alarm
    )
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let seed: u64 = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let supply: f64 = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(50.0);
    let temp: f64 = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(25.0);
    let base = RigSpec::random(seed, supply, temp);
    let p = Params::nominal();
    let none = Leak::default();
    type Edit = fn(&mut RigSpec);
    let variants: Vec<(&str, Edit)> = vec![
        ("as drawn", |_| {}),
        ("quiet sensors", quiet_sensors),
        ("no lags", |r| {
            for c in r.sensors.pressure.iter_mut() {
                c.lag_s = 0.0;
            }
            r.sensors.position.lag_s = 0.0;
        }),
        ("no coloured/ripple noise", |r| {
            for c in r.sensors.pressure.iter_mut() {
                c.coloured_sigma = 0.0;
                c.ripple_pickup = 0.0;
            }
            r.supply.ripple_bar = [0.0; 3];
        }),
        ("no offsets", |r| {
            for c in r.sensors.pressure.iter_mut() {
                c.offset = 0.0;
            }
            r.sensors.position.offset = 0.0;
            r.sensors.valve_command_offset = 0.0;
        }),
        ("symmetric land leak 3.3e-3", |r| {
            r.valve.land_leak_lpm_per_bar = [3.3e-3; 4];
        }),
        ("land leak 0", |r| {
            r.valve.land_leak_lpm_per_bar = [0.0; 4];
        }),
        ("nominal valve gains/overlap", nominal_valve),
        ("ideal supply/tank", |r| {
            ideal_supply(r);
            r.supply.tank_bar = 0.8;
        }),
        ("nominal air/bulk", nominal_fluid),
        ("nominal load", nominal_load),
        ("nominal friction", nominal_friction),
        ("nominal cylinder", nominal_cylinder),
        ("all of the above", everything_but_mechanics),
        ("all + load + friction + cyl", |r| {
            everything_but_mechanics(r);
            nominal_load(r);
            nominal_friction(r);
            nominal_cylinder(r);
        }),
    ];
    let only: Option<&str> = a.get(4).map(|s| s.as_str());
    for (name, edit) in variants {
        if only.is_some_and(|o| !name.contains(o)) {
            continue;
        }
        let mut rig = base.clone();
        edit(&mut rig);
        println!("{name:32} healthy  {}", run(&rig, none, &p));
    }
}

fn quiet_sensors(r: &mut RigSpec) {
    for c in r.sensors.pressure.iter_mut() {
        c.white_sigma = 0.02;
        c.coloured_sigma = 0.0;
        c.lag_s = 0.0;
        c.ripple_pickup = 0.0;
        c.offset = 0.0;
    }
    r.sensors.position.white_sigma = 1e-5;
    r.sensors.position.coloured_sigma = 0.0;
    r.sensors.position.lag_s = 0.0;
    r.sensors.position.offset = 0.0;
    r.sensors.valve_command_offset = 0.0;
}

fn nominal_valve(r: &mut RigSpec) {
    r.valve.flow_gain_lpm_sqrt_bar = [7.9025, 7.9025, 7.4187, 7.4187];
    r.valve.overlap = [0.015; 4];
    r.valve.null_bias = 0.0;
}

fn ideal_supply(r: &mut RigSpec) {
    r.supply.ripple_bar = [0.0; 3];
    r.supply.droop_bar = 0.2;
    r.supply.pump_max_lpm = 60.0;
}

fn nominal_fluid(r: &mut RigSpec) {
    r.fluid.air_fraction = 0.01;
    r.fluid.bulk_modulus_bar = 16000.0;
    r.cylinder.hose_fraction = 0.0;
}

fn nominal_load(r: &mut RigSpec) {
    r.load.masses_kg = [6.12844, 15.36792, 13.62235, 87.92456];
    r.load.inertias_kg_m2 = [0.070_673, 1.321_969, 0.879_096, 53.414_170];
    r.load.payload_kg = 0.0;
    r.load.force_offset_n = 0.0;
}

fn nominal_friction(r: &mut RigSpec) {
    r.friction.coulomb_n = 480.0;
    r.friction.breakaway_n = 990.0;
    r.friction.viscous_ns_per_m = 5000.0;
    r.friction.viscous_viscosity_exponent = 0.0;
}

fn nominal_cylinder(r: &mut RigSpec) {
    r.cylinder.piston_area_m2 = 3.117e-3;
    r.cylinder.rod_area_m2 = 2.41e-3;
    r.cylinder.dead_volume_piston_m3 = 2e-4;
    r.cylinder.dead_volume_rod_m3 = 2e-4;
}

/// Sensors, land leakage, valve, supply and fluid as the monitor assumes.
fn everything_but_mechanics(r: &mut RigSpec) {
    quiet_sensors(r);
    r.valve.land_leak_lpm_per_bar = [3.3e-3; 4];
    nominal_valve(r);
    ideal_supply(r);
    nominal_fluid(r);
}
