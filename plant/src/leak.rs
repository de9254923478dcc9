//! The faults the monitor must find: an internal leak (piston seal,
//! piston chamber → rod chamber) and an external leak (rod-side line →
//! tank). The flow law of a run is laminar, orifice or a mix, drawn from
//! the run's noise seed; its coefficient is scaled so that the realised
//! mean flow after onset matches the request (see `simulate`).
//!
//! Flows are signed in the leak's nominal direction: a seal leaks either
//! way according to the pressure difference, so the internal leak is
//! negative while the rod chamber is above the piston chamber.

use serde::{Deserialize, Serialize};

use crate::rng::Rand;
use crate::valve::LPM;

/// Reference pressure drop at which the laminar and orifice parts of a
/// mixed law are weighted as given, bar.
pub const MIX_REFERENCE_DP_BAR: f64 = 30.0;

/// The flow law of the leaks of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum LeakLaw {
    /// Q = c·Δp·(ν_ref/ν) (a long narrow gap).
    Laminar,
    /// Q = c·Δp/(Δp² + Δp_t²)^¼ (a sharp hole; √Δp above Δp_t).
    Orifice {
        /// Laminar transition, bar.
        transition_bar: f64,
    },
    /// `w`·laminar + (1 − `w`)·orifice, each normalised to the same flow at
    /// [`MIX_REFERENCE_DP_BAR`].
    Mix {
        /// Laminar weight 0..1.
        laminar_weight: f64,
        /// Laminar transition of the orifice part, bar.
        transition_bar: f64,
    },
}

impl LeakLaw {
    pub(crate) fn random(r: &mut Rand) -> Self {
        let t = r.uniform(0.2, 1.0);
        match r.int(0, 2) {
            0 => Self::Laminar,
            1 => Self::Orifice { transition_bar: t },
            _ => Self::Mix {
                laminar_weight: r.uniform(0.2, 0.8),
                transition_bar: t,
            },
        }
    }

    /// Flow per unit coefficient at `dp` (bar), fluidity `nu_ref/nu`:
    /// dimension "l/min at the reference", the coefficient is l/min.
    #[inline]
    pub fn shape(&self, dp: f64, fluidity: f64) -> f64 {
        let lam = dp / MIX_REFERENCE_DP_BAR * fluidity;
        let orf = |t: f64| dp / (dp * dp + t * t).sqrt().sqrt() / MIX_REFERENCE_DP_BAR.sqrt();
        match *self {
            Self::Laminar => lam,
            Self::Orifice { transition_bar } => orf(transition_bar),
            Self::Mix {
                laminar_weight,
                transition_bar,
            } => laminar_weight * lam + (1.0 - laminar_weight) * orf(transition_bar),
        }
    }

    /// Flow, m³/s, for coefficient `c_lpm` (l/min at the reference drop).
    #[inline]
    pub fn flow(&self, c_lpm: f64, dp: f64, fluidity: f64) -> f64 {
        c_lpm * self.shape(dp, fluidity) * LPM
    }
}
