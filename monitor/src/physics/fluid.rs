//! Oil properties: pressure-dependent effective bulk modulus and the
//! temperature dependence of laminar leakage.

use crate::params::Fluid;
use crate::physics::units::BAR;
use crate::real::Real;

const INTERVALS: usize = 64;
const NODES: usize = INTERVALS + 1;
/// Lowest absolute pressure of the table, Pa (near vacuum).
const P_LO_ABS: f64 = 0.1 * BAR;
/// Highest absolute pressure of the table, Pa.
const P_HI_ABS: f64 = 400.0 * BAR;

/// Effective bulk modulus of oil with entrained air at gauge pressure
/// `p_gauge_pa`, Pa. Thesis eqs. 6.9–6.10 written correctly (erratum 4):
/// ε(p) = ε₀·(p_atm/p)^(1/κ) / ((1 − ε₀) + ε₀·(p_atm/p)^(1/κ)),
/// 1/β = 1/β_oil + ε(p)/(κ·p), pressures absolute.
pub fn bulk_modulus_exact(fluid: &Fluid, p_gauge_pa: f64) -> f64 {
    let p_atm = fluid.atmospheric_pressure_bar * BAR;
    let p_abs = (p_gauge_pa + p_atm).max(P_LO_ABS);
    let e0 = fluid.air_fraction;
    let beta_oil = fluid.bulk_modulus_bar * BAR;
    if e0 <= 0.0 {
        return beta_oil;
    }
    let expansion = libm::pow(p_atm / p_abs, 1.0 / fluid.adiabatic_index);
    let eps = e0 * expansion / ((1.0 - e0) + e0 * expansion);
    1.0 / (1.0 / beta_oil + eps / (fluid.adiabatic_index * p_abs))
}

/// The bulk modulus tabulated over pressure, on a grid that is dense at low
/// pressure where entrained air makes it change fastest (node pressures
/// grow with the cube of the node index).
#[derive(Clone, Debug)]
pub struct BulkModulusTable<T> {
    p_node: [T; NODES],
    beta: [T; NODES],
    slope: [T; INTERVALS],
}

impl<T: Real> BulkModulusTable<T> {
    /// Tabulate `fluid`'s bulk modulus.
    pub fn new(fluid: &Fluid) -> Self {
        let p_atm = fluid.atmospheric_pressure_bar * BAR;
        let mut p_node = [T::ZERO; NODES];
        let mut beta = [T::ZERO; NODES];
        let mut slope = [T::ZERO; INTERVALS];
        let mut p64 = [0.0f64; NODES];
        let mut b64 = [0.0f64; NODES];
        for i in 0..NODES {
            let u = i as f64 / INTERVALS as f64;
            p64[i] = P_LO_ABS + (P_HI_ABS - P_LO_ABS) * u * u * u - p_atm;
            b64[i] = bulk_modulus_exact(fluid, p64[i]);
            p_node[i] = T::c(p64[i]);
            beta[i] = T::c(b64[i]);
        }
        for i in 0..INTERVALS {
            slope[i] = T::c((b64[i + 1] - b64[i]) / (p64[i + 1] - p64[i]));
        }
        Self {
            p_node,
            beta,
            slope,
        }
    }

    /// The interval of `p` ∈ [p_node[0], p_node[64]]: the largest i ≤ 63
    /// with p_node[i] ≤ p. Binary search in six fixed halving steps
    /// (32, 16, …, 1), each a compare and a conditional add that the
    /// compiler unrolls without branches: no roots, and about half the
    /// instructions of a loop that narrows [lo, hi].
    #[inline(always)]
    fn interval(&self, p: T) -> usize {
        const { assert!(INTERVALS.is_power_of_two()) };
        let mut lo = 0;
        let mut half = INTERVALS / 2;
        while half > 0 {
            if p >= self.p_node[lo + half] {
                lo += half;
            }
            half /= 2;
        }
        lo
    }

    /// Bulk modulus (Pa) and its derivative dβ/dp (1) at gauge pressure
    /// `p_gauge_pa` (clamped to the table).
    #[inline]
    pub fn at(&self, p_gauge_pa: T) -> (T, T) {
        let p = p_gauge_pa.clamp_to(self.p_node[0], self.p_node[INTERVALS]);
        let i = self.interval(p);
        let s = self.slope[i];
        (self.beta[i] + s * (p - self.p_node[i]), s)
    }
}

/// How much more easily oil flows through a laminar gap at `temp_c` than at
/// the reference temperature: ν(T_ref)/ν(T) = exp(k·(T − T_ref)).
pub fn laminar_flow_factor(fluid: &Fluid, temp_c: f64) -> f64 {
    let dt = (temp_c - fluid.reference_temperature_c).clamp(-40.0, 80.0);
    libm::exp(fluid.viscosity_temperature_coeff_per_c * dt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn air_softens_oil_at_low_pressure() {
        let f = Fluid::NOMINAL;
        let b5 = bulk_modulus_exact(&f, 5.0 * BAR);
        let b50 = bulk_modulus_exact(&f, 50.0 * BAR);
        let b200 = bulk_modulus_exact(&f, 200.0 * BAR);
        assert!(b5 < b50 && b50 < b200 && b200 < f.bulk_modulus_bar * BAR);
        assert!(b5 < 0.5 * f.bulk_modulus_bar * BAR);
        let no_air = Fluid {
            air_fraction: 0.0,
            ..Fluid::NOMINAL
        };
        assert_eq!(
            bulk_modulus_exact(&no_air, 5.0 * BAR),
            no_air.bulk_modulus_bar * BAR
        );
    }

    #[test]
    fn table_is_within_one_percent() {
        for air in [0.005, 0.01, 0.03] {
            let f = Fluid {
                air_fraction: air,
                ..Fluid::NOMINAL
            };
            let tab = BulkModulusTable::<f32>::new(&f);
            let mut p = -0.5 * BAR;
            while p < 300.0 * BAR {
                let exact = bulk_modulus_exact(&f, p);
                let (b, _) = tab.at(p as f32);
                // Below 1 bar gauge the oil is near cavitation: 5 % is enough.
                let tol = if p < 1.0 * BAR { 0.05 } else { 0.01 };
                assert!(
                    ((b as f64) - exact).abs() < tol * exact,
                    "air {air} p {p}: {b} vs {exact}"
                );
                p += 0.37 * BAR;
            }
        }
    }

    #[test]
    fn interval_is_the_one_a_plain_search_finds() {
        let tab = BulkModulusTable::<f32>::new(&Fluid::NOMINAL);
        let plain = |p: f32| (0..INTERVALS).rev().find(|&i| p >= tab.p_node[i]).unwrap();
        for i in 0..=INTERVALS {
            let node = tab.p_node[i];
            let below = f32::from_bits(node.to_bits() - 1);
            let above = f32::from_bits(node.to_bits() + 1);
            for p in [below, node, above] {
                let p = p.clamp_to(tab.p_node[0], tab.p_node[INTERVALS]);
                assert_eq!(tab.interval(p), plain(p), "node {i}, p {p}");
            }
        }
    }

    #[test]
    fn table_slope_is_the_derivative() {
        let f = Fluid::NOMINAL;
        let tab = BulkModulusTable::<f64>::new(&f);
        for p_bar in [2.0, 10.0, 30.0, 80.0, 150.0] {
            let p = p_bar * BAR;
            let h = 0.01 * BAR;
            let fd = (bulk_modulus_exact(&f, p + h) - bulk_modulus_exact(&f, p - h)) / (2.0 * h);
            let (_, s) = tab.at(p);
            assert!(
                (s - fd).abs() < 0.1 * fd.abs() + 1.0,
                "p {p_bar}: {s} vs {fd}"
            );
        }
    }

    #[test]
    fn warm_oil_leaks_more() {
        let f = Fluid::NOMINAL;
        assert_eq!(laminar_flow_factor(&f, 25.0), 1.0);
        let k40 = laminar_flow_factor(&f, 40.0);
        assert!(k40 > 1.8 && k40 < 2.2, "{k40}");
    }
}
