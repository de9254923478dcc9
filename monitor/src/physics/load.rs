//! The pantograph load on the cylinder, derived from the crane's geometry by
//! the Lagrangian of thesis §5.2 with the piston position x as the single
//! generalised coordinate.
//!
//! Each rod's centre of mass moves on a path p(x) fixed by the two angle
//! fits θ1(x), θ2(x) (eqs. 5.4–5.5, in degrees). With T = ½·M(x)·ẋ² and
//! V = G-potential, Lagrange's equation gives the force the cylinder must
//! deliver:
//!
//! F = M(x)·ẍ + ½·M'(x)·ẋ² + G(x),
//! M(x) = Σ m_i·|p_i'(x)|² + I_i·θ_i'(x)², G(x) = Σ m_i·g·y_i'(x).
//!
//! These are the c1, c2, c3 of eq. 5.57, as functions of position (the
//! thesis' constant c3·x is not used, erratum 6). They are tabulated once,
//! in f64, when the monitor is built, and linearly interpolated per step:
//! no trigonometry on the 1 ms path.

use crate::params::Pantograph;
use crate::real::Real;

/// Number of table intervals over the stroke.
pub const LOAD_TABLE_INTERVALS: usize = 64;
const NODES: usize = LOAD_TABLE_INTERVALS + 1;

/// Inertia, velocity-squared and gravity terms at one position (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadTerms<T> {
    /// Effective moving mass M(x), kg.
    pub mass_kg: T,
    /// Velocity-squared coefficient ½·M'(x), kg/m.
    pub c2_kg_m: T,
    /// Gravity load G(x), N (positive opposes extension).
    pub gravity_n: T,
    /// dM/dx, kg/m.
    pub dmass: T,
    /// d(½M')/dx, kg/m².
    pub dc2: T,
    /// dG/dx, N/m.
    pub dgravity: T,
}

/// The load at one position, computed exactly (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactLoad {
    /// Effective moving mass M(x), kg.
    pub mass_kg: f64,
    /// Velocity-squared coefficient ½·M'(x), kg/m.
    pub c2_kg_m: f64,
    /// Gravity load G(x), N (positive opposes extension).
    pub gravity_n: f64,
}

/// Exact load terms at position `x_m` (f64, with trigonometry): used to
/// build the table and by the rig simulator.
pub fn load_terms_exact(geo: &Pantograph, x_m: f64) -> ExactLoad {
    let d2r = core::f64::consts::PI / 180.0;
    let [a1, b1] = geo.theta1_fit_deg;
    let [a2, b2, c2] = geo.theta2_fit_deg;
    let th1 = (a1 * x_m + b1) * d2r;
    let th1p = a1 * d2r;
    let th1pp = 0.0;
    let th2 = ((a2 * x_m + b2) * x_m + c2) * d2r;
    let th2p = (2.0 * a2 * x_m + b2) * d2r;
    let th2pp = 2.0 * a2 * d2r;
    let (s1, c1) = (libm::sin(th1), libm::cos(th1));
    let (s2, c2v) = (libm::sin(th2), libm::cos(th2));
    // A link of length d at angle θ(x): position d·(cos θ, sin θ),
    // first and second derivatives w.r.t. x.
    let link = |d: f64, s: f64, c: f64, tp: f64, tpp: f64| -> ([f64; 2], [f64; 2]) {
        let v = [-d * s * tp, d * c * tp];
        let a = [
            -d * c * tp * tp - d * s * tpp,
            -d * s * tp * tp + d * c * tpp,
        ];
        (v, a)
    };
    let on1 = |d: f64| link(d, s1, c1, th1p, th1pp);
    let on2 = |d: f64| link(d, s2, c2v, th2p, th2pp);
    let sum = |parts: &[([f64; 2], [f64; 2])]| {
        let mut v = [0.0; 2];
        let mut a = [0.0; 2];
        for (pv, pa) in parts {
            v[0] += pv[0];
            v[1] += pv[1];
            a[0] += pa[0];
            a[1] += pa[1];
        }
        (v, a)
    };
    // Centre-of-mass paths (eqs. 5.11, 5.34, 5.43, 5.23); the constant
    // base offset has no derivative. Angle of each rod: rods 1 and 3 turn
    // with θ1, rods 2.1 and 2.2 with θ2.
    let bodies = [
        (
            sum(&[on2(geo.r21_to_r1_m), on1(geo.r1_to_cg1_m)]),
            th1p,
            th1pp,
        ),
        (sum(&[on2(geo.r21_to_cg21_m)]), th2p, th2pp),
        (
            sum(&[
                on2(geo.r21_to_r1_m),
                on1(geo.r1_to_r22_m),
                on2(geo.r22_to_cg22_m),
            ]),
            th2p,
            th2pp,
        ),
        (
            sum(&[on2(geo.r21_to_r3_m), on1(geo.r3_to_cg3_m)]),
            th1p,
            th1pp,
        ),
    ];
    let mut m = 0.0;
    let mut dm = 0.0;
    let mut g = 0.0;
    for (i, ((v, a), tp, tpp)) in bodies.iter().enumerate() {
        let mass = geo.masses_kg[i];
        let inertia = geo.inertias_kg_m2[i];
        m += mass * (v[0] * v[0] + v[1] * v[1]) + inertia * tp * tp;
        dm += 2.0 * mass * (v[0] * a[0] + v[1] * a[1]) + 2.0 * inertia * tp * tpp;
        g += mass * geo.gravity_m_s2 * v[1];
    }
    let m = m * geo.inertia_scale;
    let dm = dm * geo.inertia_scale;
    let g = g * geo.gravity_scale + geo.force_offset_n;
    ExactLoad {
        mass_kg: m,
        c2_kg_m: 0.5 * dm,
        gravity_n: g,
    }
}

/// The load terms tabulated over the stroke.
#[derive(Clone, Debug)]
pub struct LoadTable<T> {
    x0: T,
    inv_dx: T,
    mass: [T; NODES],
    c2: [T; NODES],
    gravity: [T; NODES],
}

impl<T: Real> LoadTable<T> {
    /// Tabulate the load of `geo` over `[0, stroke_m]`.
    pub fn new(geo: &Pantograph, stroke_m: f64) -> Self {
        let dx = stroke_m / LOAD_TABLE_INTERVALS as f64;
        let mut mass = [T::ZERO; NODES];
        let mut c2 = [T::ZERO; NODES];
        let mut gravity = [T::ZERO; NODES];
        for i in 0..NODES {
            let t = load_terms_exact(geo, i as f64 * dx);
            mass[i] = T::c(t.mass_kg);
            c2[i] = T::c(t.c2_kg_m);
            gravity[i] = T::c(t.gravity_n);
        }
        Self {
            x0: T::ZERO,
            inv_dx: T::c(1.0 / dx),
            mass,
            c2,
            gravity,
        }
    }

    /// Interpolated terms and their slopes at position `x_m` (clamped to
    /// the stroke).
    #[inline]
    pub fn at(&self, x_m: T) -> LoadTerms<T> {
        let u =
            ((x_m - self.x0) * self.inv_dx).clamp_to(T::ZERO, T::c(LOAD_TABLE_INTERVALS as f64));
        // Truncation of a value in [0, 64]: the index is in range.
        let mut i = to_index(u);
        if i >= LOAD_TABLE_INTERVALS {
            i = LOAD_TABLE_INTERVALS - 1;
        }
        let frac = u - T::from_f32(i as f32);
        let lerp = |tab: &[T; NODES]| {
            let slope = tab[i + 1] - tab[i];
            (tab[i] + slope * frac, slope * self.inv_dx)
        };
        let (mass_kg, dmass) = lerp(&self.mass);
        let (c2_kg_m, dc2) = lerp(&self.c2);
        let (gravity_n, dgravity) = lerp(&self.gravity);
        LoadTerms {
            mass_kg,
            c2_kg_m,
            gravity_n,
            dmass,
            dc2,
            dgravity,
        }
    }
}

/// ⌊u⌋ for u ∈ [0, 64], without f64 (software arithmetic on the MCU):
/// the cast truncates an f32 in one instruction. For T = f64, rounding u
/// to f32 can carry it up to the next integer, never below ⌊u⌋: step back
/// then.
#[inline(always)]
fn to_index<T: Real>(u: T) -> usize {
    let i = u.to_f32() as usize;
    if T::from_f32(i as f32) > u {
        i - 1
    } else {
        i
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geo() -> Pantograph {
        Pantograph::NOMINAL
    }

    #[test]
    fn gravity_is_nearly_constant_over_the_stroke() {
        // §7.1: the gravity force is almost constant (≈ 3.3–3.6 kN here),
        // and the static load at 41 mm matches the example recording's
        // pressures (21.4 bar × A_p − 12.95 bar × A_r = 3.55 kN) within
        // the ±480 N Coulomb friction band.
        let mut lo = f64::MAX;
        let mut hi = f64::MIN;
        for i in 0..=18 {
            let g = load_terms_exact(&geo(), i as f64 * 0.01).gravity_n;
            lo = lo.min(g);
            hi = hi.max(g);
        }
        assert!(lo > 3000.0 && hi < 3800.0, "{lo} .. {hi}");
        assert!((hi - lo) / lo < 0.1);
        let g = load_terms_exact(&geo(), 0.0412).gravity_n;
        let f = 21.4e5 * 3.117e-3 - 12.95e5 * 2.41e-3;
        assert!(
            (f - g).abs() < 480.0,
            "static load {g} vs hydraulic force {f}"
        );
    }

    #[test]
    fn c2_is_half_the_mass_derivative() {
        let h = 1e-6;
        for i in 1..18 {
            let x = i as f64 * 0.01;
            let t = load_terms_exact(&geo(), x);
            let dm = (load_terms_exact(&geo(), x + h).mass_kg
                - load_terms_exact(&geo(), x - h).mass_kg)
                / (2.0 * h);
            assert!((t.c2_kg_m - 0.5 * dm).abs() < 1e-3 * t.mass_kg, "x={x}");
        }
    }

    #[test]
    fn energy_is_conserved_without_damping() {
        // Free motion under F = 0 must conserve ½Mẋ² + V(x); V' = G.
        // Checks that c2 = ½M' has the right sign and size.
        let g = geo();
        let (mut x, mut v) = (0.05_f64, 0.2_f64);
        let pot = |x: f64| {
            // ∫ G dx by Simpson from 0.
            let n = 200;
            let h = x / n as f64;
            let mut s = 0.0;
            for k in 0..=n {
                let w = if k == 0 || k == n {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                s += w * load_terms_exact(&g, k as f64 * h).gravity_n;
            }
            s * h / 3.0
        };
        let energy = |x: f64, v: f64| 0.5 * load_terms_exact(&g, x).mass_kg * v * v + pot(x);
        let e0 = energy(x, v);
        let acc = |x: f64, v: f64| {
            let t = load_terms_exact(&g, x);
            -(t.c2_kg_m * v * v + t.gravity_n) / t.mass_kg
        };
        let h = 1e-4;
        for _ in 0..500 {
            // RK4 on (x, v).
            let (k1x, k1v) = (v, acc(x, v));
            let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
            let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
            let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
            x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        }
        let e1 = energy(x, v);
        assert!((e1 - e0).abs() < 1e-6 * e0.abs().max(1.0), "{e0} -> {e1}");
    }

    #[test]
    fn index_is_the_floor_in_either_precision() {
        for k in 0..=64u32 {
            let n = k as f64;
            for u in [n, n + 1e-12, n - 1e-12, n + 0.5, n - 0.5] {
                if (0.0..=64.0).contains(&u) {
                    assert_eq!(to_index(u), libm::floor(u) as usize, "f64 {u}");
                }
            }
            let n = k as f32;
            for u in [
                n,
                n + 0.25,
                n - 0.25,
                f32::from_bits(n.to_bits().wrapping_sub(1)),
            ] {
                if (0.0..=64.0).contains(&u) {
                    assert_eq!(to_index(u), libm::floorf(u) as usize, "f32 {u}");
                }
            }
        }
    }

    #[test]
    fn table_matches_exact_terms() {
        let tab = LoadTable::<f32>::new(&geo(), 0.18);
        for i in 0..=180 {
            let x = i as f64 * 0.001;
            let e = load_terms_exact(&geo(), x);
            let t = tab.at(x as f32);
            assert!(
                ((t.mass_kg as f64) - e.mass_kg).abs() < 2e-3 * e.mass_kg,
                "M at {x}"
            );
            assert!(((t.gravity_n as f64) - e.gravity_n).abs() < 1.0, "G at {x}");
            assert!(
                ((t.c2_kg_m as f64) - e.c2_kg_m).abs() < 60.0,
                "c2 at {x}: {} vs {}",
                t.c2_kg_m,
                e.c2_kg_m
            );
        }
        // Clamped outside the stroke.
        assert_eq!(tab.at(-1.0), tab.at(0.0));
        assert_eq!(tab.at(1.0), tab.at(0.18));
    }
}
