//! Physical plausibility of the position reading and of the valve command.
//!
//! **Spikes.** A piston of a few hundred kilograms cannot move 5 mm in a
//! millisecond. A position reading that jumps further from the last
//! accepted one than [`MAX_SPEED_M_S`] allows (plus the reading's noise)
//! is an outlier: it is not used (the last accepted reading stands in and
//! the sample is no leak evidence) and it is counted. A count that decays
//! with [`OUTLIER_MEMORY_S`] and reaches [`OUTLIER_FAULT_COUNT`] makes the
//! channel faulted: a transmitter that spikes again and again cannot be
//! trusted. A jump that persists for [`REBASE_SAMPLES`] is taken as the new
//! level (and counted).
//!
//! **Valve command.** An open wire on the command input reads 0 while the
//! machine's controller still drives the real valve: the piston moves with
//! a command that says "closed", which the filters would read as oil
//! leaving through a leak. When the piston moves faster than
//! [`CLOSED_SPEED_M_S`] with the command inside the valve's dead zone, or
//! clearly against the commanded direction, the command is contradicted:
//! from the first such sample the sample is no evidence, and after
//! [`COMMAND_FAULT_S`] of contradiction of a command that stayed where it
//! is for [`COMMAND_SETTLE_S`] the command channel is faulted (a hunting
//! loop's piston lags its swinging command: no evidence, but no fault;
//! and a closed valve's contradiction faults only a reading within
//! [`STILL_BAND`] of zero, what a dead input reads: a valve whose null
//! the calibration did not fit may open inside the kept dead zone).
//! The contradiction drains ten times slower than it fills, so an open
//! wire stays a fault through the holds between moves.
//!
//! **A command that sits still.** A slow move (5–20 mm/s) with the wire
//! open is below that speed, and a calibrated null offset just outside
//! the dead zone makes a reading of 0 look like a small opening; the
//! filters then take the real valve flow for a leak. A live command
//! moves with the controller's error; an open wire's reading does not
//! change at all. So while the command stays within [`STILL_TOL`] of one
//! value near zero (within [`STILL_BAND`]), the piston's net travel from
//! where it stood when the command took that value is watched: beyond
//! [`STILL_SUSPECT_M`] the command is contradicted, beyond
//! [`STILL_FAULT_M`] faulted. Net travel, not time or speed: a hunting
//! loop's command never sits still, and its piston swings about one
//! place (no net travel); a valve closed by design sees at most the slow
//! drift of a leak while the command is held (a leak of 1 l/min moves
//! this piston 3 mm in 0.6 s: the price is that such drift with a
//! constant zero command reads as a sensor fault, never as a leak from an
//! untrusted command).
//!
//! **A command that drops dead at a hold.** When the wire opens while the
//! loop holds the piston, nothing moves until the next move: the reading
//! says 0 where the controller drives a small opening, and the filters
//! take the difference for a leak within a second or two. A live command
//! that settles near zero gets there smoothly; a dead input's reading
//! jumps there (by more than [`STILL_JUMP`] in one sample) and then does
//! not change at all. Such a command is contradicted from
//! [`STILL_DEAD_S`] after the jump until it changes again: no evidence,
//! but no fault (a machine that commands exactly 0 at rest looks the
//! same until it moves).

use crate::physics::valve::spool_at;
use crate::real::Real;

/// Fastest plausible piston speed, m/s (the rig moves at ≤ 0.2 m/s).
pub const MAX_SPEED_M_S: f32 = 0.5;
/// A jump must also exceed this many σ of the reading's noise.
const JUMP_SIGMAS: f32 = 8.0;
/// And this much, m (quantisation of coarse recordings).
const JUMP_MIN_M: f32 = 1.0e-4;
/// Time constant of the outlier count's decay, s.
pub const OUTLIER_MEMORY_S: f32 = 10.0;
/// Outlier count that faults the channel.
pub const OUTLIER_FAULT_COUNT: f32 = 3.0;
/// Outlier count below which a faulted channel recovers.
const OUTLIER_RECOVER_COUNT: f32 = 1.0;
/// Consecutive outlying samples after which the new level is accepted.
const REBASE_SAMPLES: u8 = 20;
/// Smoothing of the position and of its rate for the command check, s.
const SPEED_SMOOTHING_S: f32 = 0.02;
/// Speed that a closed valve cannot explain, m/s (a 1 l/min leak moves
/// this piston at 5 mm/s).
pub const CLOSED_SPEED_M_S: f32 = 0.02;
/// Command beyond the dead zone that names a direction.
const DIRECTION_MARGIN: f32 = 0.05;
/// How long the command must have stayed inside the dead zone, or beyond
/// the direction margin on one side, before the motion contradicting it
/// counts towards a fault, s. A position loop that hunts swings its
/// command through the dead zone and from side to side faster than the
/// piston (lagging by the valve's and the oil's dynamics) follows: on a
/// development rig hunting at 14 Hz the piston still ran at 0.1 m/s
/// against each new direction for 20–30 ms, and those moments added up
/// to a false fault. An open wire's reading stays put.
pub const COMMAND_SETTLE_S: f32 = 0.06;
/// Contradiction time that faults the command, s.
pub const COMMAND_FAULT_S: f32 = 0.3;
/// The contradiction drains this many times slower than it fills.
const COMMAND_DRAIN: f32 = 10.0;
/// Contradiction time kept at most, s.
const COMMAND_MEMORY_S: f32 = 2.0;
/// A command within this of zero may be a dead input's reading (an open
/// wire reads 0, plus the input's offset of a few thousandths at most).
/// It was 0.01: on two 100 bar cells of the second survey a live command
/// of 0.008–0.010 held steady to 1e-5 while it moved the piston at 10 mm/s
/// (a controller fed a clean position follows a ramp with a constant
/// error), and the command was faulted on three runs without a fault.
pub const STILL_BAND: f32 = 0.005;
/// A command that changes by no more than this sits still (a live
/// command changes with the controller's error from sample to sample).
pub const STILL_TOL: f32 = 1.0e-5;
/// Net travel with the command sitting still that contradicts it, m.
pub const STILL_SUSPECT_M: f32 = 1.5e-3;
/// Net travel with the command sitting still that faults it, m (the
/// healthy development runs travel at most 0.9 mm with the command inside
/// the dead zone).
pub const STILL_FAULT_M: f32 = 3.0e-3;
/// A step into [`STILL_BAND`] larger than this in one sample is how a dead
/// input's reading arrives (four quanta of a 12-bit input over ±1; a
/// live loop's command moves by less from sample to sample as it settles).
/// The open command wires of the survey rigs stepped by 0.002–0.3.
pub const STILL_JUMP: f32 = 2.0e-3;
/// How long a command that jumped into the band must sit still before it
/// is contradicted, s (no live command of the survey rigs sat still for
/// 0.25 s after such a jump; an open wire's leak alarm took ≥ 0.9 s).
pub const STILL_DEAD_S: f32 = 0.05;

/// Verdict on one position reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionCheck {
    /// The reading to use, m (the last accepted one for an outlier).
    pub x_m: f32,
    /// This reading was an outlier.
    pub outlier: bool,
    /// Outliers are persistent: the channel is faulted.
    pub faulted: bool,
}

/// Rate plausibility of the position reading.
#[derive(Clone, Debug, Default)]
pub struct PositionSpikes {
    last_good: Option<f32>,
    pending: u8,
    count: f32,
    faulted: bool,
}

impl PositionSpikes {
    /// Check reading `x_m`, `dt_s` after the previous sample, with the
    /// reading's current noise σ `sigma_m`.
    pub fn check(&mut self, x_m: f32, dt_s: f32, sigma_m: f32) -> PositionCheck {
        self.count -= self.count * Real::min(dt_s / OUTLIER_MEMORY_S, 1.0);
        let mut outlier = false;
        let x = match self.last_good {
            None => {
                self.last_good = Some(x_m);
                x_m
            }
            Some(good) => {
                let elapsed = dt_s * (self.pending as f32 + 1.0);
                let limit = MAX_SPEED_M_S * elapsed + JUMP_SIGMAS * sigma_m + JUMP_MIN_M;
                if (x_m - good).abs() <= limit {
                    self.pending = 0;
                    self.last_good = Some(x_m);
                    x_m
                } else {
                    if self.pending == 0 {
                        self.count += 1.0;
                    }
                    self.pending += 1;
                    if self.pending >= REBASE_SAMPLES {
                        // The level really changed (a re-zeroed transducer,
                        // a loose connector settling): take it, counted.
                        self.pending = 0;
                        self.last_good = Some(x_m);
                        x_m
                    } else {
                        outlier = true;
                        good
                    }
                }
            }
        };
        if self.count >= OUTLIER_FAULT_COUNT {
            self.faulted = true;
        } else if self.count < OUTLIER_RECOVER_COUNT {
            self.faulted = false;
        }
        PositionCheck {
            x_m: x,
            outlier,
            faulted: self.faulted,
        }
    }

    /// Forget the last reading (the channel was missing); the count stays.
    pub fn break_sequence(&mut self) {
        self.last_good = None;
        self.pending = 0;
    }

    /// The decaying outlier count.
    pub fn count(&self) -> f32 {
        self.count
    }
}

/// Verdict on one valve command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandCheck {
    /// The motion contradicts the command now (the sample is no evidence).
    pub contradicted: bool,
    /// It has for long enough: the command channel is faulted.
    pub faulted: bool,
}

/// Does the piston's motion agree with the valve command?
#[derive(Clone, Debug)]
pub struct CommandAgreement {
    dead_zone: f32,
    null_offset: f32,
    x_smooth: Option<f32>,
    speed: f32,
    /// Where the command is (inside the dead zone, beyond the margin on
    /// one side, in between) and how long it has been there, s.
    region: CommandRegion,
    region_s: f32,
    contradiction_s: f32,
    faulted: bool,
    /// The command value that sits still, and the smoothed position when
    /// it took that value, m.
    still_u: f32,
    still_x_m: f32,
    /// The still command jumped into the band, and how long it has sat
    /// still since, s.
    still_jumped: bool,
    still_s: f32,
}

impl CommandAgreement {
    /// For a valve with `dead_zone` and `null_offset` (fractions of travel).
    pub fn new(dead_zone: f32, null_offset: f32) -> Self {
        Self {
            dead_zone,
            null_offset,
            x_smooth: None,
            speed: 0.0,
            region: CommandRegion::Between,
            region_s: 0.0,
            contradiction_s: 0.0,
            faulted: false,
            still_u: f32::NAN,
            still_x_m: 0.0,
            still_jumped: false,
            still_s: 0.0,
        }
    }

    /// Take the accepted position `x_m` and the command `u` of a sample
    /// `dt_s` after the previous one.
    pub fn check(&mut self, x_m: f32, u: f32, dt_s: f32) -> CommandCheck {
        let a = Real::min(dt_s / SPEED_SMOOTHING_S, 1.0);
        match self.x_smooth {
            None => self.x_smooth = Some(x_m),
            Some(xs) if dt_s > 0.0 => {
                let next = xs + a * (x_m - xs);
                let rate = (next - xs) / dt_s;
                self.speed += a * (rate - self.speed);
                self.x_smooth = Some(next);
            }
            Some(_) => {}
        }
        let region = CommandRegion::of(u, self.dead_zone, self.null_offset);
        if region == self.region {
            self.region_s = Real::min(self.region_s + dt_s, COMMAND_SETTLE_S);
        } else {
            self.region = region;
            self.region_s = 0.0;
        }
        let v = self.speed;
        let closed = region == CommandRegion::Closed && v.abs() > CLOSED_SPEED_M_S;
        let against = (region == CommandRegion::Extend && v < -CLOSED_SPEED_M_S)
            || (region == CommandRegion::Retract && v > CLOSED_SPEED_M_S);
        // Only a command that stayed where it is builds up to a fault; a
        // piston lagging a swinging command is no evidence, but no fault.
        let settled = self.region_s >= COMMAND_SETTLE_S;
        // And a closed valve's contradiction only from a reading a dead
        // input can give: a valve whose null the calibration kept opens
        // at a command of ±0.012 (two thirteenth-survey rigs moved at
        // 20 mm/s there), no evidence, but no fault.
        let dead_reading = u.abs() <= STILL_BAND;
        // Net travel while the command sits still near zero (a NaN anchor
        // never compares equal: the first sample re-anchors).
        let xs = self.x_smooth.unwrap_or(x_m);
        let still = (u - self.still_u).abs() <= STILL_TOL;
        if !dead_reading || !still {
            self.still_jumped = dead_reading && (u - self.still_u).abs() > STILL_JUMP;
            self.still_s = 0.0;
            self.still_u = u;
            self.still_x_m = xs;
        } else {
            self.still_s = Real::min(self.still_s + dt_s, STILL_DEAD_S);
        }
        let travel = (xs - self.still_x_m).abs();
        let drifting = travel > STILL_SUSPECT_M;
        let dropped_dead = self.still_jumped && self.still_s >= STILL_DEAD_S;
        let contradicted = closed || against || drifting || dropped_dead;
        if (settled && ((closed && dead_reading) || against)) || drifting {
            self.contradiction_s = Real::min(self.contradiction_s + dt_s, COMMAND_MEMORY_S);
        } else if !contradicted {
            self.contradiction_s = Real::max(self.contradiction_s - dt_s / COMMAND_DRAIN, 0.0);
        }
        if self.contradiction_s >= COMMAND_FAULT_S || travel > STILL_FAULT_M {
            self.faulted = true;
        } else if self.contradiction_s <= 0.0 {
            self.faulted = false;
        }
        CommandCheck {
            contradicted: contradicted || self.contradiction_s > 0.0,
            faulted: self.faulted,
        }
    }

    /// Forget the motion (a channel was missing).
    pub fn break_sequence(&mut self) {
        self.x_smooth = None;
        self.speed = 0.0;
        self.region_s = 0.0;
        self.still_u = f32::NAN;
        self.still_jumped = false;
    }
}

/// Where a valve command is, for [`CommandAgreement`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CommandRegion {
    /// Inside the dead zone: the valve is closed.
    Closed,
    /// Beyond the direction margin, extending.
    Extend,
    /// Beyond the direction margin, retracting.
    Retract,
    /// Open, but too little to name a direction.
    Between,
}

impl CommandRegion {
    /// Where command `u` puts the spool of a valve with `dead_zone` and
    /// `null_offset` (the spool at zero command; fractions of travel).
    fn of(u: f32, dead_zone: f32, null_offset: f32) -> Self {
        let spool = spool_at(u, null_offset);
        let margin = dead_zone + DIRECTION_MARGIN;
        if spool.abs() <= dead_zone {
            Self::Closed
        } else if spool > margin {
            Self::Extend
        } else if spool < -margin {
            Self::Retract
        } else {
            Self::Between
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::Lcg;

    #[test]
    fn a_single_spike_is_rejected_but_not_a_fault() {
        let mut s = PositionSpikes::default();
        let mut rng = Lcg::new(3);
        let mut flagged = 0;
        for k in 0..5_000 {
            let truth = 0.05 + 0.05 * (k as f32 * 1e-3); // 50 mm/s
            let spike = if k == 2_000 { 0.02 } else { 0.0 };
            let x = truth + 5e-5 * rng.gaussian() as f32 + spike;
            let c = s.check(x, 1e-3, 5e-5);
            if c.outlier {
                flagged += 1;
                assert_eq!(k, 2_000);
                assert!((c.x_m - truth).abs() < 1e-3);
            }
            assert!(!c.faulted);
        }
        assert_eq!(flagged, 1);
    }

    #[test]
    fn repeated_spikes_fault_the_channel_and_it_recovers() {
        let mut s = PositionSpikes::default();
        let mut faulted_at = None;
        for k in 0..4_000 {
            // 1.5 spikes per second of 2 samples, 10 mm.
            let spike = if k % 667 < 2 && k > 0 { 0.01 } else { 0.0 };
            if s.check(0.08 + spike, 1e-3, 5e-5).faulted && faulted_at.is_none() {
                faulted_at = Some(k);
            }
        }
        assert!(faulted_at.is_some_and(|k| k < 2_100), "{faulted_at:?}");
        let mut k = 0;
        while s.check(0.08, 1e-3, 5e-5).faulted {
            k += 1;
            assert!(k < 20_000, "never recovers");
        }
    }

    #[test]
    fn fast_real_motion_is_not_a_spike() {
        let mut s = PositionSpikes::default();
        for k in 0..2_000 {
            let x = 0.01 + 0.3 * (k as f32 * 1e-3).min(0.5); // 300 mm/s
            assert!(!s.check(x, 1e-3, 5e-5).outlier, "{k}");
        }
    }

    #[test]
    fn an_open_command_wire_is_a_fault_within_half_a_second_of_motion() {
        let mut c = CommandAgreement::new(0.015, 0.0);
        // Hold, then a 50 mm/s move with the command reading 0.
        let mut fault_at = None;
        for k in 0..3_000 {
            let t = k as f32 * 1e-3;
            let x = 0.05 + 0.05 * (t - 1.0).max(0.0);
            let r = c.check(x, 0.0, 1e-3);
            if k < 1_000 {
                assert!(!r.contradicted, "{k}");
            }
            if r.faulted && fault_at.is_none() {
                fault_at = Some(k);
            }
        }
        assert!(fault_at.is_some_and(|k| k < 1_500), "{fault_at:?}");
    }

    #[test]
    fn a_slow_move_with_an_open_command_wire_is_a_fault_within_half_a_second() {
        // A calibrated null offset just outside a narrow dead zone (as on
        // development rig 3): a reading of 0 is a small opening, and the
        // 8 mm/s move is below the speed test.
        let mut c = CommandAgreement::new(0.002, -0.0173);
        let mut rng = Lcg::new(7);
        let (mut suspect_at, mut fault_at) = (None, None);
        for k in 0..4_000 {
            let t = k as f32 * 1e-3;
            let x = 0.05 + 0.008 * (t - 1.0).max(0.0) + 5e-5 * rng.gaussian() as f32;
            let r = c.check(x, 0.0, 1e-3);
            if k < 1_000 {
                assert!(!r.contradicted, "{k}");
            }
            if r.contradicted && suspect_at.is_none() {
                suspect_at = Some(k);
            }
            if r.faulted && fault_at.is_none() {
                fault_at = Some(k);
            }
        }
        // 1.5 mm and 3 mm of travel at 8 mm/s, plus the smoothing.
        assert!(suspect_at.is_some_and(|k| k < 1_250), "{suspect_at:?}");
        assert!(fault_at.is_some_and(|k| k < 1_450), "{fault_at:?}");
        // The piston stands still at its new place: the fault stays.
        assert!(c.check(0.074, 0.0, 1e-3).faulted);
    }

    #[test]
    fn a_slow_move_with_a_small_live_command_is_not_contradicted() {
        // The controller's command during a slow move: small (inside the
        // band), nearly steady, but live (it follows the error).
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut rng = Lcg::new(9);
        for k in 0..6_000 {
            let t = k as f32 * 1e-3;
            let x = 0.05 + 0.009 * t;
            let u = -0.0079 + 1e-4 * (t * 3.0).sin() + 2e-5 * rng.gaussian() as f32;
            let r = c.check(x + 5e-5 * rng.gaussian() as f32, u, 1e-3);
            assert!(!r.contradicted, "{k}");
        }
    }

    #[test]
    fn a_steady_small_opening_that_moves_the_piston_is_not_contradicted() {
        // A controller fed a clean position follows a 10 mm/s ramp with a
        // constant error: its command holds 0.009 to the last digit while
        // the piston travels 20 mm (second survey rig 89, 100 bar).
        let mut c = CommandAgreement::new(0.005, -0.004);
        for k in 0..2_000 {
            let t = k as f32 * 1e-3;
            let r = c.check(0.05 + 0.01 * t, 0.009, 1e-3);
            assert!(!r.contradicted && !r.faulted, "{k}");
        }
    }

    #[test]
    fn a_live_command_inside_a_kept_dead_zone_that_moves_the_piston_is_no_evidence_but_no_fault() {
        // Calibration kept the reference valve (dead zone 0.015, no null
        // offset); the rig's valve opens at 0.012, and the loop follows a
        // slow ramp at 22 mm/s with that steady command (thirteenth survey
        // rigs 638 and 654, 100 bar): the model's closed valve cannot
        // explain the motion, but no open wire reads 0.012.
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut contradicted = false;
        for k in 0..3_000 {
            let t = k as f32 * 1e-3;
            let r = c.check(0.04 + 0.022 * t, 0.012, 1e-3);
            contradicted |= r.contradicted;
            assert!(!r.faulted, "{k}");
        }
        assert!(contradicted);
        // The same motion with the reading at 0 is the open wire.
        let mut c = CommandAgreement::new(0.015, 0.0);
        let faulted =
            (0..3_000).any(|k| c.check(0.04 + 0.022 * k as f32 * 1e-3, 0.0, 1e-3).faulted);
        assert!(faulted);
    }

    #[test]
    fn a_command_wire_that_opens_at_a_hold_is_no_evidence_until_the_command_moves() {
        // The loop holds the piston with a steady 0.008 (a controller fed
        // a clean position); at 1 s the wire opens and the reading drops
        // to 0; nothing moves. At 3 s the command is live again.
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut contradicted_at = None;
        for k in 0..4_000 {
            let t = k as f32 * 1e-3;
            let u = match k {
                0..1_000 => 0.008,
                1_000..3_000 => 0.0,
                _ => 0.004 + 1e-4 * (t * 7.0).sin(),
            };
            let r = c.check(0.08, u, 1e-3);
            assert!(!r.faulted, "{k}");
            if !(1_000..3_001).contains(&k) {
                assert!(!r.contradicted, "{k}");
            }
            if r.contradicted && contradicted_at.is_none() {
                contradicted_at = Some(k);
            }
            if (1_060..3_000).contains(&k) {
                assert!(r.contradicted, "{k}");
            }
        }
        assert!(
            contradicted_at.is_some_and(|k| k >= 1_049),
            "{contradicted_at:?}"
        );
    }

    #[test]
    fn a_command_that_settles_into_the_band_is_not_contradicted() {
        // At the end of a move the loop's command decays to a steady
        // 0.002 (50 ms time constant) and then holds it to the last digit
        // for seconds; and a command that steps by one 12-bit quantum
        // (4.9e-4) inside the band and sits there is no dead input either.
        let mut c = CommandAgreement::new(0.015, 0.0);
        for k in 0..6_000 {
            let t = k as f32 * 1e-3;
            let u = if k < 4_000 {
                0.002 + 0.3 * (-t / 0.05).exp()
            } else {
                0.002 - 4.9e-4
            };
            let r = c.check(0.08, u, 1e-3);
            assert!(!r.contradicted && !r.faulted, "{k}");
        }
    }

    #[test]
    fn a_hunting_position_loop_is_not_a_fault() {
        // The loop hunts at 20 Hz: the command swings ±0.1 about the dead
        // zone and the piston, half a cycle behind, swings ±0.5 mm about
        // its place (chamber pressures swinging with it).
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut rng = Lcg::new(11);
        let w = 2.0 * core::f32::consts::PI * 20.0;
        let mut contradicted = 0;
        for k in 0..20_000 {
            let t = k as f32 * 1e-3;
            let u = 0.1 * (w * t).sin();
            let x = 0.08 - 5e-4 * (w * t).sin() + 5e-5 * rng.gaussian() as f32;
            let r = c.check(x, u, 1e-3);
            assert!(!r.faulted, "{k}");
            contradicted += r.contradicted as u32;
        }
        assert_eq!(contradicted, 0);
    }

    #[test]
    fn a_hunting_loop_whose_piston_lags_its_command_is_no_evidence_but_no_fault() {
        // Development rig 1 at 100 bar, 40 °C: the loop hunts at 14 Hz, the
        // command swings ±0.12 through the dead zone, and the piston's
        // speed (±0.12 m/s) lags it by 100°, so that for 20–30 ms of every
        // swing the piston still runs against the new direction. Those
        // samples are no evidence; the command is not faulted.
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut rng = Lcg::new(7);
        let w = 2.0 * core::f32::consts::PI * 14.0;
        let lag = 100.0_f32.to_radians();
        let mut contradicted = 0;
        for k in 0..20_000 {
            let t = k as f32 * 1e-3;
            let u = 0.12 * (w * t).sin();
            // x' = 0.12 m/s · sin(ωt − lag).
            let x = 0.13 - 0.12 / w * (w * t - lag).cos() + 5e-5 * rng.gaussian() as f32;
            let r = c.check(x, u, 1e-3);
            assert!(!r.faulted, "{k}");
            contradicted += r.contradicted as u32;
        }
        assert!(contradicted > 1_000, "{contradicted}");
    }

    #[test]
    fn the_command_region_is_where_command_plus_null_offset_puts_the_spool() {
        // Null offset −0.06 (beyond dead zone and margin): a zero command
        // already retracts, and +0.06 centres the spool.
        let of = |u| CommandRegion::of(u, 0.005, -0.06);
        assert_eq!(of(0.06), CommandRegion::Closed);
        assert_eq!(of(0.0), CommandRegion::Retract);
        assert_eq!(of(0.13), CommandRegion::Extend);
        assert_eq!(of(0.03), CommandRegion::Between);
    }

    #[test]
    fn a_command_that_drives_the_motion_is_not_contradicted() {
        let mut c = CommandAgreement::new(0.015, 0.0);
        let mut rng = Lcg::new(5);
        let mut x = 0.05_f32;
        for k in 0..10_000 {
            let t = k as f32 * 1e-3;
            // Moves of ±60 mm/s with the command, holds between.
            let phase = (t / 2.0) as u32 % 4;
            let (u, v) = match phase {
                0 => (0.0, 0.0),
                1 => (0.3, 0.06),
                2 => (0.0, 0.0),
                _ => (-0.3, -0.06),
            };
            x += v * 1e-3;
            let r = c.check(x + 1e-4 * rng.gaussian() as f32, u, 1e-3);
            assert!(!r.faulted, "{k}");
        }
    }
}
