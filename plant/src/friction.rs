//! Cylinder (seal and guide) friction. Each rig has one of two laws:
//! - LuGre: bristle deflection `z`, `ż = v − σ0·|v|·z/g(v)`,
//!   `F = σ0·z + σ1·ż + B·v`, `g(v) = Fc + (Fs − Fc)·e^(−(v/vs)²)`;
//! - Karnopp stick–slip with a Stribeck curve: inside a small velocity
//!   window the friction balances the applied force up to breakaway (and
//!   brings the piston to rest); outside, `F = g(v)·sign(v) + B·v` with
//!   `g(v) = Fc + (Fs − Fc)·e^(−|v/vs|^δ)`.
//!
//! The viscous part B scales with oil viscosity as `(ν/ν_ref)^e`.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// Which friction law a rig has.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum FrictionLaw {
    /// LuGre bristle model.
    LuGre {
        /// Bristle stiffness σ0, N/m (3e6–2e7).
        stiffness_n_per_m: f64,
        /// Bristle damping σ1, N·s/m.
        damping_ns_per_m: f64,
    },
    /// Karnopp stick–slip with Stribeck.
    Karnopp {
        /// Half-width of the stick window, m/s (0.05–0.3 mm/s).
        window_m_s: f64,
        /// Stribeck exponent δ (1–2).
        stribeck_exponent: f64,
    },
}

/// One rig's friction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrictionSpec {
    /// The law.
    pub law: FrictionLaw,
    /// Coulomb level Fc, N (300–700).
    pub coulomb_n: f64,
    /// Breakaway (static) level Fs, N (1.2–2.5 × Fc).
    pub breakaway_n: f64,
    /// Stribeck velocity vs, m/s (2–20 mm/s).
    pub stribeck_m_s: f64,
    /// Viscous coefficient B at the reference temperature (25 °C),
    /// N·s/m (2000–8000).
    pub viscous_ns_per_m: f64,
    /// Exponent e of B ∝ (ν/ν_ref)^e (0.3–0.8).
    pub viscous_viscosity_exponent: f64,
}

/// Time constant with which Karnopp stiction brings a stuck piston to rest, s.
const STICK_TAU_S: f64 = 0.002;

impl FrictionSpec {
    pub(crate) fn random(r: &mut Rand, nominal_mass_kg: f64) -> Self {
        let coulomb_n = r.uniform(300.0, 700.0);
        let law = if r.chance(0.5) {
            let s0 = r.log_uniform(3e6, 2e7);
            let zeta = r.uniform(0.1, 0.6);
            FrictionLaw::LuGre {
                stiffness_n_per_m: s0,
                damping_ns_per_m: 2.0 * zeta * (s0 * nominal_mass_kg).sqrt(),
            }
        } else {
            FrictionLaw::Karnopp {
                window_m_s: r.uniform(5e-5, 3e-4),
                stribeck_exponent: r.uniform(1.0, 2.0),
            }
        };
        Self {
            law,
            coulomb_n,
            breakaway_n: coulomb_n * r.uniform(1.2, 2.5),
            stribeck_m_s: r.uniform(0.002, 0.02),
            viscous_ns_per_m: r.uniform(2000.0, 8000.0),
            viscous_viscosity_exponent: r.uniform(0.3, 0.8),
        }
    }

    /// Friction force, N (opposing motion), and the bristle rate ż (m/s; 0
    /// for Karnopp), at velocity `v` (m/s), bristle state `z` (m), applied
    /// non-friction force `f_app` (N), effective mass `m` (kg) and viscous
    /// coefficient `b` (N·s/m, temperature-corrected).
    #[inline]
    pub fn force(&self, v: f64, z: f64, f_app: f64, m: f64, b: f64) -> (f64, f64) {
        let dfs = self.breakaway_n - self.coulomb_n;
        match self.law {
            FrictionLaw::LuGre {
                stiffness_n_per_m: s0,
                damping_ns_per_m: s1,
            } => {
                let r = v / self.stribeck_m_s;
                let g = self.coulomb_n + dfs * (-r * r).exp();
                let zd = v - s0 * v.abs() * z / g;
                (s0 * z + s1 * zd + b * v, zd)
            }
            FrictionLaw::Karnopp {
                window_m_s,
                stribeck_exponent,
            } => {
                if v.abs() < window_m_s {
                    let f =
                        (f_app + m * v / STICK_TAU_S).clamp(-self.breakaway_n, self.breakaway_n);
                    (f, 0.0)
                } else {
                    let g = self.coulomb_n
                        + dfs
                            * (-((v.abs() / self.stribeck_m_s).ln() * stribeck_exponent).exp())
                                .exp();
                    (g * v.signum() + b * v, 0.0)
                }
            }
        }
    }
}
