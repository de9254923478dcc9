//! How well does the monitor's 1 ms model predict the rig? Starting every
//! sample from the rig's true state, compare the monitor model's one-step
//! prediction of the chamber pressures with the truth, expressed as the
//! equivalent flow error per chamber in l/min (the unit of a leak).
//! `cargo run --release -p host-sim --example model_mismatch [supply]`
use host_sim::sim::{Rig, Scenario, SensorModel, Simulation};
use monitor::fluid::bulk_modulus_exact;
use monitor::model::{Inputs, Leaks, Nuisance, Plant, Step, BAR, NX, P_REF, V_REF, X_REF};
use monitor::Params;

fn main() {
    let supply: f64 = std::env::args().nth(1).map_or(50.0, |s| s.parse().unwrap());
    let quiet = SensorModel {
        pressure_lag_s: 0.0,
        pressure_noise_bar: 0.0,
        position_noise_m: 0.0,
        command_noise: 0.0,
        pressure_step_bar: 0.0,
        position_step_m: 0.0,
        command_step: 0.0,
        ..SensorModel::default()
    };
    let sc = Scenario {
        supply_bar: supply,
        sensors: quiet,
        duration_s: 60.0,
        ..Scenario::default()
    };
    let params = Params::nominal();
    let plant: Plant<f64> = Plant::new(&params);
    let step = Step {
        dt: 0.001,
        substeps: 2,
        spool: plant.spool_step(0.0005),
    };
    let mut sim = Simulation::new(sc, Rig::nominal());
    let mut prev: Option<([f64; NX], Inputs<f64>)> = None;
    let c = &params.cylinder;
    let mut acc: Vec<(f64, f64, f64, f64)> = Vec::new();
    while let Some(row) = sim.next() {
        let st = sim.state(); // state at t + 1 ms, after this row's command
        let s_true = [
            st.x / X_REF,
            st.v / V_REF,
            st.xv,
            st.vv / plant.omega,
            st.p3 / P_REF,
            st.p4 / P_REF,
        ];
        if let Some((s0, u)) = prev {
            let mut s = s0;
            plant.advance(&mut s, &u, Nuisance::default(), Leaks::default(), &step);
            let va = c.dead_volume_piston_m3 + c.piston_area_m2 * st.x;
            let vb = c.dead_volume_rod_m3 + c.rod_side_area_m2 * (c.stroke_m - st.x);
            let qa =
                (s_true[4] - s[4]) * P_REF * va / bulk_modulus_exact(&params.fluid, st.p3) / 0.001
                    * 60_000.0;
            let qb =
                (s_true[5] - s[5]) * P_REF * vb / bulk_modulus_exact(&params.fluid, st.p4) / 0.001
                    * 60_000.0;
            acc.push((row.sample.t_s, qa, qb, (s_true[2] - s[2]) * 100.0));
        }
        let u = Inputs {
            p_supply_pa: row.sample.p_supply_bar.unwrap() as f64 * BAR,
            p_tank_pa: row.sample.p_tank_bar.unwrap() as f64 * BAR,
            u_valve: row.sample.u_valve.unwrap() as f64,
            laminar_factor: 1.0,
        };
        prev = Some((s_true, u));
    }
    // Report the mean flow error per 1 s window.
    println!("  t0-t1    dQ_A l/min  dQ_B l/min  d spool %");
    for w in acc.chunks(1000) {
        let n = w.len() as f64;
        let (a, b, x) = w
            .iter()
            .fold((0.0, 0.0, 0.0), |s, v| (s.0 + v.1, s.1 + v.2, s.2 + v.3));
        println!(
            "{:5.1}-{:4.1}   {:+8.3}    {:+8.3}    {:+7.3}",
            w[0].0,
            w[w.len() - 1].0,
            a / n,
            b / n,
            x / n
        );
    }
}
