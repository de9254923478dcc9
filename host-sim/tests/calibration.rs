//! `calibrate` recovers a simulated installation's parameters from a
//! healthy recording, and with them the monitor reads zero leak there and
//! still finds real leaks.

mod common;

use host_sim::calibrate::calibrate;
use host_sim::sim::{perturbed_rig, Rig, Scenario, Simulation};
use monitor::{Params, Sample, Verdict};

fn healthy_run(rig: &Rig, sensors: &host_sim::sim::SensorModel, seed: u64) -> Vec<Sample> {
    let sc = Scenario {
        duration_s: 120.0,
        seed,
        sensors: sensors.clone(),
        ..Scenario::default()
    };
    Simulation::new(sc, rig.clone()).map(|r| r.sample).collect()
}

#[test]
fn recovers_valve_and_load_of_a_different_rig() {
    let (rig, sensors) = perturbed_rig(&Params::nominal(), 7);
    let truth = &rig.plant;
    let cal = calibrate(&healthy_run(&rig, &sensors, 71), &Params::nominal()).unwrap();
    let p = &cal.params;
    // Flow gain per direction: the piston-side edge of each direction.
    let kv_ext = truth.valve.flow_gain_extend_lpm_sqrt_bar * rig.edge_gain[0];
    let kv_ret = truth.valve.flow_gain_retract_lpm_sqrt_bar * rig.edge_gain[3];
    assert!(
        (p.valve.flow_gain_extend_lpm_sqrt_bar / kv_ext - 1.0).abs() < 0.01,
        "{}",
        cal.report()
    );
    assert!(
        (p.valve.flow_gain_retract_lpm_sqrt_bar / kv_ret - 1.0).abs() < 0.01,
        "{}",
        cal.report()
    );
    let ratio_ext = rig.edge_gain[1] / rig.edge_gain[0];
    let ratio_ret = rig.edge_gain[2] / rig.edge_gain[3];
    assert!((p.valve.rod_edge_gain_extend - ratio_ext).abs() < 0.01);
    assert!((p.valve.rod_edge_gain_retract - ratio_ret).abs() < 0.01);
    assert!((p.valve.dead_zone - truth.valve.dead_zone).abs() < 5e-4);
    assert!((p.valve.null_offset - truth.valve.null_offset).abs() < 5e-4);
    // Friction within 10 %; gravity within 3 % (pressure-sensor offsets of
    // this rig add ≈ 2 % of apparent load, absorbed on purpose).
    assert!((p.friction.coulomb_n / truth.friction.coulomb_n - 1.0).abs() < 0.1);
    assert!((p.friction.viscous_ns_per_m / truth.friction.viscous_ns_per_m - 1.0).abs() < 0.1);
    assert!((p.load.gravity_scale / truth.load.gravity_scale - 1.0).abs() < 0.03);
    // The only acceptable warning: the air content is not always
    // determined by a recording (it shows in pressure transients only).
    assert!(
        cal.warnings.iter().all(|w| w.starts_with("entrained air")),
        "{:?}",
        cal.warnings
    );
    // On its own healthy recording the calibrated monitor's largest
    // detection reading stays below half the alarm level.
    let half = 0.5 * Params::nominal().alarm.alarm_lpm;
    assert!(
        cal.leak_after_lpm[0] < half && cal.leak_after_lpm[1] < half,
        "{}",
        cal.report()
    );
}

#[test]
fn a_dead_zone_and_null_shift_is_found() {
    let mut rig = Rig::nominal();
    rig.plant.valve.dead_zone = 0.019;
    rig.plant.valve.null_offset = 0.002;
    let sensors = host_sim::sim::SensorModel::default();
    let cal = calibrate(&healthy_run(&rig, &sensors, 72), &Params::nominal()).unwrap();
    assert!(
        (cal.params.valve.dead_zone - 0.019).abs() < 5e-4,
        "{}",
        cal.report()
    );
    assert!(
        (cal.params.valve.null_offset - 0.002).abs() < 5e-4,
        "{}",
        cal.report()
    );
}

#[test]
fn calibrated_monitor_detects_a_leak_on_the_other_rig() {
    let (rig, sensors) = perturbed_rig(&Params::nominal(), 9);
    let cal = calibrate(&healthy_run(&rig, &sensors, 91), &Params::nominal()).unwrap();
    let sc = Scenario {
        duration_s: 60.0,
        seed: 92,
        internal_lpm: 0.3,
        leak_onset_s: 25.0,
        sensors,
        ..Scenario::default()
    };
    let run = common::run_with(sc, rig, &cal.params);
    let t = run.first_alarm.expect("leak detected").0;
    assert!(t > 25.0 && t < 30.0, "alarm at {t}");
    assert_eq!(run.final_status.verdict, Verdict::Internal);
}

#[test]
fn too_short_a_recording_is_refused() {
    let (rig, sensors) = perturbed_rig(&Params::nominal(), 3);
    let sc = Scenario {
        duration_s: 5.0,
        sensors,
        ..Scenario::default()
    };
    let s: Vec<Sample> = Simulation::new(sc, rig).map(|r| r.sample).collect();
    let e = calibrate(&s, &Params::nominal()).unwrap_err().to_string();
    assert!(e.contains("too short"), "{e}");
}
