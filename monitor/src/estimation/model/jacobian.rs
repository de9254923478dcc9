//! The model's linearisation: the operating-point entries of ∂f/∂s, with f, as one evaluation.

use super::NX;

/// The nonzero entries of ∂f/∂s (scaled state s, scaled derivative f) that
/// depend on the operating point. Constant entries (ṡ_xp = ṡ_v, the spool
/// block) live in [`Plant`](super::Plant).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[allow(missing_docs)]
pub struct Jacobian<T> {
    pub v_x: T,
    pub v_v: T,
    pub v_p3: T,
    pub v_p4: T,
    pub p3_x: T,
    pub p3_v: T,
    pub p3_xv: T,
    pub p3_p3: T,
    pub p3_p4: T,
    /// ∂ṗ3/∂θ_i (scaled).
    pub p3_li: T,
    pub p4_x: T,
    pub p4_v: T,
    pub p4_xv: T,
    pub p4_p3: T,
    pub p4_p4: T,
    /// ∂ṗ4/∂θ_i (scaled).
    pub p4_li: T,
    /// ∂ṗ4/∂θ_e (scaled).
    pub p4_le: T,
    /// ∂ṗ3/∂gain_extend (scaled).
    pub p3_ge: T,
    /// ∂ṗ4/∂gain_extend (scaled).
    pub p4_ge: T,
    /// ∂ṗ3/∂gain_retract (scaled).
    pub p3_gr: T,
    /// ∂ṗ4/∂gain_retract (scaled).
    pub p4_gr: T,
    /// ∂ṗ3/∂laminar (scaled).
    pub p3_lam: T,
    /// ∂ṗ4/∂laminar (scaled).
    pub p4_lam: T,
}

/// The model evaluated at one state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Eval<T> {
    /// Time derivative of the scaled state, 1/s.
    pub f: [T; NX],
    /// Its Jacobian.
    pub jac: Jacobian<T>,
    /// Internal leak flow beyond the healthy seal leakage, m³/s.
    pub q_internal: T,
    /// External leak flow beyond the healthy baseline, m³/s.
    pub q_external: T,
    /// Metering flow through the valve into the piston chamber, m³/s.
    pub q_valve_a: T,
}
