//! When does a sample count as leak evidence?
//!
//! Leaks are small flows (0.05–1 l/min) against valve flows of 5–40 l/min.
//! The evidence about them is good while the plant is *quasi-steady*:
//! holds, and slow steady moves. It is poor during transients — valve
//! steps, breakaway from stiction, the start and end of moves — where the
//! estimated piston velocity lags the truth by tens of milliseconds (at
//! A_p = 3·10⁻³ m², 10 mm/s of velocity error is 1.9 l/min of apparent
//! flow) and the pressure transmitters' 4 ms lag shows, and during fast
//! moves, where a 2 % model error is more flow than the leak sought and a
//! small leak-coefficient error times a large pressure difference looks
//! like a flow spike.
//!
//! The *evidence weight* w ∈ (0, 1] measures this from what is observed,
//! not from the model's own derivatives (a tiny flow mismatch in a small,
//! stiff chamber is already 15 bar/s of model rate, balanced every sample
//! by the measurement update):
//!
//! w = w_t / (1 + (q/q₀)²),  w_t = 1 / (1 + (r/r₀)² + (c/c₀)²),
//!
//! r = smoothed rate of the estimated chamber pressures (bar/s), c =
//! smoothed rate of the valve command (1/s), q = valve metering flow
//! (l/min). After a transient w_t drops at once and recovers with a time
//! constant, so the tail of a transient does not count either. The leak
//! states learn with gain × w, and the decision counts evidence time as
//! dt × w.
//!
//! Whose estimates? A filter whose model lacks a flow the plant has
//! chatters where the plant is quietest: at a hold against a leak the
//! healthy filter swings its speed state by millimetres per second to
//! explain the flow, and its pressure estimates' rates read as a
//! transient — the leak's own evidence was weighted to nothing (tenth
//! survey rig 467: w 0.95 at the holds before an external leak's onset,
//! 0.01 after; the 0.5 l/min leak never alarmed). So [`EvidenceWeight`]
//! judges the plant under the healthy and the `both` model, and with the
//! piston at rest, while the `both` model describes the plant (its mean
//! NIS at most twice the expected), takes the quieter view. In moves the
//! healthy view alone counts: there a transient the leak states take in
//! makes the `both` filter the quieter one, and the quieter of the two
//! in moves too raised false alarms on the tenth and eleventh survey
//! rigs.
//!
//! The valve's flow-gain states are the opposite case: they are only
//! observable while the valve passes flow (at a hold the valve merely
//! feeds whatever leaks, and a gain error there is indistinguishable from
//! an internal leak — but it is also harmless, a few percent of a fraction
//! of a litre). They learn with w_t·q²/(q² + q_g²).

use crate::params::{EXTENDING_REGION, RETRACTING_REGION};
use crate::real::Real;
use crate::signal::Conditioned;

/// Smoothing time constant of the rates, s.
const RATE_SMOOTHING_S: f64 = 0.02;
/// Command rate at which w halves, 1/s (full travel in 2 s).
const QUIET_COMMAND_RATE: f64 = 0.5;

/// Band, bar, within which a chamber counts as sitting at the supply or
/// the tank pressure: several σ of the transmitters' noise and offsets.
const RAIL_BAND_BAR: f32 = 3.0;

/// Is the piston pinned with the valve open, against an end stop or an
/// obstacle? The valve opens toward one chamber (the operating `region`
/// of `params::operating_region`: retracting 0, extending 2), that
/// chamber sits at the supply pressure and the other at the tank's. The
/// open edges then feed whatever leaks at a pressure drop
/// far below the transmitters' offsets (1 l/min through an edge that
/// passes 20 l/min at 35 bar drops 0.09 bar, against offsets of tenths of
/// a bar): the model's metering flow hangs on those offsets, and neither
/// leak can be told from it. Such a sample is no leak evidence. (The
/// classic end-stop leak test closes the valve; a closed valve is a hold.)
pub fn pinned(c: &Conditioned, region: usize) -> bool {
    let (fed, drained) = match region {
        RETRACTING_REGION => (c.p_rod_bar, c.p_piston_bar),
        EXTENDING_REGION => (c.p_piston_bar, c.p_rod_bar),
        _ => return false,
    };
    fed >= c.p_supply_bar - RAIL_BAND_BAR && drained <= c.p_tank_bar + RAIL_BAND_BAR
}

/// Time constant of the position reading's smoothing, s: 20 samples,
/// 0.15 mm of white noise falls to 0.03 mm.
const POSITION_SMOOTHING_S: f64 = 0.02;
/// Time constant over which the piston speed is measured, s: the
/// smoothed reading's noise is 0.3 mm/s of speed.
const SPEED_WINDOW_S: f64 = 0.1;

/// The piston speed from the position reading alone, m/s: the difference
/// of two first-order lags, which on a steady move is speed × the second
/// lag. Each filter's own speed estimate leans on its model: at a hold
/// against a leak it does not model, it reads millimetres per second of
/// motion that is not there.
#[derive(Clone, Debug)]
pub struct PistonSpeed<T> {
    /// The position reading smoothed over `POSITION_SMOOTHING_S`, m.
    smoothed_m: Option<T>,
    /// `smoothed_m` less its lag over `SPEED_WINDOW_S`, m (kept as the
    /// difference: hundredths of a millimetre on a position of tenths of a
    /// metre).
    lead_m: T,
}

impl<T: Real> Default for PistonSpeed<T> {
    fn default() -> Self {
        Self {
            smoothed_m: None,
            lead_m: T::ZERO,
        }
    }
}

impl<T: Real> PistonSpeed<T> {
    /// Forget the history (filters restarted): at rest from the next reading.
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// Take the position reading `x_m` (m) after a step of `dt` s; returns
    /// the speed, m/s.
    pub fn update(&mut self, x_m: T, dt: T) -> T {
        let Some(smoothed) = self.smoothed_m.as_mut() else {
            self.smoothed_m = Some(x_m);
            return T::ZERO;
        };
        let a1 = (dt / T::c(POSITION_SMOOTHING_S)).min(T::ONE);
        let a2 = (dt / T::c(SPEED_WINDOW_S)).min(T::ONE);
        let step = a1 * (x_m - *smoothed);
        *smoothed += step;
        self.lead_m += step - a2 * self.lead_m;
        self.speed()
    }

    /// The last speed, m/s.
    pub fn speed(&self) -> T {
        self.lead_m / T::c(SPEED_WINDOW_S)
    }
}

/// The `both` filter's mean NIS (3 expected) up to which its view of a
/// hold counts for the evidence weight ([`EvidenceWeight`]): twice the
/// expected. A hold whose pressures neither model describes is no
/// evidence of a leak (twelfth survey rig 595 settled its chambers for
/// 3 s after a move at a `both` NIS of 7: an external alarm on a healthy
/// run when its view counted there).
pub const BOTH_VIEW_NIS: f64 = 6.0;

/// Tracks how quasi-steady the plant is.
#[derive(Clone, Debug)]
pub struct Quietness<T> {
    rate_ref_bar_s: T,
    flow_ref_lpm: T,
    gain_flow_lpm: T,
    recovery_s: T,
    last: Option<[T; 3]>,
    rates: [T; 3],
    transient: T,
    flow_lpm: T,
    /// `weight()`, refreshed whenever its inputs change (it is read
    /// several times a step; the gain weight once, and of one view only).
    weight: T,
}

impl<T: Real> Quietness<T> {
    /// A tracker: pressure rate `rate_ref_bar_s` (bar/s) and valve flow
    /// `flow_ref_lpm` (l/min) halve the evidence weight; it recovers with
    /// `recovery_s`; the valve gains learn at half weight at a flow of
    /// `gain_flow_lpm`. A `rate_ref_bar_s` ≤ 0 disables the weighting.
    pub fn new(
        rate_ref_bar_s: f64,
        flow_ref_lpm: f64,
        gain_flow_lpm: f64,
        recovery_s: f64,
    ) -> Self {
        Self {
            rate_ref_bar_s: T::c(rate_ref_bar_s),
            flow_ref_lpm: T::c(flow_ref_lpm),
            gain_flow_lpm: T::c(gain_flow_lpm),
            recovery_s: T::c(recovery_s.max(1e-6)),
            last: None,
            rates: [T::ZERO; 3],
            transient: T::ZERO,
            flow_lpm: T::ZERO,
            weight: T::ZERO,
        }
        .refreshed()
    }

    fn refreshed(mut self) -> Self {
        self.refresh();
        self
    }

    fn refresh(&mut self) {
        self.weight = self.compute_weight();
    }

    /// Forget everything (filters restarted): weights 0, rising.
    pub fn restart(&mut self) {
        self.last = None;
        self.rates = [T::ZERO; 3];
        self.transient = T::ZERO;
        self.refresh();
    }

    /// The evidence weight w: how much the current sample counts as leak
    /// evidence, and the learning weight of the leak states.
    pub fn weight(&self) -> T {
        self.weight
    }

    /// The learning weight of the valve flow-gain states.
    pub fn gain_weight(&self) -> T {
        let q2 = self.flow_lpm * self.flow_lpm;
        let transient = if self.rate_ref_bar_s > T::ZERO {
            self.transient
        } else {
            T::ONE
        };
        transient * q2 / (q2 + self.gain_flow_lpm * self.gain_flow_lpm)
    }

    fn compute_weight(&self) -> T {
        if !(self.rate_ref_bar_s > T::ZERO) {
            return T::ONE;
        }
        let q = self.flow_lpm / self.flow_ref_lpm;
        self.transient / (T::ONE + q * q)
    }

    /// Update with the estimated chamber pressures (bar), the valve command
    /// and the valve metering flow (l/min) after a step of `dt` s.
    pub fn update(
        &mut self,
        p_piston_bar: T,
        p_rod_bar: T,
        command: T,
        valve_flow_lpm: T,
        dt: T,
    ) -> T {
        self.flow_lpm = valve_flow_lpm.abs();
        if !(self.rate_ref_bar_s > T::ZERO) {
            self.refresh();
            return T::ONE;
        }
        let now = [p_piston_bar, p_rod_bar, command];
        if let Some(last) = self.last {
            let a = (dt / T::c(RATE_SMOOTHING_S)).min(T::ONE);
            for i in 0..3 {
                let rate = (now[i] - last[i]) / dt;
                self.rates[i] += a * (rate - self.rates[i]);
            }
        }
        self.last = Some(now);
        let r = self.rates[0].abs().max(self.rates[1].abs()) / self.rate_ref_bar_s;
        let c = self.rates[2].abs() / T::c(QUIET_COMMAND_RATE);
        let instant = T::ONE / (T::ONE + r * r + c * c);
        let recovered =
            self.transient + (T::ONE - self.transient) * (dt / self.recovery_s).min(T::ONE);
        self.transient = instant.min(recovered);
        self.refresh();
        self.weight
    }
}

/// The evidence weight of a sample, judged under the healthy model and
/// under the `both` model (see the module doc): the valve gains learn
/// with the healthy view's weight.
#[derive(Clone, Debug)]
pub struct EvidenceWeight<T> {
    /// From the healthy filter's estimates.
    pub healthy: Quietness<T>,
    /// From the `both` filter's estimates.
    pub both: Quietness<T>,
    /// Whether the `both` view counts (see [`Self::judge_both`]).
    both_counts: bool,
}

impl<T: Real> EvidenceWeight<T> {
    /// Both views with `view`'s settings.
    pub fn new(view: Quietness<T>) -> Self {
        Self {
            healthy: view.clone(),
            both: view,
            both_counts: false,
        }
    }

    /// Forget everything (filters restarted).
    pub fn restart(&mut self) {
        self.healthy.restart();
        self.both.restart();
    }

    /// Whether the `both` view counts from this sample on: with the
    /// piston `at_rest` and the `both` model describing the plant, its
    /// mean NIS (`both_mean_nis`, 3 expected) at most [`BOTH_VIEW_NIS`].
    pub fn judge_both(&mut self, at_rest: bool, both_mean_nis: T) {
        self.both_counts = at_rest && both_mean_nis <= T::c(BOTH_VIEW_NIS);
    }

    /// The evidence weight w.
    pub fn weight(&self) -> T {
        if self.both_counts {
            self.healthy.weight().max(self.both.weight())
        } else {
            self.healthy.weight()
        }
    }

    /// The learning weight of the valve flow-gain states.
    pub fn gain_weight(&self) -> T {
        self.healthy.gain_weight()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_piston_speed_follows_a_steady_move_and_reads_zero_at_rest() {
        let mut s = PistonSpeed::<f64>::default();
        let dt = 1e-3;
        // 10 mm/s for 1 s, then at rest for 1 s.
        let mut x = 0.2;
        for _ in 0..1000 {
            x += 0.01 * dt;
            s.update(x, dt);
        }
        assert!((s.speed() - 0.01).abs() < 2e-4, "moving: {}", s.speed());
        for _ in 0..1000 {
            s.update(x, dt);
        }
        assert!(s.speed().abs() < 1e-5, "at rest: {}", s.speed());
    }

    #[test]
    fn an_open_valve_into_a_chamber_at_the_supply_pressure_is_pinned() {
        let band = (-0.01, 0.01);
        let at = |u: f32, p_piston_bar: f32, p_rod_bar: f32| {
            let region = crate::params::operating_region(u, band);
            pinned(
                &Conditioned {
                    p_supply_bar: 50.0,
                    p_piston_bar,
                    p_rod_bar,
                    p_tank_bar: 1.5,
                    x_piston_m: 0.0,
                    u_valve: u,
                    temp_oil_c: None,
                },
                region,
            )
        };
        // Against either end stop, the valve open into it.
        assert!(at(-0.5, 1.6, 49.9));
        assert!(at(0.5, 49.7, 1.4));
        // Moving: the feeding chamber below the supply, or the drained
        // one above the tank.
        assert!(!at(-0.5, 26.0, 47.0));
        assert!(!at(-0.5, 3.0, 35.0));
        assert!(!at(0.5, 35.0, 11.0));
        // Held, or the valve open away from the chamber at the supply.
        assert!(!at(0.0, 1.6, 49.9));
        assert!(!at(0.5, 1.6, 49.9));
    }

    #[test]
    fn steady_plant_weighs_one_transients_near_zero_then_recover() {
        let mut q = Quietness::<f64>::new(10.0, 10.0, 2.0, 0.3);
        let dt = 0.001;
        let mut w = 0.0;
        for _ in 0..3000 {
            w = q.update(26.0, 24.0, 0.0, 0.1, dt);
        }
        assert!(w > 0.99, "hold: {w}");
        // A valve step: command jumps and pressures ramp at 200 bar/s.
        let mut p = 26.0;
        for _ in 0..50 {
            p += 0.2;
            w = q.update(p, 24.0, 0.3, 12.0, dt);
        }
        assert!(w < 0.05, "transient: {w}");
        // Steady again: weight recovers over a few recovery times.
        for _ in 0..300 {
            w = q.update(p, 24.0, 0.3, 0.1, dt);
        }
        assert!(w > 0.5 && w < 0.9, "recovering: {w}");
        for _ in 0..2000 {
            w = q.update(p, 24.0, 0.3, 0.1, dt);
        }
        assert!(w > 0.99);
    }

    #[test]
    fn fast_moves_weigh_little() {
        let mut q = Quietness::<f32>::new(10.0, 10.0, 2.0, 0.3);
        let mut w = 0.0;
        for _ in 0..2000 {
            w = q.update(25.0, 5.0, 0.6, 35.0, 0.001);
        }
        assert!(w < 0.1, "{w}");
        // …but that is when the valve gains learn.
        assert!(q.gain_weight() > 0.99);
    }

    #[test]
    fn valve_gains_do_not_learn_at_holds() {
        let mut q = Quietness::<f32>::new(10.0, 10.0, 2.0, 0.3);
        for _ in 0..3000 {
            q.update(26.0, 24.0, 0.02, 0.3, 0.001);
        }
        assert!(q.weight() > 0.99);
        assert!(q.gain_weight() < 0.03, "{}", q.gain_weight());
    }

    #[test]
    fn at_rest_a_fitting_both_model_judges_the_plant_in_moves_the_healthy_one() {
        let mut w = EvidenceWeight::new(Quietness::<f64>::new(10.0, 10.0, 2.0, 0.3));
        // A hold against a leak: the healthy filter's pressure estimates
        // swing by ±1 bar at 10 Hz (its speed state explains the flow),
        // the `both` filter's sit still.
        for k in 0..3000 {
            let chatter = (k as f64 * 1e-3 * 10.0 * core::f64::consts::TAU).sin();
            w.healthy
                .update(33.0 + chatter, 20.0 - chatter, -0.003, 0.5, 0.001);
            w.both.update(33.0, 20.0, -0.003, 0.5, 0.001);
        }
        assert!(w.healthy.weight() < 0.3, "{}", w.healthy.weight());
        w.judge_both(true, BOTH_VIEW_NIS);
        assert!(w.weight() > 0.99, "{}", w.weight());
        // Moving, or the `both` model not fitting, the healthy view alone
        // counts; the gains learn with it always.
        for (at_rest, nis) in [(false, 3.0), (true, BOTH_VIEW_NIS + 0.01), (true, f64::NAN)] {
            w.judge_both(at_rest, nis);
            assert_eq!(w.weight(), w.healthy.weight(), "{at_rest} {nis}");
        }
        assert_eq!(w.gain_weight(), w.healthy.gain_weight());
        w.restart();
        w.judge_both(true, 3.0);
        assert_eq!(w.weight(), 0.0);
    }
}
