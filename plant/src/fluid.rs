//! The oil: viscosity against temperature (Walther / ASTM D341 form) and an
//! effective bulk modulus with entrained air (polytropic gas in series with
//! the liquid) plus hose wall compliance.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;

/// Atmospheric pressure, bar (absolute).
pub const P_ATM_BAR: f64 = 1.013;

/// Oil and entrained air of one rig.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FluidSpec {
    /// Kinematic viscosity at 40 °C, cSt (ISO VG 46 ±15 %).
    pub viscosity_40c_cst: f64,
    /// Viscosity ratio ν(25 °C)/ν(40 °C) (1.8–2.2: "halves from 25 to 40").
    pub viscosity_ratio_25_40: f64,
    /// Bulk modulus of the air-free liquid, bar (16000 ±15 %).
    pub bulk_modulus_bar: f64,
    /// Free air volume fraction at atmospheric pressure (0.2–3 %).
    pub air_fraction: f64,
    /// Polytropic exponent of the air bubbles (1.0 isothermal … 1.4
    /// adiabatic).
    pub polytropic_exponent: f64,
}

impl FluidSpec {
    pub(crate) fn random(r: &mut Rand) -> Self {
        Self {
            viscosity_40c_cst: 46.0 * r.uniform(0.85, 1.15),
            viscosity_ratio_25_40: r.uniform(1.8, 2.2),
            bulk_modulus_bar: 16_000.0 * r.uniform(0.85, 1.15),
            air_fraction: r.log_uniform(0.002, 0.03),
            polytropic_exponent: r.uniform(1.0, 1.4),
        }
    }

    /// Walther constants (A, B) of log10 log10(ν + 0.7) = A − B·log10(T/K),
    /// through the two points ν(40 °C) and ν(25 °C).
    fn walther(&self) -> (f64, f64) {
        let w = |nu: f64| (nu + 0.7).log10().log10();
        let (t25, t40) = (298.15f64.log10(), 313.15f64.log10());
        let nu25 = self.viscosity_40c_cst * self.viscosity_ratio_25_40;
        let b = (w(nu25) - w(self.viscosity_40c_cst)) / (t40 - t25);
        (w(self.viscosity_40c_cst) + b * t40, b)
    }

    /// Kinematic viscosity at `temp_c`, cSt.
    pub fn viscosity_cst(&self, temp_c: f64) -> f64 {
        let (a, b) = self.walther();
        let lhs = a - b * (temp_c + 273.15).log10();
        10f64.powf(10f64.powf(lhs)) - 0.7
    }

    /// Effective bulk modulus of oil with air at gauge pressure `p_bar`, bar.
    /// Per unit volume at atmospheric pressure: liquid `1 − ε` with
    /// compressibility `1/β_l`, gas `ε·(p_atm/p)^(1/n)` with compressibility
    /// `1/(n·p)`; the mixture's modulus is total volume over total
    /// `dV/dp`. It falls to a few bar near vacuum (cavitation-like).
    #[inline]
    pub fn bulk_modulus_bar(&self, p_bar: f64) -> f64 {
        let pa = (p_bar + P_ATM_BAR).max(0.02);
        let n = self.polytropic_exponent;
        // exp/ln: several times cheaper than powf.
        let vg = self.air_fraction * ((P_ATM_BAR.ln() - pa.ln()) / n).exp();
        let vl = 1.0 - self.air_fraction;
        (vl + vg) / (vl / self.bulk_modulus_bar + vg / (n * pa))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viscosity_passes_through_its_two_points_and_falls_with_temperature() {
        let f = FluidSpec {
            viscosity_40c_cst: 46.0,
            viscosity_ratio_25_40: 2.0,
            bulk_modulus_bar: 16000.0,
            air_fraction: 0.01,
            polytropic_exponent: 1.4,
        };
        assert!((f.viscosity_cst(40.0) - 46.0).abs() < 1e-6);
        assert!((f.viscosity_cst(25.0) - 92.0).abs() < 1e-6);
        assert!(f.viscosity_cst(60.0) < f.viscosity_cst(40.0));
    }

    #[test]
    fn air_softens_the_oil_at_low_pressure_only() {
        let f = FluidSpec {
            viscosity_40c_cst: 46.0,
            viscosity_ratio_25_40: 2.0,
            bulk_modulus_bar: 16000.0,
            air_fraction: 0.01,
            polytropic_exponent: 1.4,
        };
        assert!(f.bulk_modulus_bar(100.0) > 14_000.0);
        assert!(f.bulk_modulus_bar(2.0) < 3_000.0);
        assert!(f.bulk_modulus_bar(-1.0) < 50.0);
    }
}
