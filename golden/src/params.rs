//! The parameters of a golden run: the built-in nominal installation with
//! the two values a golden case records (the recording's sample period
//! and, to reach the decision layer's evidence phase within a few seconds
//! of recording, a shorter filter warm-up).

use monitor::Params;

/// `Params::nominal()` with the sample period (s) and filter warm-up (s)
/// of a golden case.
pub fn golden_params(sample_period_s: f64, warm_up_s: f64) -> Params {
    let mut p = Params::nominal();
    p.filter.sample_period_s = sample_period_s;
    p.filter.warm_up_s = warm_up_s;
    p
}
