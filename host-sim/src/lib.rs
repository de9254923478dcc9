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

/// The parameters in `path` (see [`load_params`]), or the reference rig's
/// as a provisional set ([`Params::PROVISIONAL`]): a recording of an
/// installation nobody calibrated is monitored for gross leaks only and
/// never called `healthy`.
pub fn load_params_or_provisional(path: Option<&Path>) -> anyhow::Result<Params> {
    path.map_or_else(|| Ok(Params::provisional()), load_params)
}

/// Largest parameter file read, bytes (a real one is a few KB).
pub const MAX_PARAMS_BYTES: u64 = 1 << 20;

/// Load installation parameters from a TOML file (only the fields it sets
/// change from nominal), validated; `-` reads them from standard input.
/// At most [`MAX_PARAMS_BYTES`] are read.
pub fn load_params(path: &Path) -> anyhow::Result<Params> {
    use std::io::Read;
    let stdin = path.as_os_str() == "-";
    let name = if stdin {
        "standard input".to_string()
    } else {
        path.display().to_string()
    };
    let source: Box<dyn Read> = if stdin {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(
            std::fs::File::open(path).map_err(|e| anyhow::anyhow!("{name}: cannot read: {e}"))?,
        )
    };
    let mut text = String::new();
    source
        .take(MAX_PARAMS_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| anyhow::anyhow!("{name}: cannot read: {e}"))?;
    anyhow::ensure!(
        text.len() as u64 <= MAX_PARAMS_BYTES,
        "{name}: more than {MAX_PARAMS_BYTES} bytes: not a parameter file"
    );
    let p: Params = toml::from_str(&text).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    p.validate().map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    Ok(p)
}

/// Standard input can feed one thing: refuse `--params -` together with a
/// recording read from `-`.
pub fn stdin_used_once<'a>(
    params: Option<&Path>,
    inputs: impl IntoIterator<Item = &'a Path>,
) -> anyhow::Result<()> {
    let dash = |p: &Path| p.as_os_str() == "-";
    anyhow::ensure!(
        !(params.is_some_and(dash) && inputs.into_iter().any(dash)),
        "standard input cannot hold both the parameters (--params -) and a recording (-)"
    );
    Ok(())
}
