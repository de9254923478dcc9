//! Frozen readings: a sensor (or a logger, or a gateway that repeats the
//! last value) whose reading stops changing.
//!
//! A frozen position reading is the dangerous case: with the valve open the
//! oil goes somewhere, and if the piston "does not move" the filters can
//! only explain it by a leak. The test is deliberately plain — the reading
//! is **bit-identical** for a while — and it only fires where a live
//! reading could not be: a recording written with coarse resolution and no
//! noise legitimately repeats a value through every hold, and must never
//! turn a healthy cylinder into a "sensor fault".
//!
//! A reading is frozen when it has not changed for
//! - longer than [`NOISE_FACTOR`] × the longest run of identical readings
//!   this channel has shown so far (at least [`REST_MIN_S`]), once its
//!   completed runs include [`LEARN_S`] with the valve not feeding: a
//!   channel whose noise changed it every few samples, at rest too, has
//!   stopped. A noise-free channel repeats its value through a hold; that
//!   run, once over, sets the bar so high that the test never fires for it;
//! - or, for the position, [`FROZEN_S`] during which the valve fed the
//!   piston for [`FEEDING_MIN_S`] (open beyond its dead zone by
//!   [`OPENING_MIN`], [`METERING_DROP_MIN_BAR`] across the feeding edge,
//!   away from the end stops): the piston must then have moved by
//!   millimetres, noise or not;
//! - or, for a chamber pressure, [`FROZEN_S`] during which the position
//!   reading travelled [`TRAVEL_MIN_M`], once learnt as above and longer
//!   than [`TRAVEL_NOISE_FACTOR`] × its longest run (a noise-free steady
//!   move of a constant load may hold a pressure on one code).
//!
//! Long before a channel is declared frozen it is **suspect**: a run
//! [`SUSPECT_FACTOR`] × its longest (at least [`SUSPECT_MIN_S`]), or a
//! position unchanged through [`SUSPECT_FEEDING_S`] of feeding. A suspect
//! sample is not leak evidence (the monitor pauses its decision and the
//! leak states' learning), so a frozen position cannot raise a leak alarm
//! in the second it takes to prove the freeze.
//!
//! The channel recovers as soon as its reading changes. Supply and tank
//! pressure are steady by design and the valve command may legitimately be
//! constant: they are not tested.

use crate::physics::valve::spool_at;
use crate::real::Real;
use crate::sample::{Channel, Sample};

/// Rest time (valve not feeding) in completed runs before the noise-based
/// test applies, s.
pub const LEARN_S: f32 = 5.0;
/// A run this many times longer than the longest seen is a freeze.
pub const NOISE_FACTOR: f32 = 50.0;
/// Shortest run the noise-based test flags, s.
pub const REST_MIN_S: f32 = 0.5;
/// Shortest run the motion-based tests flag, s.
pub const FROZEN_S: f32 = 1.0;
/// Feeding time within a run that must move the piston, s.
pub const FEEDING_MIN_S: f32 = 0.5;
/// Valve opening beyond the dead zone that counts as open, fraction of
/// travel (≈ 0.3 l/min at 3 bar on the reference valve: millimetres per
/// second of piston speed).
pub const OPENING_MIN: f32 = 0.02;
/// Pressure drop across the feeding metering edge that counts as flow, bar.
pub const METERING_DROP_MIN_BAR: f32 = 3.0;
/// Distance from either end stop within which the piston may legitimately
/// stand still with the valve open, m.
pub const END_STOP_MARGIN_M: f32 = 0.003;
/// Position travel during which a chamber pressure should change, m.
pub const TRAVEL_MIN_M: f32 = 0.005;
/// For the travel test, a run this many times the longest seen.
pub const TRAVEL_NOISE_FACTOR: f32 = 10.0;

/// A run this many times the longest seen makes a channel suspect.
pub const SUSPECT_FACTOR: f32 = 10.0;
/// Shortest run that makes a channel suspect, s.
pub const SUSPECT_MIN_S: f32 = 0.05;
/// Feeding time without a change that makes the position suspect, s.
pub const SUSPECT_FEEDING_S: f32 = 0.1;

/// Channels found frozen, and channels suspected (`Channel::bit`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frozen {
    /// Frozen: a sensor fault.
    pub frozen: u8,
    /// Possibly frozen: not leak evidence.
    pub suspect: u8,
}

/// The channels tested, in the order of [`FrozenDetector`]'s runs.
const TESTED: [Channel; 3] = [Channel::PPiston, Channel::PRod, Channel::XPiston];

/// One channel's current run of identical readings and its history.
#[derive(Clone, Copy, Debug, Default)]
struct Run {
    /// The reading's bit pattern, `None` while the channel is missing.
    bits: Option<u32>,
    /// Position reading range during the run (pressure channels), m.
    x_min: f32,
    x_max: f32,
    /// Time the valve fed the piston during the run (position), s.
    feeding_s: f32,
    /// Time the valve did not feed the piston during the run, s. The run
    /// has lasted `feeding_s + resting_s`.
    resting_s: f32,
    /// Longest completed run so far, s.
    longest_s: f32,
    /// Rest time in completed runs so far, s.
    rest_s: f32,
}

/// The valve and stroke the feeding test needs (from the parameters).
#[derive(Clone, Copy, Debug)]
pub struct FrozenConfig {
    /// Stroke, m.
    pub stroke_m: f32,
    /// Valve dead zone, fraction of travel.
    pub dead_zone: f32,
    /// Valve null offset, fraction of travel.
    pub null_offset: f32,
}

/// Conditioned readings the feeding test uses (offsets removed, command
/// clamped), when every one of them is valid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Readings {
    /// Supply pressure, bar.
    pub p_supply_bar: f32,
    /// Piston-chamber pressure, bar.
    pub p_piston_bar: f32,
    /// Rod-chamber pressure, bar.
    pub p_rod_bar: f32,
    /// Piston position, m.
    pub x_piston_m: f32,
    /// Valve command, [-1, 1].
    pub u_valve: f32,
}

/// Tracks runs of identical readings and reports frozen channels.
#[derive(Clone, Debug)]
pub struct FrozenDetector {
    cfg: FrozenConfig,
    runs: [Run; 3],
}

impl FrozenDetector {
    /// A detector for `cfg`.
    pub fn new(cfg: FrozenConfig) -> Self {
        Self {
            cfg,
            runs: [Run::default(); 3],
        }
    }

    /// Whether the valve feeds the piston: open beyond the dead zone, a
    /// pressure drop across the feeding edge, away from the end stops.
    fn feeding(&self, r: &Readings) -> bool {
        let spool = spool_at(r.u_valve, self.cfg.null_offset);
        let opening = spool.abs() - self.cfg.dead_zone;
        // Extending feeds the piston chamber, retracting the rod chamber.
        let drop = r.p_supply_bar
            - if spool > 0.0 {
                r.p_piston_bar
            } else {
                r.p_rod_bar
            };
        opening >= OPENING_MIN
            && drop >= METERING_DROP_MIN_BAR
            && r.x_piston_m > END_STOP_MARGIN_M
            && r.x_piston_m < self.cfg.stroke_m - END_STOP_MARGIN_M
    }

    /// Update with the raw sample `s` (its bit patterns are compared), the
    /// time since the previous sample `dt_s` (the monitor's clock: 0 for
    /// the first sample and for one it ignores) and the conditioned
    /// `readings` (`None` if any of them is faulted). Returns the frozen
    /// and suspect channels.
    pub fn update(&mut self, s: &Sample, dt_s: f32, readings: Option<&Readings>) -> Frozen {
        let feeding = readings.is_some_and(|r| self.feeding(r));
        let x = s.x_piston_m;
        let mut out = Frozen::default();
        for (run, ch) in self.runs.iter_mut().zip(TESTED) {
            // The interval up to this sample belongs to the run it ends.
            if feeding {
                run.feeding_s += dt_s;
            } else {
                run.resting_s += dt_s;
            }
            let bits = s.get(ch).map(f32::to_bits);
            if bits.is_none() || bits != run.bits {
                if run.bits.is_some() {
                    run.longest_s = Real::max(run.longest_s, run.feeding_s + run.resting_s);
                    run.rest_s += run.resting_s;
                }
                *run = Run {
                    bits,
                    x_min: f32::INFINITY,
                    x_max: f32::NEG_INFINITY,
                    feeding_s: 0.0,
                    resting_s: 0.0,
                    ..*run
                };
            }
            if bits.is_none() {
                continue;
            }
            if let Some(x) = x {
                // A NaN reading leaves the range as it is. (`Real`'s
                // compare-and-select min/max: `f32::min`/`max` are calls
                // to `fminf`/`fmaxf` on the MCU.)
                run.x_min = Real::min(x, run.x_min);
                run.x_max = Real::max(x, run.x_max);
            }
            let held_s = run.feeding_s + run.resting_s;
            let noise = run.rest_s >= LEARN_S
                && held_s >= Real::max(REST_MIN_S, NOISE_FACTOR * run.longest_s);
            let motion = held_s >= FROZEN_S
                && match ch {
                    Channel::XPiston => run.feeding_s >= FEEDING_MIN_S,
                    _ => {
                        run.rest_s >= LEARN_S
                            && run.x_max - run.x_min >= TRAVEL_MIN_M
                            && held_s >= TRAVEL_NOISE_FACTOR * run.longest_s
                    }
                };
            if noise || motion {
                out.frozen |= ch.bit();
            }
            let suspect = (run.rest_s >= LEARN_S
                && held_s >= Real::max(SUSPECT_MIN_S, SUSPECT_FACTOR * run.longest_s))
                || (ch == Channel::XPiston && run.feeding_s >= SUSPECT_FEEDING_S);
            if suspect || noise || motion {
                out.suspect |= ch.bit();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One 1 kHz step of `d` with the sample's own readings (no offsets).
    fn update(d: &mut FrozenDetector, s: &Sample) -> Frozen {
        let readings = (|| {
            Some(Readings {
                p_supply_bar: s.p_supply_bar?,
                p_piston_bar: s.p_piston_bar?,
                p_rod_bar: s.p_rod_bar?,
                x_piston_m: s.x_piston_m?,
                u_valve: s.u_valve?,
            })
        })();
        let dt = if s.t_s == 0.0 { 0.0 } else { 1e-3 };
        d.update(s, dt, readings.as_ref())
    }

    fn cfg() -> FrozenConfig {
        FrozenConfig {
            stroke_m: 0.18,
            dead_zone: 0.015,
            null_offset: 0.0,
        }
    }

    /// Sample `k` (1 kHz) of a piston at `x` m, command `u`, pressures
    /// `p3`, `p4`, with `noise` LSB-scale jitter (0: none) and the
    /// resolution of the spec's example (0.01 bar, 0.1 mm).
    fn sample(k: u32, x: f32, u: f32, p3: f32, p4: f32, noise: f32) -> Sample {
        let j = (((k * 7919) % 5) as f32 - 2.0) * noise;
        let q = |v: f32, lsb: f32| (v / lsb).round() * lsb;
        Sample {
            t_s: k as f64 * 1e-3,
            p_supply_bar: Some(q(50.0 + 0.02 * j, 0.01)),
            p_piston_bar: Some(q(p3 + 0.03 * j, 0.01)),
            p_rod_bar: Some(q(p4 - 0.03 * j, 0.01)),
            p_tank_bar: Some(q(0.6 + 0.01 * j, 0.01)),
            x_piston_m: Some(q(x + 1e-4 * j, 1e-4)),
            u_valve: Some(u),
            temp_oil_c: None,
        }
    }

    /// A thesis-like cycle: hold 3 s, extend at 10 mm/s for 3 s (command
    /// 0.08, pressures drifting with the load), hold 4 s, retract.
    fn cycle(k: u32, noise: f32) -> Sample {
        let t = (k % 14_000) as f32 * 1e-3;
        let (x, u) = match t {
            t if t < 3.0 => (0.05, 0.003),
            t if t < 6.0 => (0.05 + 0.01 * (t - 3.0), 0.08),
            t if t < 10.0 => (0.08, 0.003),
            t => (0.08 - 0.0075 * (t - 10.0), -0.08),
        };
        let p3 = 25.0 + 20.0 * (x - 0.05);
        sample(k, x, u, p3, 12.0, noise)
    }

    fn frozen_bits(f: impl Fn(u32) -> Sample, n: u32) -> (u8, Option<u32>) {
        let mut d = FrozenDetector::new(cfg());
        let (mut any, mut first) = (0, None);
        for k in 0..n {
            let b = update(&mut d, &f(k)).frozen;
            if b != 0 && first.is_none() {
                first = Some(k);
            }
            any |= b;
        }
        (any, first)
    }

    #[test]
    fn live_readings_are_never_frozen() {
        assert_eq!(frozen_bits(|k| cycle(k, 1.0), 60_000).0, 0);
    }

    #[test]
    fn noise_free_readings_through_holds_and_steady_moves_are_never_frozen() {
        // Pressures on one code through each hold and each steady move.
        let flat = |k: u32| {
            let mut s = cycle(k, 0.0);
            s.p_piston_bar = Some(25.0);
            s
        };
        assert_eq!(frozen_bits(|k| cycle(k, 0.0), 60_000).0, 0);
        assert_eq!(frozen_bits(flat, 60_000).0, 0);
    }

    #[test]
    fn position_frozen_while_the_valve_feeds_is_detected_without_noise() {
        // Frozen at 4 s, in the middle of the extension: detected 1 s later.
        let f = |k: u32| {
            let mut s = cycle(k, 0.0);
            if k >= 4000 {
                s.x_piston_m = Some(0.06);
            }
            s
        };
        let (bits, first) = frozen_bits(f, 8000);
        assert_eq!(bits, Channel::XPiston.bit());
        // (The quantised reading reaches 60.0 mm a few samples early.)
        assert!(matches!(first, Some(4990..=5001)), "{first:?}");
    }

    #[test]
    fn a_noisy_position_frozen_at_a_hold_is_detected() {
        // A second cycle's hold: frozen at 16 s, detected half a second on.
        let f = |k: u32| {
            let mut s = cycle(k, 1.0);
            if k >= 16_000 {
                s.x_piston_m = Some(0.05);
            }
            s
        };
        let (bits, first) = frozen_bits(f, 16_900);
        assert_eq!(bits, Channel::XPiston.bit());
        assert!(matches!(first, Some(16_500..=16_501)), "{first:?}");
    }

    #[test]
    fn position_at_an_end_stop_with_the_valve_open_or_blocked_is_not_frozen() {
        let at_stop = |k: u32| sample(k, 0.18, 0.3, 49.9, 0.5, 0.0);
        assert_eq!(frozen_bits(at_stop, 5000).0, 0);
        // Open but no pressure drop across the feeding edge: blocked.
        let blocked = |k: u32| sample(k, 0.09, 0.3, 49.5, 0.5, 0.0);
        assert_eq!(frozen_bits(blocked, 5000).0, 0);
    }

    #[test]
    fn a_pressure_frozen_while_the_piston_travels_is_detected() {
        // Frozen at 17 s (a second extension), noisy sensor.
        let f = |k: u32| {
            let mut s = cycle(k, 1.0);
            if k >= 17_000 {
                s.p_rod_bar = Some(12.0);
            }
            s
        };
        let (bits, first) = frozen_bits(f, 20_000);
        assert_eq!(bits, Channel::PRod.bit());
        assert!(matches!(first, Some(17_500..=18_000)), "{first:?}");
    }

    #[test]
    fn a_frozen_channel_recovers_when_its_reading_changes() {
        let mut d = FrozenDetector::new(cfg());
        for k in 0..16_900 {
            let mut s = cycle(k, 1.0);
            if k >= 16_000 {
                s.x_piston_m = Some(0.05);
            }
            let _ = update(&mut d, &s);
        }
        assert_ne!(
            update(&mut d, &{
                let mut s = cycle(16_900, 1.0);
                s.x_piston_m = Some(0.05);
                s
            })
            .frozen,
            0
        );
        assert_eq!(update(&mut d, &cycle(16_901, 1.0)), Frozen::default());
    }

    #[test]
    fn a_noisy_channel_is_suspect_long_before_it_is_frozen() {
        let mut d = FrozenDetector::new(cfg());
        let mut suspect_at = None;
        for k in 0..16_600 {
            let mut s = cycle(k, 1.0);
            if k >= 16_000 {
                s.x_piston_m = Some(0.05);
            }
            let f = update(&mut d, &s);
            if f.suspect != 0 && suspect_at.is_none() {
                suspect_at = Some(k);
                assert_eq!(f.suspect, Channel::XPiston.bit());
            }
        }
        // 50 ms after the freeze; frozen only at 500 ms.
        assert!(
            matches!(suspect_at, Some(16_050..=16_051)),
            "{suspect_at:?}"
        );
        // Noise-free readings through holds and moves: never suspect
        // (but for slow feeding moves: the position check).
        let mut d = FrozenDetector::new(cfg());
        for k in 0..60_000 {
            let f = update(&mut d, &cycle(k, 0.0));
            assert_eq!(f.suspect & !Channel::XPiston.bit(), 0, "at {k}");
        }
    }
}
