//! Desktop companion of the leak monitor: recordings, replay, the rig
//! simulator, calibration, evaluation and plots. Everything that decides
//! anything lives in the `monitor` crate; this crate moves data in and out.
#![allow(clippy::needless_range_loop)]
// `!(x > 0.0)` is deliberate: true for NaN, which must be rejected.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod calibrate;
pub mod decode;
pub mod eval;
pub mod golden;
pub mod plot;
pub mod recording;
pub mod replay;
pub mod sim;

use monitor::Params;
use std::path::Path;

/// Read a whole recording into memory (calibration needs random access).
pub fn read_all(path: &Path) -> anyhow::Result<Vec<monitor::Sample>> {
    let r = recording::RecordingReader::open(path)?;
    Ok(r.collect::<Result<Vec<_>, _>>()?)
}

/// Load installation parameters from a TOML file (only the fields it sets
/// change from nominal), validated.
pub fn load_params(path: &Path) -> anyhow::Result<Params> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let p: Params =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    p.validate()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(p)
}
