//! Writes the healthy calibration recording of each cell of an
//! `eval --json` file (from its `--cache`, simulated if missing) as a CSV,
//! so `host-sim calibrate` can be run on it by hand.
//!
//! `cargo run --release -p host-sim --example calrec -- RUNS.json CACHE OUTDIR [CELL-SUBSTRING...]`
use host_sim::eval::exec::recording_for;
use host_sim::eval::RunSpec;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    anyhow::ensure!(
        a.len() >= 4,
        "usage: RUNS.json CACHE OUTDIR [CELL-SUBSTRING...]"
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&a[1])?)?;
    let cache = std::path::PathBuf::from(&a[2]);
    let out = std::path::PathBuf::from(&a[3]);
    std::fs::create_dir_all(&out)?;
    for cell in json["cells"].as_array().into_iter().flatten() {
        let spec: RunSpec = serde_json::from_value(cell["calibration_run"].clone())?;
        if a.len() > 4 && !a[4..].iter().any(|f| spec.id.contains(f.as_str())) {
            continue;
        }
        let (text, _) = recording_for(&spec, Some(&cache))?;
        let path = out.join(format!("{}.csv", spec.id.replace('/', "_")));
        std::fs::write(&path, text)?;
        println!("{}", path.display());
    }
    Ok(())
}
