//! The sparse transition Jacobian Φ of one step and the covariance prediction with it.

use super::{GAIN_EXT, GAIN_RET, LAMINAR, MAX_STATES};
use crate::estimation::model::{Eval, NX, P3, P4, VP, VV, V_REF, XP, XV, X_REF};
use crate::physics::valve::SpoolStep;
use crate::real::Real;
use nalgebra::SMatrix;

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
    /// Φ over `dt` for a hypothesis with leak states `(internal,
    /// external)` ([`leak_indices`](super::leak_indices)), linearised at
    /// the start of the step: the explicit part of each row divided by
    /// (1 − dt·d) where the scheme treats its diagonal `d` implicitly; the
    /// spool block from its exact map; position from the updated velocity
    /// (symplectic Euler).
    pub fn new(
        e: &Eval<T>,
        dt: T,
        spool: &SpoolStep<T>,
        (li, le): (Option<usize>, Option<usize>),
    ) -> Self {
        let j = &e.jac;
        let stiff = crate::estimation::model::stiff::<T>;
        let g = dt / (T::ONE - dt * stiff(j.v_v));
        let velocity = [g * j.v_x, T::ONE + g * j.v_v, g * j.v_p3, g * j.v_p4];
        let g3 = dt / (T::ONE - dt * stiff(j.p3_p3));
        let g4 = dt / (T::ONE - dt * stiff(j.p4_p4));
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
    /// M·Φ_plantᵀ the plant block (one triangle), and the nuisance block
    /// keeps its values. Reads the whole of P, which must be symmetric;
    /// writes only its upper triangle (a ≤ b): the lower one is left
    /// stale for the step's updates, which read the upper one, and the
    /// last of which mirrors it (`Ekf::update_state_weighted`).
    pub fn predict_covariance(&self, p: &mut SMatrix<T, N, N>, q: &[T; MAX_STATES]) {
        const { assert!(N <= MAX_STATES) };
        // Column c of M (plant rows only), for every column c of P.
        let m: [[T; NX]; N] = core::array::from_fn(|c| self.plant_rows_times(p, c));
        for (c, column) in m.iter().enumerate().skip(NX) {
            for (a, &v) in column.iter().enumerate() {
                // a < NX ≤ c: upper triangle.
                p[(a, c)] = v;
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
    /// for a ≥ b, written to the upper triangle (P[b, a]); `m` holds M by
    /// columns. The columns ẋ_p and x_p are formed for every row first:
    /// column x_p is column x_p of M plus `ratio` × column ẋ_p.
    #[inline(always)]
    fn write_plant_block(&self, p: &mut SMatrix<T, N, N>, m: &[[T; NX]; N]) {
        let velocity: [T; NX] = core::array::from_fn(|a| self.row_dot(Row::Velocity, |k| m[k][a]));
        for a in 0..NX {
            p[(XP, a)] = m[XP][a] + self.ratio * velocity[a];
            if a != XP {
                p[(VP, a)] = velocity[a];
            }
        }
        for row in Row::AFTER_MECHANICS {
            let b = row.index();
            for a in b..NX {
                p[(b, a)] = self.row_dot(row, |k| m[k][a]);
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
