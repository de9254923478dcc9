//! Shared by the diagnostic examples (`detdiag`, `uvdiag`): the runs of an
//! `eval --json` file, each with its cell's calibrated parameters and its
//! recording from the eval's `--cache`, replayed as `eval` did.
//!
//! Arguments: `RUNS.json CACHE [ID-SUBSTRING...]` (no substring: every run).

use host_sim::eval::exec::{recording_for, TextReader};
use host_sim::eval::RunSpec;
use std::path::PathBuf;

/// An `eval --json` file, its cache, and the run ids asked for.
pub struct EvalRuns {
    json: serde_json::Value,
    cache: PathBuf,
    filters: Vec<String>,
}

/// One run to replay.
pub struct EvalRun {
    pub spec: RunSpec,
    /// The cell's calibrated parameters, as JSON (for overrides).
    pub params: serde_json::Value,
}

impl EvalRuns {
    /// From the command line.
    pub fn from_args() -> anyhow::Result<Self> {
        let a: Vec<String> = std::env::args().collect();
        anyhow::ensure!(a.len() >= 3, "usage: RUNS.json CACHE [ID-SUBSTRING...]");
        Ok(Self {
            json: serde_json::from_slice(&std::fs::read(&a[1])?)?,
            cache: PathBuf::from(&a[2]),
            filters: a[3..].to_vec(),
        })
    }

    /// Were run ids asked for?
    pub fn filtered(&self) -> bool {
        !self.filters.is_empty()
    }

    /// The runs asked for, in the file's order.
    pub fn runs(&self) -> anyhow::Result<Vec<EvalRun>> {
        let cells = self.json["cells"]
            .as_array()
            .ok_or_else(|| anyhow::anyhow!("no cells"))?;
        let mut out = Vec::new();
        for r in self.json["runs"]
            .as_array()
            .ok_or_else(|| anyhow::anyhow!("no runs"))?
        {
            let spec: RunSpec = serde_json::from_value(r["spec"].clone())?;
            if self.filtered() && !self.filters.iter().any(|f| spec.id.contains(f.as_str())) {
                continue;
            }
            let cell = cells
                .iter()
                .find(|c| c["cell"] == r["spec"]["cell"])
                .ok_or_else(|| anyhow::anyhow!("{}: no cell", spec.id))?;
            out.push(EvalRun {
                spec,
                params: cell["calibration"]["params"].clone(),
            });
        }
        Ok(out)
    }

    /// The run's recording, from the cache (simulated if missing).
    pub fn recording(
        &self,
        spec: &RunSpec,
    ) -> anyhow::Result<TextReader<std::io::Cursor<Vec<u8>>>> {
        let (text, _) = recording_for(spec, Some(&self.cache))?;
        TextReader::new(std::io::Cursor::new(text))
    }
}

/// `params` as `eval` replayed the run: at its sample rate.
pub fn replay_params(params: serde_json::Value, spec: &RunSpec) -> anyhow::Result<monitor::Params> {
    let mut p: monitor::Params = serde_json::from_value(params)?;
    p.filter.sample_period_s = 1.0 / spec.sample_rate_hz;
    Ok(p)
}
