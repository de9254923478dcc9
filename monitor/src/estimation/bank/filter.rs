//! One hypothesis' filter: its EKF over plant, nuisance and leak states; predict, update, output.

use super::transition::Transition;
use super::{
    leak_indices, state_count, FilterOutput, Measurement, StepContext, GAIN_EXT, GAIN_RET, LAMINAR,
    MAX_STATES, MEASURED, NB,
};
use crate::estimation::ekf::{Ekf, EkfError};
use crate::estimation::model::{Eval, Leaks, Nuisance, Plant, NX, P3, P4, P_REF, VP, XP};
use crate::hypothesis::Hypothesis;
use crate::real::Real;
use nalgebra::SVector;

/// What the three scalar updates of one step saw.
#[derive(Clone, Copy, Debug)]
struct Innovations<T> {
    /// Σν²/s.
    nis: T,
    /// Product of the innovation variances (det S).
    det: T,
    /// Per reading: ν².
    innovation_sq: [T; 3],
    /// Per reading: the innovation variance less the reading's noise.
    predicted_var: [T; 3],
}

/// One hypothesis' filter: plant states plus `N − 6` leak coefficients.
#[derive(Clone, Debug)]
pub struct HypothesisFilter<T: Real, const N: usize> {
    /// Which hypothesis.
    pub hypothesis: Hypothesis,
    /// Its estimate.
    pub ekf: Ekf<T, N>,
}

/// Chamber pressure difference (scaled: 1 = 100 bar) at which the
/// internal leak coefficient learns at half weight: 1 bar. (At 2 and
/// 4 bar the development and further rigs isolated 5 and 16 leaks fewer
/// than without the weight, at 1 bar 2.)
const INTERNAL_DP_SEEN: f64 = 0.01;

impl<T: Real, const N: usize> HypothesisFilter<T, N> {
    /// A filter for `hypothesis` started at plant state `s0`, nuisance and
    /// leaks at zero.
    pub fn new(hypothesis: Hypothesis, s0: &[T; NX], p0_base: &[T; NB], leak_prior_sd: T) -> Self {
        debug_assert!(
            state_count(hypothesis) == N,
            "state size does not match the hypothesis"
        );
        let mut x = SVector::<T, N>::zeros();
        let mut p0 = SVector::<T, N>::zeros();
        for i in 0..NX {
            x[i] = s0[i];
        }
        for i in 0..NB {
            p0[i] = p0_base[i];
        }
        for i in NB..N {
            p0[i] = leak_prior_sd * leak_prior_sd;
        }
        Self {
            hypothesis,
            ekf: Ekf::new(x, &p0),
        }
    }

    /// Restart the plant states at `s0` with their prior variances from
    /// `p0_base`, keeping the nuisance and leak estimates and their
    /// covariance: after a gap in the samples the plant moved on, its
    /// valve and leaks did not. (The cross-covariances with the plant
    /// states go: the restarted ones are independent readings.)
    pub fn restart_plant(&mut self, s0: &[T; NX], p0_base: &[T; NB]) {
        for i in 0..NX {
            self.ekf.x[i] = s0[i];
            for j in 0..N {
                self.ekf.p[(i, j)] = T::ZERO;
                self.ekf.p[(j, i)] = T::ZERO;
            }
            self.ekf.p[(i, i)] = p0_base[i];
        }
    }

    /// The valve nuisance estimates in the current state.
    pub fn nuisance(&self) -> Nuisance<T> {
        Nuisance {
            gain_extend: self.ekf.x[GAIN_EXT],
            gain_retract: self.ekf.x[GAIN_RET],
            laminar: self.ekf.x[LAMINAR],
        }
    }

    /// State indices of the internal and external leak coefficients, if
    /// the hypothesis has them ([`leak_indices`]).
    #[inline(always)]
    fn leak_indices(&self) -> (Option<usize>, Option<usize>) {
        leak_indices::<N>(self.hypothesis)
    }

    /// The leak coefficients in the current state.
    pub fn leaks(&self) -> Leaks<T> {
        let (internal, external) = self.leak_indices();
        Leaks {
            internal: internal.map_or(T::ZERO, |i| self.ekf.x[i]),
            external: external.map_or(T::ZERO, |i| self.ekf.x[i]),
        }
    }

    /// Predict over one step with process noise variances `q`
    /// ([`ProcessNoise::variances`]) and update with `m`: what the filter
    /// did.
    pub fn step(
        &mut self,
        plant: &Plant<T>,
        ctx: &StepContext<T>,
        q: &[T; MAX_STATES],
        m: &Measurement<T>,
    ) -> Result<FilterOutput<T>, EkfError> {
        let e = self.predict_mean(plant, ctx);
        let phi = Transition::new(&e, ctx.step.dt, &ctx.spool_dt, self.leak_indices());
        phi.predict_covariance(&mut self.ekf.p, q);
        let inn = self.update(ctx, m, &e)?;
        self.project(ctx);
        // Once per step, after everything that could go wrong.
        self.ekf.check_finite()?;
        Ok(self.output(ctx, &e, &inn))
    }

    /// Project the estimate onto what is physically possible: a leak
    /// coefficient not below its floor (a leak does not run backwards),
    /// the healthy laminar leakage not below its floor,
    /// the piston within its end stops and not moving into them. The
    /// model has no end-stop force; this is it, as a constraint.
    #[inline(always)]
    fn project(&mut self, ctx: &StepContext<T>) {
        let (internal, external) = self.leak_indices();
        let x = &mut self.ekf.x;
        if let Some(i) = internal {
            x[i] = x[i].max(ctx.leak_floor[0]);
        }
        if let Some(i) = external {
            x[i] = x[i].max(ctx.leak_floor[1]);
        }
        x[LAMINAR] = x[LAMINAR].max(ctx.laminar_floor);
        if x[XP] < T::ZERO {
            x[XP] = T::ZERO;
            x[VP] = x[VP].max(T::ZERO);
        } else if x[XP] > ctx.stroke {
            x[XP] = ctx.stroke;
            x[VP] = x[VP].min(T::ZERO);
        }
    }

    /// Advance the plant states through the nonlinear model; returns the
    /// model at the start of the step (its Jacobian linearises Φ).
    pub(super) fn predict_mean(&mut self, plant: &Plant<T>, ctx: &StepContext<T>) -> Eval<T> {
        let leaks = self.leaks();
        let nuis = self.nuisance();
        // The plant states are the first NX of x: advanced in place.
        let (s, _) = self
            .ekf
            .x
            .as_mut_slice()
            .split_first_chunk_mut::<NX>()
            .expect("every filter has the plant states");
        plant.advance(s, &ctx.inputs, nuis, leaks, &ctx.step)
    }

    /// How much each state learns from this sample (its Kalman gain is
    /// scaled by it). Plant states always learn; valve gains and the
    /// laminar and leak coefficients only as much as the sample is worth
    /// as evidence. The internal leak's flow is θ·Δp: with the chamber
    /// pressures nearly equal it is not observable, and what its
    /// coefficient learned there was the model's error, carried into the
    /// next move.
    pub(super) fn learning_weights(&self, ctx: &StepContext<T>) -> [T; N] {
        let mut weights: [T; N] = core::array::from_fn(|i| match i {
            GAIN_EXT | GAIN_RET => ctx.gain_learning,
            i if i >= LAMINAR => ctx.learning,
            _ => T::ONE,
        });
        // Only filters with the state pay for the division.
        if let (Some(internal), _) = self.leak_indices() {
            let dp = self.ekf.x[P3] - self.ekf.x[P4];
            let seen = dp * dp / (dp * dp + T::c(INTERNAL_DP_SEEN * INTERNAL_DP_SEEN));
            weights[internal] = ctx.learning * seen;
        }
        weights
    }

    /// The three scalar updates (x_p, p3, p4): innovations, NIS and the
    /// product of the innovation variances.
    fn update(
        &mut self,
        ctx: &StepContext<T>,
        m: &Measurement<T>,
        e: &Eval<T>,
    ) -> Result<Innovations<T>, EkfError> {
        let weights = self.learning_weights(ctx);
        let mut inn = Innovations {
            nis: T::ZERO,
            det: T::ONE,
            innovation_sq: [T::ZERO; 3],
            predicted_var: [T::ZERO; 3],
        };
        // Three calls, not a loop over MEASURED: in a loop the compiler
        // inlined the update and carried P through it on the stack; as
        // calls, one out-of-line update per filter size and reading loads
        // and stores each entry once with the column and gain in registers
        // (measured: a third fewer instructions for the updates). The
        // first two write P's upper triangle only, the last one mirrors it
        // (`Ekf::update_state_weighted`).
        self.update_one::<XP, false>(0, ctx, m, e, &weights, &mut inn)?;
        self.update_one::<P3, false>(1, ctx, m, e, &weights, &mut inn)?;
        self.update_one::<P4, true>(2, ctx, m, e, &weights, &mut inn)?;
        Ok(inn)
    }

    /// Scalar update with reading `k` of `m`, of state `J` = `MEASURED[k]`;
    /// `MIRROR` as in [`Ekf::update_state_weighted`].
    #[inline(always)]
    fn update_one<const J: usize, const MIRROR: bool>(
        &mut self,
        k: usize,
        ctx: &StepContext<T>,
        m: &Measurement<T>,
        e: &Eval<T>,
        weights: &[T; N],
        inn: &mut Innovations<T>,
    ) -> Result<(), EkfError> {
        debug_assert_eq!(MEASURED[k], J, "reading k measures state J");
        let lag = if J == XP {
            T::ZERO
        } else {
            ctx.pressure_lag_s * e.f[J]
        };
        let r = m.r[k] + lag * lag;
        let u = self
            .ekf
            .update_state_weighted::<J, MIRROR>(m.z[k], r, k as u8, weights)?;
        let nu2 = u.innovation * u.innovation;
        inn.nis += nu2 / u.variance;
        inn.det *= u.variance;
        inn.innovation_sq[k] = nu2;
        inn.predicted_var[k] = u.variance - r;
        Ok(())
    }

    /// Estimate `x_i` of an optional leak state and its standard deviation
    /// (zeros if the hypothesis has no such leak).
    fn leak(&self, index: Option<usize>) -> (T, T) {
        index.map_or((T::ZERO, T::ZERO), |i| {
            (self.ekf.x[i], self.ekf.p[(i, i)].max(T::ZERO).sqrt())
        })
    }

    /// The step's output: likelihood and innovations; each leak filter's
    /// own leak flows (zero for a leak it lacks); the valve gains of the
    /// `both` filter only (the decision reads no other's).
    fn output(&self, ctx: &StepContext<T>, e: &Eval<T>, inn: &Innovations<T>) -> FilterOutput<T> {
        let mut out = FilterOutput {
            nis: inn.nis,
            // ln N(ν; 0, S) = −½·(νᵀS⁻¹ν + ln det S + 3·ln 2π).
            log_likelihood: T::c(-0.5)
                * (inn.nis + inn.det.ln() + T::c(3.0 * 1.837_877_066_409_345_5)),
            innovation_sq: inn.innovation_sq,
            predicted_var: inn.predicted_var,
            valve_flow_lpm: e.q_valve_a.abs() * T::c(crate::estimation::model::LPM_PER_M3S),
            ..FilterOutput::default()
        };
        // The healthy filter has NB states, `both` MAX_STATES: constants
        // per filter, as in `leak_indices`.
        if N > NB {
            let (internal, external) = self.leak_indices();
            let (leak_internal, leak_internal_sd) = self.leak(internal);
            let (leak_external, leak_external_sd) = self.leak(external);
            // Leak flow magnitude at the updated pressures: θ·|Δp| / 10 bar
            // (a seal leaks whichever way the pressure difference pushes; a
            // negative θ is an estimate below the healthy baseline).
            let per_10bar = T::c(P_REF / 1.0e6);
            let dp_int = (self.ekf.x[P3] - self.ekf.x[P4]).abs() * per_10bar;
            let dp_ext = (self.ekf.x[P4] - ctx.inputs.p_tank_pa / T::c(P_REF)).abs() * per_10bar;
            out.flow_internal_lpm = leak_internal * dp_int;
            out.flow_external_lpm = leak_external * dp_ext;
            out.flow_internal_sd_lpm = leak_internal_sd * dp_int;
            out.flow_external_sd_lpm = leak_external_sd * dp_ext;
            out.dp_10bar = [dp_int, dp_ext];
        }
        if N == MAX_STATES {
            let gref = T::c(crate::estimation::model::GAIN_REF);
            out.valve_gain = [self.ekf.x[GAIN_EXT] * gref, self.ekf.x[GAIN_RET] * gref];
        }
        out
    }
}
