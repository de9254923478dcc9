//! The pantograph crane as a load on the cylinder, derived here from the
//! geometry of thesis ch. 5 by virtual work (no code shared with `monitor`).
//!
//! The crane has one degree of freedom, the piston position `x` (m). Rods 1
//! and 3 turn with θ1(x), rods 2.1 and 2.2 with θ2(x) (fits 5.4/5.5, in
//! degrees — erratum 6). Each body's centre of mass `r_i(x)` follows the
//! vector chains 5.11, 5.23, 5.34, 5.43. With `J_i = dr_i/dx`,
//! `ω_i = dθ_i/dx`, the kinetic energy is `½ M(x) ẋ²` with
//! `M(x) = Σ m_i |J_i|² + I_i ω_i²`, the potential `V(x) = Σ m_i g y_i(x)`,
//! and Lagrange gives the force the cylinder must deliver:
//! `F = M(x) ẍ + ½ M'(x) ẋ² + G(x)`, `G = dV/dx = Σ m_i g J_i,y`.
//! A point payload sits at the tip of rod 3; a constant force offset
//! (unmodelled parts, hoses, cable) adds to G.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// Geometry and mass properties of the pantograph. Lengths in m, angles
/// fits in degrees (x in m), masses in kg, inertias in kg·m².
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadSpec {
    /// θ1 = a·x + b (rods 1 and 3), `[a (°/m), b (°)]` (thesis eq. 5.4).
    pub theta1_fit_deg: [f64; 2],
    /// θ2 = a·x² + b·x + c (rods 2.1, 2.2), `[a (°/m²), b (°/m), c (°)]`
    /// (thesis eq. 5.5).
    pub theta2_fit_deg: [f64; 3],
    /// Height of the rod 2.1 pivot above the base pivot, m.
    pub base_to_r21_y_m: f64,
    /// Rod 2.1 pivot → rod 1 pivot, along rod 2.1, m.
    pub r21_to_r1_m: f64,
    /// Rod 2.1 pivot → rod 3 pivot, along rod 2.1, m.
    pub r21_to_r3_m: f64,
    /// Rod 2.1 pivot → its centre of mass, m.
    pub r21_to_cg21_m: f64,
    /// Rod 1 pivot → its centre of mass, m.
    pub r1_to_cg1_m: f64,
    /// Rod 1 pivot → rod 2.2 pivot, along rod 1, m.
    pub r1_to_r22_m: f64,
    /// Rod 2.2 pivot → its centre of mass, m.
    pub r22_to_cg22_m: f64,
    /// Rod 3 pivot → its centre of mass, m.
    pub r3_to_cg3_m: f64,
    /// Rod 3 pivot → the tip where the payload hangs, m. Not in the thesis:
    /// taken as twice the pivot → centre-of-mass distance (uniform rod).
    pub r3_to_tip_m: f64,
    /// Masses of rods 1, 2.1, 2.2, 3, kg (thesis values ±10 % per rig).
    pub masses_kg: [f64; 4],
    /// Inertias of rods 1, 2.1, 2.2, 3 about their centres, kg·m²
    /// (slender-bar estimate m·(2d)²/12, ±30 % per rig).
    pub inertias_kg_m2: [f64; 4],
    /// Unknown payload at the tip of rod 3, kg (0–30).
    pub payload_kg: f64,
    /// Constant force opposing extension, N (±200).
    pub force_offset_n: f64,
    /// Gravitational acceleration, m/s².
    pub gravity_m_s2: f64,
}

impl LoadSpec {
    /// The thesis values (no payload, no offset).
    pub fn nominal() -> Self {
        let masses_kg = [6.12844, 15.36792, 13.62235, 87.92456];
        // Slender bar about its centre, twice the pivot→cg distance long.
        let d = [0.186, 0.508, 0.44, 1.35];
        let mut inertias_kg_m2 = [0.0; 4];
        for i in 0..4 {
            let l = 2.0 * d[i];
            inertias_kg_m2[i] = masses_kg[i] * l * l / 12.0;
        }
        Self {
            theta1_fit_deg: [162.5, -19.99],
            theta2_fit_deg: [-664.6, 163.9, 87.71],
            base_to_r21_y_m: 0.155,
            r21_to_r1_m: 0.125,
            r21_to_r3_m: 1.0,
            r21_to_cg21_m: 0.508,
            r1_to_cg1_m: 0.186,
            r1_to_r22_m: 0.365,
            r22_to_cg22_m: 0.44,
            r3_to_cg3_m: 1.35,
            r3_to_tip_m: 2.7,
            masses_kg,
            inertias_kg_m2,
            payload_kg: 0.0,
            force_offset_n: 0.0,
            gravity_m_s2: 9.81,
        }
    }

    /// A rig's pantograph: masses ±10 %, inertias ±30 %, payload 0–30 kg,
    /// force offset ±200 N.
    pub(crate) fn random(r: &mut Rand) -> Self {
        let mut s = Self::nominal();
        for m in &mut s.masses_kg {
            *m *= r.uniform(0.9, 1.1);
        }
        for i in &mut s.inertias_kg_m2 {
            *i *= r.uniform(0.7, 1.3);
        }
        s.payload_kg = r.uniform(0.0, 30.0);
        s.force_offset_n = r.uniform(-200.0, 200.0);
        s
    }

    /// Angles θ1, θ2 (rad) and their derivatives dθ/dx (rad/m) at `x` (m).
    pub fn angles(&self, x: f64) -> ([f64; 2], [f64; 2]) {
        let k = std::f64::consts::PI / 180.0;
        let [a1, b1] = self.theta1_fit_deg;
        let [a2, b2, c2] = self.theta2_fit_deg;
        let t1 = (a1 * x + b1) * k;
        let t2 = (a2 * x * x + b2 * x + c2) * k;
        ([t1, t2], [a1 * k, (2.0 * a2 * x + b2) * k])
    }

    /// Every moving body at `x` (m): (mass kg, inertia kg·m², centre of mass
    /// `[x, y]` m, its derivative d/dx `[.,.]` (m/m), dθ/dx rad/m).
    /// Order: rod 1, rod 2.1, rod 2.2, rod 3, payload.
    pub fn bodies(&self, x: f64) -> [Body; 5] {
        let ([t1, t2], [w1, w2]) = self.angles(x);
        let (s1, c1) = t1.sin_cos();
        let (s2, c2) = t2.sin_cos();
        // A vector of length l along a rod at angle θ, and its d/dx.
        let along = |l: f64, c: f64, s: f64, w: f64| ([l * c, l * s], [-l * s * w, l * c * w]);
        let add = |a: ([f64; 2], [f64; 2]), b: ([f64; 2], [f64; 2])| {
            (
                [a.0[0] + b.0[0], a.0[1] + b.0[1]],
                [a.1[0] + b.1[0], a.1[1] + b.1[1]],
            )
        };
        let base = ([0.0, self.base_to_r21_y_m], [0.0, 0.0]);
        let r1 = add(base, along(self.r21_to_r1_m, c2, s2, w2));
        let cg1 = add(r1, along(self.r1_to_cg1_m, c1, s1, w1));
        let cg21 = add(base, along(self.r21_to_cg21_m, c2, s2, w2));
        let r22 = add(r1, along(self.r1_to_r22_m, c1, s1, w1));
        let cg22 = add(r22, along(self.r22_to_cg22_m, c2, s2, w2));
        let r3 = add(base, along(self.r21_to_r3_m, c2, s2, w2));
        let cg3 = add(r3, along(self.r3_to_cg3_m, c1, s1, w1));
        let tip = add(r3, along(self.r3_to_tip_m, c1, s1, w1));
        let m = self.masses_kg;
        let i = self.inertias_kg_m2;
        let body = |mass: f64, inertia: f64, p: ([f64; 2], [f64; 2]), w: f64| Body {
            mass_kg: mass,
            inertia_kg_m2: inertia,
            pos_m: p.0,
            dpos_dx: p.1,
            dtheta_dx: w,
        };
        [
            body(m[0], i[0], cg1, w1),
            body(m[1], i[1], cg21, w2),
            body(m[2], i[2], cg22, w2),
            body(m[3], i[3], cg3, w1),
            body(self.payload_kg, 0.0, tip, w1),
        ]
    }

    /// Potential energy of the crane at `x`, J (zero at the base pivot).
    pub fn potential_j(&self, x: f64) -> f64 {
        self.bodies(x)
            .iter()
            .map(|b| b.mass_kg * self.gravity_m_s2 * b.pos_m[1])
            .sum::<f64>()
            + self.force_offset_n * x
    }

    /// Static force the cylinder must push to hold the crane at `x`, N
    /// (virtual work `Σ m g dy/dx`, plus the constant offset).
    pub fn gravity_force_n(&self, x: f64) -> f64 {
        self.bodies(x)
            .iter()
            .map(|b| b.mass_kg * self.gravity_m_s2 * b.dpos_dx[1])
            .sum::<f64>()
            + self.force_offset_n
    }

    /// Effective mass reduced to the piston, kg: `Σ m |dr/dx|² + I (dθ/dx)²`.
    pub fn effective_mass_kg(&self, x: f64) -> f64 {
        self.bodies(x)
            .iter()
            .map(|b| {
                b.mass_kg * (b.dpos_dx[0].powi(2) + b.dpos_dx[1].powi(2))
                    + b.inertia_kg_m2 * b.dtheta_dx.powi(2)
            })
            .sum()
    }
}

/// One moving body of the crane at a piston position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Inertia about the centre of mass, kg·m².
    pub inertia_kg_m2: f64,
    /// Centre of mass `[x, y]`, m.
    pub pos_m: [f64; 2],
    /// d(centre of mass)/d(piston position), m/m.
    pub dpos_dx: [f64; 2],
    /// d(angle)/d(piston position), rad/m.
    pub dtheta_dx: f64,
}

/// `M(x)`, `M'(x)` and `G(x)` tabulated over the stroke (plus margins) for
/// fast, smooth lookup during integration.
#[derive(Clone, Debug)]
pub(crate) struct LoadTable {
    x0: f64,
    dx: f64,
    m: Vec<f64>,
    dm: Vec<f64>,
    g: Vec<f64>,
}

impl LoadTable {
    pub(crate) fn new(spec: &LoadSpec, stroke_m: f64) -> Self {
        let n = 801;
        let x0 = -0.02;
        let dx = (stroke_m + 0.04) / (n - 1) as f64;
        let h = 1e-6;
        let mut m = Vec::with_capacity(n);
        let mut dm = Vec::with_capacity(n);
        let mut g = Vec::with_capacity(n);
        for k in 0..n {
            let x = x0 + dx * k as f64;
            m.push(spec.effective_mass_kg(x));
            dm.push((spec.effective_mass_kg(x + h) - spec.effective_mass_kg(x - h)) / (2.0 * h));
            g.push(spec.gravity_force_n(x));
        }
        Self { x0, dx, m, dm, g }
    }

    /// (M kg, M' kg/m, G N) at `x`, linear interpolation (clamped).
    #[inline]
    pub(crate) fn at(&self, x: f64) -> (f64, f64, f64) {
        let f = ((x - self.x0) / self.dx).clamp(0.0, (self.m.len() - 2) as f64);
        let i = f as usize;
        let a = f - i as f64;
        let lerp = |v: &[f64]| v[i] + a * (v[i + 1] - v[i]);
        (lerp(&self.m), lerp(&self.dm), lerp(&self.g))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_by_virtual_work_matches_potential_energy_difference() {
        let mut r = Rand::new(7, 1);
        for _ in 0..5 {
            let s = LoadSpec::random(&mut r);
            for k in 0..=18 {
                let x = 0.01 * k as f64;
                let h = 1e-5;
                let fd = (s.potential_j(x + h) - s.potential_j(x - h)) / (2.0 * h);
                let g = s.gravity_force_n(x);
                assert!(
                    (fd - g).abs() < 1e-4 * g.abs().max(1.0),
                    "x={x} fd={fd} g={g}"
                );
            }
        }
    }

    #[test]
    fn load_is_plausible_for_the_thesis_rig() {
        let s = LoadSpec::nominal();
        for k in 0..=18 {
            let x = 0.01 * k as f64;
            let g = s.gravity_force_n(x);
            let m = s.effective_mass_kg(x);
            // Lifting a ~120 kg boom through a ~1:4 lever: kN, not N or MN.
            assert!(g > 1_000.0 && g < 10_000.0, "G({x}) = {g}");
            assert!(m > 100.0 && m < 10_000.0, "M({x}) = {m}");
        }
    }

    #[test]
    fn kinetic_energy_matches_finite_difference_velocities() {
        // M(x)·ẋ²/2 equals Σ ½ m |Δr/Δt|² + ½ I (Δθ/Δt)² for a small move.
        let s = LoadSpec::nominal();
        let (x, dx) = (0.1, 1e-6);
        let a = s.bodies(x - dx);
        let b = s.bodies(x + dx);
        let ([t1a, t2a], _) = s.angles(x - dx);
        let ([t1b, t2b], _) = s.angles(x + dx);
        let dth = [t1b - t1a, t2b - t2a, t2b - t2a, t1b - t1a, t1b - t1a];
        let mut e = 0.0;
        for i in 0..5 {
            let vx = (b[i].pos_m[0] - a[i].pos_m[0]) / (2.0 * dx);
            let vy = (b[i].pos_m[1] - a[i].pos_m[1]) / (2.0 * dx);
            let w = dth[i] / (2.0 * dx);
            e += a[i].mass_kg * (vx * vx + vy * vy) + a[i].inertia_kg_m2 * w * w;
        }
        let m = s.effective_mass_kg(x);
        assert!((e - m).abs() < 1e-3 * m, "{e} vs {m}");
    }
}
