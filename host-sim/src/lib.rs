//! Desktop companion of the leak monitor: recordings, replay, the rig
//! simulator, calibration, evaluation and plots. Everything that decides
//! anything lives in the `monitor` crate; this crate moves data in and out.
#![allow(clippy::needless_range_loop)]

pub mod eval;
pub mod golden;
pub mod recording;
pub mod replay;
pub mod sim;

use monitor::Params;
use std::path::Path;

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
