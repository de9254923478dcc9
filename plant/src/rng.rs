//! Deterministic random streams. Every stream is a ChaCha8 generator seeded
//! from a (seed, stream tag) pair, so adding a draw to one model never shifts
//! the draws of another.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
pub(crate) fn mix(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random stream with the draws the models need.
pub(crate) struct Rand(ChaCha8Rng);

impl Rand {
    /// The stream `stream` of `seed`.
    pub(crate) fn new(seed: u64, stream: u64) -> Self {
        Self(ChaCha8Rng::seed_from_u64(mix(seed, stream)))
    }

    /// Uniform in [a, b).
    pub(crate) fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.0.random::<f64>()
    }

    /// Log-uniform in [a, b) (a, b > 0).
    pub(crate) fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
        self.uniform(a.ln(), b.ln()).exp()
    }

    /// Standard normal.
    pub(crate) fn normal(&mut self) -> f64 {
        self.0.sample(StandardNormal)
    }

    /// True with probability `p`.
    pub(crate) fn chance(&mut self, p: f64) -> bool {
        self.0.random::<f64>() < p
    }

    /// ±1 with equal probability.
    pub(crate) fn sign(&mut self) -> f64 {
        if self.chance(0.5) {
            1.0
        } else {
            -1.0
        }
    }

    /// Integer in [lo, hi] inclusive.
    pub(crate) fn int(&mut self, lo: u32, hi: u32) -> u32 {
        self.0.random_range(lo..=hi)
    }
}

/// Stream tags (one per model), so draws stay independent.
pub(crate) mod stream {
    pub const LOAD: u64 = 1;
    pub const CYLINDER: u64 = 2;
    pub const FLUID: u64 = 3;
    pub const VALVE: u64 = 4;
    pub const FRICTION: u64 = 5;
    pub const SUPPLY: u64 = 6;
    pub const SENSORS: u64 = 7;
    pub const CONTROLLER: u64 = 8;
    pub const PROFILE: u64 = 20;
    pub const RUN_PHYSICS: u64 = 30;
    pub const NOISE: u64 = 31;
    pub const FAULTS: u64 = 32;
}
