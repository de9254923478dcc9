//! One-at-a-time sensitivity of the monitor's healthy-run leak estimates to
//! rig deviations from nominal: which unmodelled differences bias it most.
//! `cargo run --release -p host-sim --example sensitivity`
use host_sim::sim::{Rig, Scenario, SensorModel, Simulation};
use monitor::{Monitor, Params, Sample};

fn run(
    rig: Rig,
    sensors: SensorModel,
    supply: f64,
    temp: f64,
    params: &Params,
) -> (f64, f64, f64, f64) {
    let sc = Scenario {
        supply_bar: supply,
        temp_c: temp,
        duration_s: 60.0,
        sensors,
        seed: 5,
        ..Scenario::default()
    };
    let mut m: Monitor<f32> = Monitor::new(params).unwrap();
    let (mut lo_i, mut hi_i, mut lo_e, mut hi_e) = (0f64, 0f64, 0f64, 0f64);
    for row in Simulation::new(sc, rig) {
        let s = m.step(&Sample::from(&row));
        if row.t_s > params.filter.warm_up_s {
            if let (Some(i), Some(e)) = (s.detect_internal_lpm, s.detect_external_lpm) {
                lo_i = lo_i.min(i as f64);
                hi_i = hi_i.max(i as f64);
                lo_e = lo_e.min(e as f64);
                hi_e = hi_e.max(e as f64);
            }
        }
    }
    (lo_i, hi_i, lo_e, hi_e)
}

fn main() {
    type Mod = Box<dyn Fn(&mut Rig, &mut SensorModel)>;
    let cases: Vec<(&str, Mod)> = vec![
        ("nominal", Box::new(|_, _| {})),
        (
            "Kv ext +5%",
            Box::new(|r, _| r.valve.flow_gain_extend_lpm_sqrt_bar *= 1.05),
        ),
        (
            "Kv ret +5%",
            Box::new(|r, _| r.valve.flow_gain_retract_lpm_sqrt_bar *= 1.05),
        ),
        (
            "Kv both -5%",
            Box::new(|r, _| {
                r.valve.flow_gain_extend_lpm_sqrt_bar *= 0.95;
                r.valve.flow_gain_retract_lpm_sqrt_bar *= 0.95;
            }),
        ),
        (
            "edge P->A +2%",
            Box::new(|r, _| r.valve.edge_gain[0] = 1.02),
        ),
        (
            "edge B->T +2%",
            Box::new(|r, _| r.valve.edge_gain[1] = 1.02),
        ),
        (
            "edge leak +30%",
            Box::new(|r, _| r.valve.edge_leak_lpm_per_bar *= 1.3),
        ),
        (
            "friction +15%",
            Box::new(|r, _| {
                r.friction.coulomb_n *= 1.15;
                r.friction.breakaway_n *= 1.15;
            }),
        ),
        (
            "viscous +15%",
            Box::new(|r, _| r.friction.viscous_ns_per_m *= 1.15),
        ),
        (
            "mass +3%",
            Box::new(|r, _| {
                r.load.inertia_scale *= 1.03;
                r.load.gravity_scale *= 1.03;
            }),
        ),
        ("air 3%", Box::new(|r, _| r.fluid.oil.air_fraction = 0.03)),
        (
            "air 0.5%",
            Box::new(|r, _| r.fluid.oil.air_fraction = 0.005),
        ),
        (
            "dead vol +10%",
            Box::new(|r, _| {
                r.cylinder.dead_volume_piston_m3 *= 1.1;
                r.cylinder.dead_volume_rod_m3 *= 1.1;
            }),
        ),
        (
            "p_piston +0.3 bar",
            Box::new(|r, _| r.sensors.pressure_offsets_bar[1] = 0.3),
        ),
        (
            "p_rod +0.3 bar",
            Box::new(|r, _| r.sensors.pressure_offsets_bar[2] = 0.3),
        ),
        (
            "p_supply +0.3 bar",
            Box::new(|r, _| r.sensors.pressure_offsets_bar[0] = 0.3),
        ),
        (
            "p_tank +0.3 bar",
            Box::new(|r, _| r.sensors.pressure_offsets_bar[3] = 0.3),
        ),
        (
            "x +1 mm",
            Box::new(|r, _| r.sensors.position_offset_m = 0.001),
        ),
        ("null +0.3%", Box::new(|r, _| r.valve.null_offset = 0.003)),
        ("dead zone 1.8%", Box::new(|r, _| r.valve.dead_zone = 0.018)),
        (
            "seal leak x2",
            Box::new(|r, _| r.leakage.seal_lpm_per_bar *= 2.0),
        ),
    ];
    let filter: Option<String> = std::env::args().nth(1).filter(|s| !s.is_empty());
    let params = host_sim::load_params_or_nominal(
        std::env::args().nth(2).as_deref().map(std::path::Path::new),
    )
    .unwrap();
    for supply in [50.0, 100.0] {
        for (name, f) in &cases {
            if filter.as_ref().is_some_and(|s| !name.contains(s.as_str())) {
                continue;
            }
            let mut rig = Rig::reference();
            let mut sensors = SensorModel::default();
            f(&mut rig, &mut sensors);
            let (a, b, c, d) = run(rig, sensors, supply, 25.0, &params);
            println!("{supply:>5} bar  {name:<20} internal [{a:+.3}, {b:+.3}]  external [{c:+.3}, {d:+.3}]");
        }
    }
}
