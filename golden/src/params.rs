//! The parameters of a golden run: the built-in nominal installation with
//! the two values a golden case records (the recording's sample period
//! and, to reach the decision layer's evidence phase within a few seconds
//! of recording, a shorter filter warm-up), and the holds' own land
//! leakage that calibration sets where no oil temperature is read (the
//! example recordings read none), so that the cases run that path too.

use monitor::physics::valve::HOLD_EDGE_LEAK_SCALE;
use monitor::Params;

/// `Params::nominal()` with the sample period (s) and filter warm-up (s)
/// of a golden case, the holds' land leakage held as calibration holds it
/// ([`HOLD_EDGE_LEAK_SCALE`]).
pub fn golden_params(sample_period_s: f64, warm_up_s: f64) -> Params {
    let mut p = Params::nominal();
    p.valve.hold_edge_leak_scale = HOLD_EDGE_LEAK_SCALE;
    p.filter.sample_period_s = sample_period_s;
    p.filter.warm_up_s = warm_up_s;
    p
}
