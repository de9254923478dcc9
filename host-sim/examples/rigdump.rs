//! Prints a plant rig's drawn specification (valve edges, land leakage,
//! load, sensors, …) as JSON, to compare what calibration fitted with what
//! the plant has: a development tool, never an input to the monitor.
//!
//! `cargo run --release -p host-sim --example rigdump -- RIG SUPPLY_BAR TEMP_C`
use anyhow::Context;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    anyhow::ensure!(a.len() == 4, "usage: RIG SUPPLY_BAR TEMP_C");
    let rig: u64 = a[1].parse().context("RIG")?;
    let supply: f64 = a[2].parse().context("SUPPLY_BAR")?;
    let temp: f64 = a[3].parse().context("TEMP_C")?;
    let spec = plant::RigSpec::random(rig, supply, temp);
    println!("{}", serde_json::to_string_pretty(&spec)?);
    Ok(())
}
