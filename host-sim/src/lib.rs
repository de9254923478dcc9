//! Desktop companion of the leak monitor: recordings, replay, the rig
//! simulator, calibration, evaluation and plots. Everything that decides
//! anything lives in the `monitor` crate; this crate moves data in and out.
#![allow(clippy::needless_range_loop)]
// `!(x > 0.0)` is deliberate: true for NaN, which must be rejected.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod ack;
pub mod calibrate;
pub mod decode;
pub mod eval;
pub mod golden;
pub mod plot;
pub mod port;
pub mod recording;
pub mod replay;
pub mod sim;
pub mod sim_sample;

use monitor::Params;
use std::path::Path;

/// Read a whole recording into memory (calibration needs random access),
/// with its sample period as `replay` derives it.
pub fn read_all(path: &Path) -> anyhow::Result<(Vec<monitor::Sample>, Option<f64>)> {
    let mut r = recording::RecordingReader::open(path)?;
    let rate = r.meta("sample_rate_hz").map(str::to_string);
    let samples = r.by_ref().collect::<Result<Vec<_>, _>>()?;
    let period = samples
        .first()
        .and_then(|first| replay::sample_period(rate.as_deref(), first, samples.get(1)));
    Ok((samples, period))
}

/// The parameters in `path` (see [`load_params`]), or the reference rig's.
pub fn load_params_or_nominal(path: Option<&Path>) -> anyhow::Result<Params> {
    path.map_or_else(|| Ok(Params::nominal()), load_params)
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
