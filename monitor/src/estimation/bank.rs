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

use crate::estimation::ekf::{Ekf, EkfError};
use crate::estimation::model::{
    Eval, Inputs, Leaks, Nuisance, Plant, Step, NX, P3, P4, P_REF, VP, VV, V_REF, XP, XV, X_REF,
};
use crate::hypothesis::Hypothesis;
use crate::leak::Leak;
use crate::physics::valve::SpoolStep;
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

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
    /// Internal leak flow at the current pressures, l/min.
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

/// One hypothesis' filter: plant states plus `N − 6` leak coefficients.
#[derive(Clone, Debug)]
pub struct HypothesisFilter<T: Real, const N: usize> {
    /// Which hypothesis.
    pub hypothesis: Hypothesis,
    /// Its estimate.
    pub ekf: Ekf<T, N>,
}

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

    /// The valve nuisance estimates in the current state.
    pub fn nuisance(&self) -> Nuisance<T> {
        Nuisance {
            gain_extend: self.ekf.x[GAIN_EXT],
            gain_retract: self.ekf.x[GAIN_RET],
            laminar: self.ekf.x[LAMINAR],
        }
    }

    /// The leak coefficients in the current state.
    pub fn leaks(&self) -> Leaks<T> {
        Leaks {
            internal: internal_index(self.hypothesis).map_or(T::ZERO, |i| self.ekf.x[i]),
            external: external_index(self.hypothesis).map_or(T::ZERO, |i| self.ekf.x[i]),
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
        let phi = Transition::new(&e, ctx.step.dt, &ctx.spool_dt, self.hypothesis);
        phi.predict_covariance(&mut self.ekf.p, q);
        let inn = self.update(ctx, m, &e)?;
        self.project(ctx);
        // Once per step, after everything that could go wrong.
        self.ekf.check_finite()?;
        Ok(self.output(ctx, &e, &inn))
    }

    /// Project the estimate onto what is physically possible: a leak
    /// coefficient not below its floor (a leak does not run backwards),
    /// the piston within its end stops and not moving into them. The
    /// model has no end-stop force; this is it, as a constraint.
    #[inline(always)]
    fn project(&mut self, ctx: &StepContext<T>) {
        let x = &mut self.ekf.x;
        if let Some(i) = internal_index(self.hypothesis) {
            x[i] = x[i].max(ctx.leak_floor[0]);
        }
        if let Some(i) = external_index(self.hypothesis) {
            x[i] = x[i].max(ctx.leak_floor[1]);
        }
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
    fn predict_mean(&mut self, plant: &Plant<T>, ctx: &StepContext<T>) -> Eval<T> {
        let leaks = self.leaks();
        let nuis = self.nuisance();
        let mut s: [T; NX] = core::array::from_fn(|i| self.ekf.x[i]);
        let e = plant.advance(&mut s, &ctx.inputs, nuis, leaks, &ctx.step);
        for (i, v) in s.iter().enumerate() {
            self.ekf.x[i] = *v;
        }
        e
    }

    /// The three scalar updates (x_p, p3, p4): innovations, NIS and the
    /// product of the innovation variances.
    fn update(
        &mut self,
        ctx: &StepContext<T>,
        m: &Measurement<T>,
        e: &Eval<T>,
    ) -> Result<Innovations<T>, EkfError> {
        // Plant states always learn; valve gains and the laminar and leak
        // coefficients only as much as the sample is worth as evidence.
        let weights: [T; N] = core::array::from_fn(|i| match i {
            GAIN_EXT | GAIN_RET => ctx.gain_learning,
            LAMINAR => ctx.learning,
            i if i >= NB => ctx.learning,
            _ => T::ONE,
        });
        let mut inn = Innovations {
            nis: T::ZERO,
            det: T::ONE,
            innovation_sq: [T::ZERO; 3],
            predicted_var: [T::ZERO; 3],
        };
        // Three calls, not a loop over MEASURED: in a loop the compiler
        // inlined the update and carried P through it on the stack; as
        // calls, one out-of-line update per filter size loads and stores
        // each entry once with the column and gain in registers (measured:
        // a third fewer instructions for the updates).
        self.update_one(0, ctx, m, e, &weights, &mut inn)?;
        self.update_one(1, ctx, m, e, &weights, &mut inn)?;
        self.update_one(2, ctx, m, e, &weights, &mut inn)?;
        Ok(inn)
    }

    /// Scalar update with reading `k` of `m`.
    #[inline(always)]
    fn update_one(
        &mut self,
        k: usize,
        ctx: &StepContext<T>,
        m: &Measurement<T>,
        e: &Eval<T>,
        weights: &[T; N],
        inn: &mut Innovations<T>,
    ) -> Result<(), EkfError> {
        let j = MEASURED[k];
        let lag = if j == XP {
            T::ZERO
        } else {
            ctx.pressure_lag_s * e.f[j]
        };
        let r = m.r[k] + lag * lag;
        let u = self
            .ekf
            .update_state_weighted(j, m.z[k], r, k as u8, weights)?;
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

    /// The step's output.
    fn output(&self, ctx: &StepContext<T>, e: &Eval<T>, inn: &Innovations<T>) -> FilterOutput<T> {
        let gref = T::c(crate::estimation::model::GAIN_REF);
        let (leak_internal, leak_internal_sd) = self.leak(internal_index(self.hypothesis));
        let (leak_external, leak_external_sd) = self.leak(external_index(self.hypothesis));
        // Leak flow magnitude at the updated pressures: θ·|Δp| / 10 bar (a
        // seal leaks whichever way the pressure difference pushes; a
        // negative θ is an estimate below the healthy baseline).
        let per_10bar = T::c(P_REF / 1.0e6);
        let dp_int = (self.ekf.x[P3] - self.ekf.x[P4]).abs() * per_10bar;
        let dp_ext = (self.ekf.x[P4] - ctx.inputs.p_tank_pa / T::c(P_REF)).abs() * per_10bar;
        FilterOutput {
            nis: inn.nis,
            // ln N(ν; 0, S) = −½·(νᵀS⁻¹ν + ln det S + 3·ln 2π).
            log_likelihood: T::c(-0.5)
                * (inn.nis + inn.det.ln() + T::c(3.0 * 1.837_877_066_409_345_5)),
            flow_internal_lpm: leak_internal * dp_int,
            flow_external_lpm: leak_external * dp_ext,
            flow_internal_sd_lpm: leak_internal_sd * dp_int,
            flow_external_sd_lpm: leak_external_sd * dp_ext,
            dp_10bar: [dp_int, dp_ext],
            innovation_sq: inn.innovation_sq,
            predicted_var: inn.predicted_var,
            valve_gain: [self.ekf.x[GAIN_EXT] * gref, self.ekf.x[GAIN_RET] * gref],
            valve_flow_lpm: e.q_valve_a.abs() * T::c(crate::estimation::model::LPM_PER_M3S),
        }
    }
}

/// Columns of Φ's velocity (and position) row: x_p, ẋ_p, p3, p4.
const MECHANICS: [usize; 4] = [XP, VP, P3, P4];
/// Rows and columns of Φ's spool block: x_v, ẋ_v.
const SPOOL: [usize; 2] = [XV, VV];

/// A plant row of Φ stored in [`Transition`] (row x_p is formed from the
/// velocity row's products).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Row {
    Velocity,
    SpoolPosition,
    SpoolRate,
    P3,
    P4,
}

impl Row {
    /// The plant rows after x_p and ẋ_p, in state order.
    const AFTER_MECHANICS: [Row; 4] = [Row::SpoolPosition, Row::SpoolRate, Row::P3, Row::P4];

    /// Its state index.
    const fn index(self) -> usize {
        match self {
            Row::Velocity => VP,
            Row::SpoolPosition => XV,
            Row::SpoolRate => VV,
            Row::P3 => P3,
            Row::P4 => P4,
        }
    }
}

/// The discrete transition Jacobian Φ of `Plant::advance` over one step,
/// stored by its non-zero entries.
///
/// Φ is the identity except in the six plant rows (the nuisance and leak
/// states are random walks), and those rows are sparse: velocity depends
/// on x_p, ẋ_p, p3, p4; position is the identity row plus `ratio` × the
/// velocity row (x_p integrates the updated velocity); the spool pair
/// depends only on itself; the pressures on everything but ẋ_v (the
/// spool acts through x_v). The pressure rows are kept as full rows with
/// structural zeros at ẋ_v (skipped) and at a leak the hypothesis lacks
/// (multiplied, harmlessly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition<T, const N: usize> {
    /// dt·V_REF/X_REF: row x_p of Φ is e_xp + `ratio` × row ẋ_p.
    pub ratio: T,
    /// Row ẋ_p at the columns [`MECHANICS`].
    pub velocity: [T; 4],
    /// Rows x_v, ẋ_v at the columns x_v, ẋ_v.
    pub spool: [[T; 2]; 2],
    /// Row p3, all columns (zero at ẋ_v).
    pub p3: [T; N],
    /// Row p4, all columns (zero at ẋ_v).
    pub p4: [T; N],
}

impl<T: Real, const N: usize> Transition<T, N> {
    /// Φ over `dt` for `hypothesis`, linearised at the start of the step:
    /// the explicit part of each row divided by (1 − dt·d) where the
    /// scheme treats its diagonal `d` implicitly; the spool block from its
    /// exact map; position from the updated velocity (symplectic Euler).
    pub fn new(e: &Eval<T>, dt: T, spool: &SpoolStep<T>, hypothesis: Hypothesis) -> Self {
        let j = &e.jac;
        let stiff = crate::estimation::model::stiff::<T>;
        let g = dt / (T::ONE - dt * stiff(j.v_v));
        let velocity = [g * j.v_x, T::ONE + g * j.v_v, g * j.v_p3, g * j.v_p4];
        let g3 = dt / (T::ONE - dt * stiff(j.p3_p3));
        let g4 = dt / (T::ONE - dt * stiff(j.p4_p4));
        let li = internal_index(hypothesis);
        let le = external_index(hypothesis);
        let p3 = core::array::from_fn(|c| match c {
            XP => g3 * j.p3_x,
            VP => g3 * j.p3_v,
            XV => g3 * j.p3_xv,
            P3 => T::ONE + g3 * j.p3_p3,
            P4 => g3 * j.p3_p4,
            GAIN_EXT => g3 * j.p3_ge,
            GAIN_RET => g3 * j.p3_gr,
            LAMINAR => g3 * j.p3_lam,
            c if Some(c) == li => g3 * j.p3_li,
            // ẋ_v; the external leak drains the rod side only.
            _ => T::ZERO,
        });
        let p4 = core::array::from_fn(|c| match c {
            XP => g4 * j.p4_x,
            VP => g4 * j.p4_v,
            XV => g4 * j.p4_xv,
            P3 => g4 * j.p4_p3,
            P4 => T::ONE + g4 * j.p4_p4,
            GAIN_EXT => g4 * j.p4_ge,
            GAIN_RET => g4 * j.p4_gr,
            LAMINAR => g4 * j.p4_lam,
            c if Some(c) == li => g4 * j.p4_li,
            c if Some(c) == le => g4 * j.p4_le,
            _ => T::ZERO,
        });
        Self {
            // x_p ← x_p + dt·ẋ_p(new), in scaled units.
            ratio: dt * T::c(V_REF / X_REF),
            velocity,
            spool: spool.phi,
            p3,
            p4,
        }
    }

    /// (Φ·v)_row = Σ_k Φ[row, k]·v(k) over the row's non-zero columns.
    #[inline(always)]
    fn row_dot(&self, row: Row, v: impl Fn(usize) -> T) -> T {
        let pressure = |c: &[T; N]| {
            let mut sum = c[XP] * v(XP) + c[VP] * v(VP) + c[XV] * v(XV);
            for k in P3..N {
                sum += c[k] * v(k);
            }
            sum
        };
        let spool = |c: &[T; 2]| c[0] * v(SPOOL[0]) + c[1] * v(SPOOL[1]);
        match row {
            Row::Velocity => {
                let c = &self.velocity;
                c[0] * v(MECHANICS[0])
                    + c[1] * v(MECHANICS[1])
                    + c[2] * v(MECHANICS[2])
                    + c[3] * v(MECHANICS[3])
            }
            Row::SpoolPosition => spool(&self.spool[0]),
            Row::SpoolRate => spool(&self.spool[1]),
            Row::P3 => pressure(&self.p3),
            Row::P4 => pressure(&self.p4),
        }
    }

    /// P ← Φ·P·Φᵀ + diag(q), in place, touching only what Φ changes.
    ///
    /// With Φ = [[A, B], [0, I]] (A: the 6 plant rows and columns),
    /// M = Φ_plant·P (6 × N) gives the plant–nuisance covariances directly,
    /// M·Φ_plantᵀ the plant block (one triangle, mirrored: P stays exactly
    /// symmetric), and the nuisance block keeps its values.
    pub fn predict_covariance(&self, p: &mut SMatrix<T, N, N>, q: &[T; MAX_STATES]) {
        const { assert!(N <= MAX_STATES) };
        // Column c of M (plant rows only), for every column c of P.
        let m: [[T; NX]; N] = core::array::from_fn(|c| self.plant_rows_times(p, c));
        for (c, column) in m.iter().enumerate().skip(NX) {
            for (a, &v) in column.iter().enumerate() {
                set_symmetric(p, a, c, v);
            }
        }
        self.write_plant_block(p, &m);
        for i in 0..N {
            p[(i, i)] += q[i];
        }
    }

    /// Column c of M = Φ_plant·P: (Φ·P)[a, c] for the plant rows a. P is
    /// symmetric, so its column c is read once for all six rows.
    #[inline(always)]
    fn plant_rows_times(&self, p: &SMatrix<T, N, N>, c: usize) -> [T; NX] {
        let v = |k: usize| p[(k, c)];
        let velocity = self.row_dot(Row::Velocity, v);
        [
            v(XP) + self.ratio * velocity,
            velocity,
            self.row_dot(Row::SpoolPosition, v),
            self.row_dot(Row::SpoolRate, v),
            self.row_dot(Row::P3, v),
            self.row_dot(Row::P4, v),
        ]
    }

    /// The plant block of Φ·P·Φᵀ, (M·Φ_plantᵀ)[a, b] = Σ_k M[a, k]·Φ[b, k],
    /// for a ≥ b, mirrored; `m` holds M by columns. The columns ẋ_p and
    /// x_p are formed for every row first: column x_p is column x_p of M
    /// plus `ratio` × column ẋ_p.
    #[inline(always)]
    fn write_plant_block(&self, p: &mut SMatrix<T, N, N>, m: &[[T; NX]; N]) {
        let velocity: [T; NX] = core::array::from_fn(|a| self.row_dot(Row::Velocity, |k| m[k][a]));
        for a in 0..NX {
            set_symmetric(p, a, XP, m[XP][a] + self.ratio * velocity[a]);
            if a != XP {
                set_symmetric(p, a, VP, velocity[a]);
            }
        }
        for row in Row::AFTER_MECHANICS {
            let b = row.index();
            for a in b..NX {
                set_symmetric(p, a, b, self.row_dot(row, |k| m[k][a]));
            }
        }
    }

    /// Φ as a dense matrix (the tests' reference).
    #[cfg(test)]
    pub fn dense(&self) -> SMatrix<T, N, N> {
        let mut phi = SMatrix::<T, N, N>::identity();
        for (i, &c) in MECHANICS.iter().enumerate() {
            phi[(XP, c)] += self.ratio * self.velocity[i];
            phi[(VP, c)] = self.velocity[i];
        }
        for (i, &r) in SPOOL.iter().enumerate() {
            for (k, &c) in SPOOL.iter().enumerate() {
                phi[(r, c)] = self.spool[i][k];
            }
        }
        for c in 0..N {
            phi[(P3, c)] = self.p3[c];
            phi[(P4, c)] = self.p4[c];
        }
        phi
    }
}

/// P[a, b] = P[b, a] = v.
#[inline(always)]
fn set_symmetric<T: Real, const N: usize>(p: &mut SMatrix<T, N, N>, a: usize, b: usize, v: T) {
    p[(a, b)] = v;
    p[(b, a)] = v;
}

/// Step `filter`, its output into `slot` (`None` if it failed: a singular
/// or non-finite innovation covariance, or a non-finite state).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::model::{Inputs, Step, BAR};
    use crate::params::Params;

    /// A plant, a step context and the filter settings at an operating
    /// point of the reference rig: moving with the valve open, or holding
    /// with the spool in the dead zone.
    struct Setting<T: Real> {
        plant: Plant<T>,
        ctx: StepContext<T>,
        noise: ProcessNoise<T>,
        r: [T; NZ],
        s0: [T; NX],
    }

    /// Operating points: valve command and scaled plant state
    /// `[x_p, ẋ_p, x_v, ẋ_v, p3, p4]`.
    const POINTS: [(f64, [f64; NX]); 5] = [
        // Extending with the valve open.
        (0.2, [0.5, 0.2, 0.2, 0.0, 0.3, 0.12]),
        // Holding, spool in the dead zone.
        (0.0, [0.9, 0.0, 0.0, 0.0, 0.214, 0.129]),
        // Retracting fast, spool still moving.
        (-0.15, [1.2, -0.3, -0.15, 0.1, 0.14, 0.22]),
        // Near the stroke end, laminar orifice region (Δp < 1 bar).
        (0.3, [0.02, 0.0, 0.3, 0.0, 0.496, 0.012]),
        // Past the stroke end (the position terms vanish).
        (0.0, [1.85, 0.0, 0.0, 0.0, 0.2, 0.1]),
    ];

    fn setting<T: Real>(moving: bool) -> Setting<T> {
        at_point(if moving { POINTS[0] } else { POINTS[1] })
    }

    fn at_point<T: Real>((u, s0): (f64, [f64; NX])) -> Setting<T> {
        let params = Params::nominal();
        let plant = Plant::<T>::new(&params);
        let f = &params.filter;
        let ctx = StepContext {
            inputs: Inputs {
                p_supply_pa: T::c(50.0 * BAR),
                p_tank_pa: T::c(0.8 * BAR),
                u_valve: T::c(u),
                laminar_factor: T::ONE,
            },
            step: Step {
                dt: T::c(0.001),
                substeps: 2,
                spool: plant.spool_step(0.0005),
            },
            spool_dt: plant.spool_step(0.001),
            pressure_lag_s: T::c(params.sensors.pressure_lag_s),
            learning: T::c(0.7),
            gain_learning: T::c(0.4),
            leak_floor: [T::c(-1.0), T::c(-1.0)],
            // The dense reference has no end stops: keep them out of reach.
            stroke: T::c(1.0e3),
        };
        let gain = f.q_gain / 0.01;
        let noise = ProcessNoise {
            base: [
                T::c(f.q_position),
                T::c(f.q_velocity),
                T::c(f.q_spool),
                T::c(f.q_spool_rate),
                T::c(f.q_pressure),
                T::c(f.q_pressure),
                T::c(gain),
                T::c(gain),
                T::c(f.q_laminar / 0.25),
            ],
            leak: T::c(f.q_leak),
        };
        let sx = params.sensors.position_noise_m / 0.1;
        let sp = params.sensors.pressure_noise_bar * BAR / 1e7;
        Setting {
            plant,
            ctx,
            noise,
            r: [T::c(sx * sx), T::c(sp * sp), T::c(sp * sp)],
            s0: s0.map(T::c),
        }
    }

    /// One step with readings slightly off the filter's own prediction.
    fn step<T: Real, const N: usize>(
        f: &mut HypothesisFilter<T, N>,
        s: &Setting<T>,
    ) -> Result<(), EkfError> {
        let x = &f.ekf.x;
        let m = Measurement {
            z: [x[XP] + T::c(1e-4), x[P3] + T::c(1e-3), x[P4] - T::c(1e-3)],
            r: s.r,
        };
        let q = s.noise.variances(s.ctx.step.dt);
        f.step(&s.plant, &s.ctx, &q, &m).map(|_| ())
    }

    /// A filter of hypothesis `h` run for 200 steps: the covariance is
    /// populated (but for the gain of the spool direction never used).
    fn settled<T: Real, const N: usize>(h: Hypothesis, s: &Setting<T>) -> HypothesisFilter<T, N> {
        let p0 = [T::c(1e-3); NB];
        let mut f = HypothesisFilter::new(h, &s.s0, &p0, T::c(0.1));
        for _ in 0..200 {
            step(&mut f, s).expect("a healthy filter step");
        }
        f
    }

    /// A NaN or infinity anywhere in P or x fails the very next step with
    /// `NonFinite`, although only x and the diagonal are checked.
    fn non_finite_anywhere_fails_the_next_step<T: Real, const N: usize>(h: Hypothesis) {
        for moving in [true, false] {
            let s = setting::<T>(moving);
            let good = settled::<T, N>(h, &s);
            for bad in [T::c(f64::NAN), T::c(f64::INFINITY), T::c(f64::NEG_INFINITY)] {
                for a in 0..N {
                    for b in a..N {
                        let mut f = good.clone();
                        f.ekf.p[(a, b)] = bad;
                        f.ekf.p[(b, a)] = bad;
                        let got = step(&mut f, &s);
                        let at = (h, moving, bad, a, b);
                        assert_eq!(got, Err(EkfError::NonFinite), "P at {at:?}");
                    }
                    let mut f = good.clone();
                    f.ekf.x[a] = bad;
                    let got = step(&mut f, &s);
                    assert_eq!(got, Err(EkfError::NonFinite), "x at {:?}", (h, a));
                }
            }
        }
    }

    /// Φ as the dense code built it before the sparse form (reference).
    fn dense_transition<T: Real, const N: usize>(
        h: Hypothesis,
        e: &Eval<T>,
        dt: T,
        spool: &SpoolStep<T>,
    ) -> SMatrix<T, N, N> {
        let j = &e.jac;
        let mut phi = SMatrix::<T, N, N>::identity();
        let stiff = crate::estimation::model::stiff::<T>;
        let g = dt / (T::ONE - dt * stiff(j.v_v));
        phi[(VP, XP)] = g * j.v_x;
        phi[(VP, VP)] = T::ONE + g * j.v_v;
        phi[(VP, P3)] = g * j.v_p3;
        phi[(VP, P4)] = g * j.v_p4;
        let ratio = dt * T::c(V_REF / X_REF);
        for c in [XP, VP, P3, P4] {
            let v = phi[(VP, c)];
            phi[(XP, c)] += ratio * v;
        }
        phi[(XV, XV)] = spool.phi[0][0];
        phi[(XV, VV)] = spool.phi[0][1];
        phi[(VV, XV)] = spool.phi[1][0];
        phi[(VV, VV)] = spool.phi[1][1];
        let g3 = dt / (T::ONE - dt * stiff(j.p3_p3));
        phi[(P3, XP)] = g3 * j.p3_x;
        phi[(P3, VP)] = g3 * j.p3_v;
        phi[(P3, XV)] = g3 * j.p3_xv;
        phi[(P3, P3)] = T::ONE + g3 * j.p3_p3;
        phi[(P3, P4)] = g3 * j.p3_p4;
        let g4 = dt / (T::ONE - dt * stiff(j.p4_p4));
        phi[(P4, XP)] = g4 * j.p4_x;
        phi[(P4, VP)] = g4 * j.p4_v;
        phi[(P4, XV)] = g4 * j.p4_xv;
        phi[(P4, P3)] = g4 * j.p4_p3;
        phi[(P4, P4)] = T::ONE + g4 * j.p4_p4;
        phi[(P3, GAIN_EXT)] = g3 * j.p3_ge;
        phi[(P4, GAIN_EXT)] = g4 * j.p4_ge;
        phi[(P3, GAIN_RET)] = g3 * j.p3_gr;
        phi[(P4, GAIN_RET)] = g4 * j.p4_gr;
        phi[(P3, LAMINAR)] = g3 * j.p3_lam;
        phi[(P4, LAMINAR)] = g4 * j.p4_lam;
        if let Some(i) = internal_index(h) {
            phi[(P3, i)] = g3 * j.p3_li;
            phi[(P4, i)] = g4 * j.p4_li;
        }
        if let Some(i) = external_index(h) {
            phi[(P4, i)] = g4 * j.p4_le;
        }
        phi
    }

    /// The model at an operating point, with non-zero nuisance and leaks
    /// so that every Jacobian entry is exercised.
    fn eval_at<T: Real>(s: &Setting<T>) -> Eval<T> {
        let nuis = Nuisance {
            gain_extend: T::c(0.3),
            gain_retract: T::c(-0.2),
            laminar: T::c(0.4),
        };
        let leaks = Leaks {
            internal: T::c(0.4),
            external: T::c(0.3),
        };
        s.plant.eval(&s.s0, &s.ctx.inputs, nuis, leaks)
    }

    /// Sparse Φ and prediction against the dense references, at every
    /// operating point, on random SPD covariances: Φ exactly, the
    /// prediction within `tol` of √(P_aa·P_bb) of the result.
    fn prediction_matches_dense<T: Real, const N: usize>(h: Hypothesis, tol: f64) {
        let mut rng = crate::estimation::ekf::TestRng(0x9e37_79b9_7f4a_7c15 ^ h as u64);
        for point in POINTS {
            let s = at_point::<T>(point);
            let e = eval_at(&s);
            let phi = Transition::<T, N>::new(&e, s.ctx.step.dt, &s.ctx.spool_dt, h);
            let dense = dense_transition::<T, N>(h, &e, s.ctx.step.dt, &s.ctx.spool_dt);
            assert_eq!(phi.dense(), dense, "{h:?} at {point:?}");
            let q = s.noise.variances(s.ctx.step.dt);
            let q_n: [T; N] = core::array::from_fn(|i| q[i]);
            for _ in 0..40 {
                let p0 = rng.spd::<T, N>();
                let mut fast = p0;
                phi.predict_covariance(&mut fast, &q);
                let mut slow = p0;
                crate::estimation::ekf::predict_covariance_dense(&mut slow, &dense, &q_n);
                for a in 0..N {
                    for b in 0..N {
                        let scale = (slow[(a, a)] * slow[(b, b)]).sqrt().to_f64();
                        let d = (fast[(a, b)] - slow[(a, b)]).abs().to_f64() / scale;
                        assert!(d <= tol, "{h:?} at {point:?}: P[{a}, {b}] differs by {d:e}");
                        assert_eq!(fast[(a, b)], fast[(b, a)]);
                    }
                }
            }
        }
    }

    #[test]
    fn sparse_prediction_equals_the_dense_product() {
        // The same products, summed in another order (one triangle of the
        // plant block; row x_p from row ẋ_p): rounding differences only,
        // a few units in the last place (seen: f64 5e-16, f32 5e-7).
        prediction_matches_dense::<f64, { NB }>(Hypothesis::Healthy, 2e-15);
        prediction_matches_dense::<f64, { NB + 1 }>(Hypothesis::Internal, 2e-15);
        prediction_matches_dense::<f64, { NB + 1 }>(Hypothesis::External, 2e-15);
        prediction_matches_dense::<f64, { NB + 2 }>(Hypothesis::Both, 2e-15);
        prediction_matches_dense::<f32, { NB }>(Hypothesis::Healthy, 2e-6);
        prediction_matches_dense::<f32, { NB + 1 }>(Hypothesis::Internal, 2e-6);
        prediction_matches_dense::<f32, { NB + 1 }>(Hypothesis::External, 2e-6);
        prediction_matches_dense::<f32, { NB + 2 }>(Hypothesis::Both, 2e-6);
    }

    /// The whole filter step as the dense code did it: nonlinear mean,
    /// dense Φ·P·Φᵀ, Joseph updates as matrix products.
    fn dense_step<T: Real, const N: usize>(f: &mut HypothesisFilter<T, N>, s: &Setting<T>) {
        // The readings of `step`: off the state before the step.
        let x = f.ekf.x;
        let z = [x[XP] + T::c(1e-4), x[P3] + T::c(1e-3), x[P4] - T::c(1e-3)];
        let e = f.predict_mean(&s.plant, &s.ctx);
        let phi = dense_transition::<T, N>(f.hypothesis, &e, s.ctx.step.dt, &s.ctx.spool_dt);
        let q = s.noise.variances(s.ctx.step.dt);
        let q: [T; N] = core::array::from_fn(|i| q[i]);
        crate::estimation::ekf::predict_covariance_dense(&mut f.ekf.p, &phi, &q);
        let w: [T; N] = core::array::from_fn(|i| match i {
            GAIN_EXT | GAIN_RET => s.ctx.gain_learning,
            i if i >= LAMINAR => s.ctx.learning,
            _ => T::ONE,
        });
        for (k, &j) in MEASURED.iter().enumerate() {
            let lag = if j == XP {
                T::ZERO
            } else {
                s.ctx.pressure_lag_s * e.f[j]
            };
            crate::estimation::ekf::joseph_update_dense(
                &mut f.ekf,
                j,
                z[k],
                s.r[k] + lag * lag,
                &w,
            );
        }
    }

    /// 500 steps of the optimised filter and of the dense one from the
    /// same start, at every operating point: x within `tol_x` (relative to
    /// 1 + |x|), P within `tol_p` of √(P_aa·P_bb).
    fn filter_matches_dense<T: Real, const N: usize>(h: Hypothesis, tol_x: f64, tol_p: f64) {
        for point in POINTS {
            let s = at_point::<T>(point);
            let p0 = [T::c(1e-3); NB];
            let mut fast = HypothesisFilter::<T, N>::new(h, &s.s0, &p0, T::c(0.1));
            let mut slow = fast.clone();
            for _ in 0..500 {
                step(&mut fast, &s).expect("a healthy filter step");
                dense_step(&mut slow, &s);
            }
            let rel = |a: T, b: T, scale: f64| (a - b).abs().to_f64() / scale;
            for a in 0..N {
                let d = rel(
                    fast.ekf.x[a],
                    slow.ekf.x[a],
                    1.0 + slow.ekf.x[a].abs().to_f64(),
                );
                assert!(d <= tol_x, "{h:?} at {point:?}: x[{a}] differs by {d:e}");
                for b in 0..N {
                    let scale = (slow.ekf.p[(a, a)] * slow.ekf.p[(b, b)]).sqrt().to_f64();
                    let d = rel(fast.ekf.p[(a, b)], slow.ekf.p[(a, b)], scale);
                    assert!(
                        d <= tol_p,
                        "{h:?} at {point:?}: P[{a}, {b}] differs by {d:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn filter_steps_equal_the_dense_filter() {
        // The dense Joseph update (matrix products) rounds differently
        // from the elementwise one: f64 agrees to ~1e-13, f32 to ~1e-5.
        filter_matches_dense::<f64, { NB }>(Hypothesis::Healthy, 1e-13, 1e-11);
        filter_matches_dense::<f64, { NB + 1 }>(Hypothesis::Internal, 1e-13, 1e-11);
        filter_matches_dense::<f64, { NB + 1 }>(Hypothesis::External, 1e-13, 1e-11);
        filter_matches_dense::<f64, { NB + 2 }>(Hypothesis::Both, 1e-13, 1e-11);
        filter_matches_dense::<f32, { NB }>(Hypothesis::Healthy, 1e-5, 3e-4);
        filter_matches_dense::<f32, { NB + 1 }>(Hypothesis::Internal, 1e-5, 3e-4);
        filter_matches_dense::<f32, { NB + 1 }>(Hypothesis::External, 1e-5, 3e-4);
        filter_matches_dense::<f32, { NB + 2 }>(Hypothesis::Both, 1e-5, 3e-4);
    }

    #[test]
    fn non_finite_values_anywhere_are_caught_within_one_step() {
        non_finite_anywhere_fails_the_next_step::<f32, { NB }>(Hypothesis::Healthy);
        non_finite_anywhere_fails_the_next_step::<f32, { NB + 1 }>(Hypothesis::Internal);
        non_finite_anywhere_fails_the_next_step::<f32, { NB + 1 }>(Hypothesis::External);
        non_finite_anywhere_fails_the_next_step::<f32, { NB + 2 }>(Hypothesis::Both);
        non_finite_anywhere_fails_the_next_step::<f64, { NB + 2 }>(Hypothesis::Both);
    }
}
