//! The bank: one EKF per leak hypothesis, stepped on every sample.
//!
//! Every filter carries the six plant states and three nuisance states,
//! random walks: the flow-gain deviations of the two spool directions (the
//! valve's real coefficients are never known to better than a few percent,
//! and that alone would masquerade as a leak) and the healthy laminar
//! leakage's deviation (oil viscosity). Each leak hypothesis adds its leak
//! coefficient(s) as slowly varying (random-walk) states, so a filter does
//! not assume a leak size: it estimates it. The healthy filter has none.
//!
//! State layout: `[x_p, ẋ_p, x_v, ẋ_v, p3, p4, gain_ext, gain_ret, laminar, θ…]`.
//! Per filter and step the bank reports innovations, the normalised
//! innovation squared (NIS) and the Gaussian log-likelihood, from which
//! the decision layer builds its evidence.

use crate::estimation::model::{Inputs, Plant, Step, NX, P3, P4, XP};
use crate::hypothesis::Hypothesis;
use crate::leak::Leak;
use crate::physics::valve::SpoolStep;
use crate::real::Real;

mod filter;
#[cfg(test)]
mod tests;
mod transition;

pub use filter::HypothesisFilter;

/// Number of measurements per sample (x_p, p3, p4).
pub const NZ: usize = 3;
/// Index of the extend-direction flow-gain nuisance state.
pub const GAIN_EXT: usize = NX;
/// Index of the retract-direction flow-gain nuisance state.
pub const GAIN_RET: usize = NX + 1;
/// Index of the laminar-leakage (viscosity) nuisance state.
pub const LAMINAR: usize = NX + 2;
/// States before the leak coefficients (plant + nuisance).
pub const NB: usize = NX + 3;
/// States of the largest filter (both leaks).
pub const MAX_STATES: usize = NB + 2;

/// State index of a hypothesis' internal leak coefficient, if it has one.
pub const fn internal_index(h: Hypothesis) -> Option<usize> {
    if h.leaks().contains(Leak::Internal) {
        Some(NB)
    } else {
        None
    }
}

/// State index of a hypothesis' external leak coefficient, if it has one.
pub const fn external_index(h: Hypothesis) -> Option<usize> {
    match h {
        Hypothesis::External => Some(NB),
        Hypothesis::Both => Some(NB + 1),
        _ => None,
    }
}

/// Number of filter states of a hypothesis: plant, valve nuisance, leaks.
pub const fn state_count(h: Hypothesis) -> usize {
    NB + h.leaks().len() as usize
}

/// [`internal_index`] and [`external_index`] of hypothesis `h`, whose
/// filter has `N` states. The state count alone decides them for the
/// healthy (NB) and both (NB + 2) filters, so in those filters' code they
/// are constants; only the two NB + 1 filters test their hypothesis.
#[inline(always)]
pub(crate) fn leak_indices<const N: usize>(h: Hypothesis) -> (Option<usize>, Option<usize>) {
    debug_assert!(
        state_count(h) == N,
        "state size does not match the hypothesis"
    );
    match N {
        NB => (None, None),
        MAX_STATES => (Some(NB), Some(NB + 1)),
        _ => (internal_index(h), external_index(h)),
    }
}
const MEASURED: [usize; NZ] = [XP, P3, P4];

/// One sample's measurements in scaled filter units (see `model`), with
/// their noise variances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<T> {
    /// x_p / 0.1 m, p3 / 100 bar, p4 / 100 bar.
    pub z: [T; NZ],
    /// Noise variances, same units squared (before lag inflation).
    pub r: [T; NZ],
}

/// What one filter did on one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterOutput<T> {
    /// Normalised innovation squared Σν²/s (χ² with 3 dof if consistent).
    pub nis: T,
    /// Gaussian log-likelihood of this sample's measurements.
    pub log_likelihood: T,
    /// Internal leak flow at the current pressures, l/min. Each flow and
    /// its σ are reported by every filter with that leak (0 otherwise),
    /// `dp_10bar` by every filter with a leak: the decision alarms on the
    /// `both` filter's flows and asks a single-leak filter's whether its
    /// likelihood speaks for a leak at all. `valve_gain` is the `both`
    /// filter's only.
    pub flow_internal_lpm: T,
    /// External leak flow at the current pressures, l/min.
    pub flow_external_lpm: T,
    /// 1σ of the internal leak flow, l/min.
    pub flow_internal_sd_lpm: T,
    /// 1σ of the external leak flow, l/min.
    pub flow_external_sd_lpm: T,
    /// Pressure differences across the internal and external leak paths,
    /// in units of 10 bar (flow = coefficient × this).
    pub dp_10bar: [T; 2],
    /// Per reading (x_p, p3, p4): the squared innovation and its predicted
    /// variance's share from the state uncertainty (HPHᵀ), scaled units.
    pub innovation_sq: [T; 3],
    /// HPHᵀ per reading, scaled units.
    pub predicted_var: [T; 3],
    /// Valve flow-gain deviation estimates (extend, retract), relative
    /// (0.05 = 5 % more flow than parameterised).
    pub valve_gain: [T; 2],
    /// Metering flow through the valve (piston side) at the start of the
    /// step, l/min (magnitude).
    pub valve_flow_lpm: T,
}

/// Per-step settings shared by the filters.
#[derive(Clone, Debug)]
pub struct StepContext<T> {
    /// Inputs held over the step.
    pub inputs: Inputs<T>,
    /// The prediction step (length, substeps, spool map per substep).
    pub step: Step<T>,
    /// Spool map for the whole step (covariance).
    pub spool_dt: SpoolStep<T>,
    /// Pressure-transmitter lag, s (inflates pressure noise by (τ·ṗ)²).
    pub pressure_lag_s: T,
    /// Learning weight ∈ [0, 1] of the leak states this sample (0 during
    /// transients and fast moves).
    pub learning: T,
    /// Learning weight of the valve flow-gain states (0 at holds and during
    /// transients).
    pub gain_learning: T,
    /// Lowest value of each leak coefficient (internal, external), in the
    /// filter's unit (l/min at 10 bar): minus the installation's healthy
    /// leakage, so that the total leak never flows backwards.
    pub leak_floor: [T; 2],
    /// Lowest laminar-leakage deviation, in the filter's scaled unit.
    pub laminar_floor: T,
    /// Stroke, in the scaled position unit: the end stops.
    pub stroke: T,
}

/// Process-noise intensities per scaled state, per second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProcessNoise<T> {
    /// Position, velocity, spool, spool rate, p3, p4, gain_ext, gain_ret,
    /// laminar.
    pub base: [T; NB],
    /// Leak coefficient random walk.
    pub leak: T,
}

impl<T: Real> ProcessNoise<T> {
    /// Process noise variances over `dt` seconds (the diagonal of Q), in
    /// the state layout of the largest filter; every filter uses the
    /// leading entries of its own size.
    pub fn variances(&self, dt: T) -> [T; MAX_STATES] {
        core::array::from_fn(|i| {
            let intensity = if i < NB { self.base[i] } else { self.leak };
            intensity * dt
        })
    }
}

/// Step `filter`, its output into `slot` (`None` if it failed: a singular
/// or non-finite innovation covariance, or a non-finite state).
///
/// Never inlined: inlined into the monitor's step (as the compiler did
/// with the healthy and both filters, each stepped once), the filter's
/// covariance and the step's many temporaries lie beyond the 1 KiB reach
/// of a floating-point load's offset, and every access needed an extra
/// address instruction.
#[inline(never)]
fn step_into<T: Real, const N: usize>(
    filter: &mut HypothesisFilter<T, N>,
    plant: &Plant<T>,
    ctx: &StepContext<T>,
    q: &[T; MAX_STATES],
    m: &Measurement<T>,
    slot: &mut Option<FilterOutput<T>>,
) {
    *slot = filter.step(plant, ctx, q, m).ok();
}

/// The four filters.
#[derive(Clone, Debug)]
pub struct Bank<T: Real> {
    /// No leak.
    pub healthy: HypothesisFilter<T, { NB }>,
    /// Internal leak.
    pub internal: HypothesisFilter<T, { NB + 1 }>,
    /// External leak.
    pub external: HypothesisFilter<T, { NB + 1 }>,
    /// Both leaks.
    pub both: HypothesisFilter<T, { NB + 2 }>,
}

/// Outcome of one bank step: per hypothesis, in `Hypothesis::ALL` order,
/// what the filter did (`None` if it failed).
pub type BankOutput<T> = [Option<FilterOutput<T>>; 4];

impl<T: Real> Bank<T> {
    /// All four filters started at plant state `s0`.
    pub fn new(s0: &[T; NX], p0: &[T; NB], leak_prior_sd: T) -> Self {
        Self {
            healthy: HypothesisFilter::new(Hypothesis::Healthy, s0, p0, leak_prior_sd),
            internal: HypothesisFilter::new(Hypothesis::Internal, s0, p0, leak_prior_sd),
            external: HypothesisFilter::new(Hypothesis::External, s0, p0, leak_prior_sd),
            both: HypothesisFilter::new(Hypothesis::Both, s0, p0, leak_prior_sd),
        }
    }

    /// Step every filter, writing their outputs into `out` (in place: no
    /// copies of the outputs). A filter that fails is reported, not
    /// stopped: its output is `None`; the caller re-initialises it.
    pub fn step(
        &mut self,
        plant: &Plant<T>,
        ctx: &StepContext<T>,
        noise: &ProcessNoise<T>,
        m: &Measurement<T>,
        out: &mut BankOutput<T>,
    ) {
        let q = noise.variances(ctx.step.dt);
        let [o_healthy, o_internal, o_external, o_both] = out;
        step_into(&mut self.healthy, plant, ctx, &q, m, o_healthy);
        step_into(&mut self.internal, plant, ctx, &q, m, o_internal);
        step_into(&mut self.external, plant, ctx, &q, m, o_external);
        step_into(&mut self.both, plant, ctx, &q, m, o_both);
    }

    /// Restart hypothesis `h`'s filter at plant state `s0`.
    pub fn reset(&mut self, h: Hypothesis, s0: &[T; NX], p0: &[T; NB], leak_prior_sd: T) {
        match h {
            Hypothesis::Healthy => self.healthy = HypothesisFilter::new(h, s0, p0, leak_prior_sd),
            Hypothesis::Internal => self.internal = HypothesisFilter::new(h, s0, p0, leak_prior_sd),
            Hypothesis::External => self.external = HypothesisFilter::new(h, s0, p0, leak_prior_sd),
            Hypothesis::Both => self.both = HypothesisFilter::new(h, s0, p0, leak_prior_sd),
        }
    }

    /// Restart every filter's plant states at `s0`, keeping what each
    /// has learned of the valve and the leaks
    /// ([`HypothesisFilter::restart_plant`]).
    pub fn restart_plant(&mut self, s0: &[T; NX], p0: &[T; NB]) {
        self.healthy.restart_plant(s0, p0);
        self.internal.restart_plant(s0, p0);
        self.external.restart_plant(s0, p0);
        self.both.restart_plant(s0, p0);
    }

    /// Has the `both` filter learned its valve flow gains (extend,
    /// retract) to 1σ below `sd` (relative)?
    pub fn valve_gains_learned(&self, sd: f64) -> [bool; 2] {
        let sd_scaled = sd / crate::estimation::model::GAIN_REF;
        let var = T::c(sd_scaled * sd_scaled);
        let p = &self.both.ekf.p;
        [p[(GAIN_EXT, GAIN_EXT)] < var, p[(GAIN_RET, GAIN_RET)] < var]
    }

    /// Plant state estimate of hypothesis `h`, scaled units.
    pub fn plant_state(&self, h: Hypothesis) -> [T; NX] {
        let mut s = [T::ZERO; NX];
        for (i, v) in s.iter_mut().enumerate() {
            *v = match h {
                Hypothesis::Healthy => self.healthy.ekf.x[i],
                Hypothesis::Internal => self.internal.ekf.x[i],
                Hypothesis::External => self.external.ekf.x[i],
                Hypothesis::Both => self.both.ekf.x[i],
            };
        }
        s
    }
}
