//! Simulate a scenario and write only the window [from, to] of the
//! recording (with truth), to study one episode of a long run.
//! `cargo run --release -p host-sim --example window -- OUT FROM TO DURATION PROFILE SEED`
use host_sim::recording::RecordingWriter;
use host_sim::sim::{Profile, Rig, Scenario, Simulation};
use monitor::Sample;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (out, from, to, dur) = (
        &a[1],
        a[2].parse::<f64>().unwrap(),
        a[3].parse::<f64>().unwrap(),
        a[4].parse::<f64>().unwrap(),
    );
    let profile = if a[5] == "random" {
        Profile::Random
    } else {
        Profile::Thesis
    };
    let sc = Scenario {
        duration_s: dur,
        profile,
        seed: a[6].parse().unwrap(),
        ..Scenario::default()
    };
    let mut w = RecordingWriter::create(
        std::path::Path::new(out),
        &[],
        false,
        &["q_internal_lpm", "q_external_lpm"],
    )
    .unwrap();
    for row in Simulation::new(sc, Rig::reference()) {
        if row.t_s >= from && row.t_s <= to {
            w.write(
                &Sample::from(&row),
                &[row.q_internal_lpm, row.q_external_lpm],
            )
            .unwrap();
        }
        if row.t_s > to {
            break;
        }
    }
    w.close().unwrap();
}
