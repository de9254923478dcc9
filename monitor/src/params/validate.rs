//! `Params::validate`: every field within its physical bounds (the tables
//! generated from `mod.rs`), then the relations between fields that a
//! wrong value would break, then the load model over the whole stroke.

use super::bounds::{ParamError, Problem};
use super::Params;
use crate::physics::load::load_terms_exact;
use crate::physics::valve::MAX_LAND_EXPONENT;

/// The filter's time constants must span at least this many sample
/// periods: a shorter one is a step, not an average.
pub const MIN_TIME_CONSTANT_SAMPLES: f64 = 4.0;

/// Positions (evenly spaced, both ends included) at which the load model
/// is evaluated to check that the geometry is buildable over the stroke.
pub const STROKE_CHECK_POINTS: usize = 9;

/// Largest turn of a rod over the whole stroke, degrees: a linkage driven
/// by one cylinder does not turn its rods more than once round.
const MAX_ROD_TURN_DEG: f64 = 360.0;

/// Plausible effective moving mass at the cylinder, kg: above zero (the
/// velocity equation divides by it) and below 10 000 t.
const EFFECTIVE_MASS_KG: (f64, f64) = (0.01, 1.0e7);

/// Plausible magnitude of the velocity-squared coefficient ½M'(x), kg/m.
const MAX_C2_KG_M: f64 = 1.0e9;

/// Pa per bar.
const PA_PER_BAR: f64 = 1.0e5;

fn relation(
    field: &'static str,
    value: f64,
    rule: &'static str,
    limit: f64,
    unit: &'static str,
) -> ParamError {
    ParamError {
        field,
        index: None,
        value,
        problem: Problem::Relation { rule, limit, unit },
    }
}

impl Params {
    /// Check that every value is a finite number within its field's
    /// physical bounds ([`Params::BOUNDS`]), that the fields are consistent
    /// with each other, and that the load model is buildable over the
    /// whole stroke. Returns the first offending field, its value and what
    /// is allowed.
    ///
    /// This is the one check of an installation's parameters: `host-sim
    /// replay`/`calibrate` (through `Monitor::new` and on the fitted
    /// result), the firmware build script and [`crate::Monitor::new`] all
    /// call it.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.cylinder.check_bounds()?;
        self.load.check_bounds()?;
        self.valve.check_bounds()?;
        self.fluid.check_bounds()?;
        self.friction.check_bounds()?;
        self.leakage.check_bounds()?;
        self.baseline.check_bounds()?;
        self.sensors.check_bounds()?;
        self.filter.check_bounds()?;
        self.alarm.check_bounds()?;
        self.can.check_bounds()?;
        self.check_relations()?;
        self.check_load()
    }

    /// The largest force the cylinder can deliver, N: the top of the
    /// plausible pressure range on the piston area.
    pub fn max_cylinder_force_n(&self) -> f64 {
        self.sensors.pressure_range_bar[1] * PA_PER_BAR * self.cylinder.piston_area_m2
    }

    /// Relations between fields (the bounds hold already).
    fn check_relations(&self) -> Result<(), ParamError> {
        let c = &self.cylinder;
        if !(c.rod_side_area_m2 < c.piston_area_m2) {
            return Err(relation(
                "cylinder.rod_side_area_m2",
                c.rod_side_area_m2,
                "must be smaller than cylinder.piston_area_m2 =",
                c.piston_area_m2,
                "m²",
            ));
        }
        let a = &self.alarm;
        if !(a.warning_lpm <= a.alarm_lpm) {
            return Err(relation(
                "alarm.warning_lpm",
                a.warning_lpm,
                "must be ≤ alarm.alarm_lpm =",
                a.alarm_lpm,
                "l/min",
            ));
        }
        // The hold band (null ± dead zone) decides the operating regions
        // of the baseline; it must leave most of the travel metering.
        let v = &self.valve;
        let room = 0.5 - v.null_offset.abs();
        if !(v.dead_zone <= room) {
            return Err(relation(
                "valve.dead_zone",
                v.dead_zone,
                "must be ≤ 0.5 − |valve.null_offset| (the hold band −null ± dead zone must leave half the spool travel metering) =",
                room,
                "",
            ));
        }
        // The land leakage's growth over the dead zone stays in the range
        // the model's exponential is accurate for.
        let exponent = v.edge_leak_spool_gain * v.dead_zone;
        if !(exponent <= MAX_LAND_EXPONENT) {
            return Err(relation(
                "valve.edge_leak_spool_gain",
                exponent,
                "(its product with valve.dead_zone, the land leakage's e-folds over the dead zone) must be ≤",
                MAX_LAND_EXPONENT,
                "",
            ));
        }
        let fr = &self.friction;
        if !(fr.breakaway_n >= fr.coulomb_n) {
            return Err(relation(
                "friction.breakaway_n",
                fr.breakaway_n,
                "must be ≥ friction.coulomb_n (static friction is not below sliding friction) =",
                fr.coulomb_n,
                "N",
            ));
        }
        let f_max = self.max_cylinder_force_n();
        if !(fr.breakaway_n <= f_max) {
            return Err(relation(
                "friction.breakaway_n",
                fr.breakaway_n,
                "must be ≤ the largest cylinder force, sensors.pressure_range_bar[1] × cylinder.piston_area_m2 =",
                f_max,
                "N",
            ));
        }
        if !(self.load.force_offset_n.abs() <= f_max) {
            return Err(relation(
                "load.force_offset_n",
                self.load.force_offset_n,
                "must be within ± the largest cylinder force, sensors.pressure_range_bar[1] × cylinder.piston_area_m2 =",
                f_max,
                "N",
            ));
        }
        // Sample-rate dependent: averages over fewer than a few samples.
        let f = &self.filter;
        let shortest = MIN_TIME_CONSTANT_SAMPLES * f.sample_period_s;
        for (field, tau) in [
            ("filter.detection_window_s", f.detection_window_s),
            ("filter.evidence_window_s", f.evidence_window_s),
            ("filter.learning_recovery_s", f.learning_recovery_s),
            ("filter.noise_time_constant_s", f.noise_time_constant_s),
            ("filter.evidence_memory_s", f.evidence_memory_s),
        ] {
            if !(tau >= shortest) {
                return Err(relation(
                    field,
                    tau,
                    "must span at least 4 sample periods (4 × filter.sample_period_s) =",
                    shortest,
                    "s",
                ));
            }
        }
        if !(f.detection_window_s <= f.evidence_window_s) {
            return Err(relation(
                "filter.detection_window_s",
                f.detection_window_s,
                "must be ≤ filter.evidence_window_s (detection averages faster than the reported leak size) =",
                f.evidence_window_s,
                "s",
            ));
        }
        Ok(())
    }

    /// The load model over the stroke: rods turn less than once round, the
    /// effective mass and the velocity-squared term are plausible, and the
    /// cylinder can hold the gravity load at the top of the pressure range.
    fn check_load(&self) -> Result<(), ParamError> {
        let g = &self.load;
        let stroke = self.cylinder.stroke_m;
        let turn1 = (g.theta1_fit_deg[0] * stroke).abs();
        let [a2, b2, c2] = g.theta2_fit_deg;
        let th2 = |x: f64| (a2 * x + b2) * x + c2;
        let mut lo2 = th2(0.0).min(th2(stroke));
        let mut hi2 = th2(0.0).max(th2(stroke));
        if a2 != 0.0 {
            let vertex = -b2 / (2.0 * a2);
            if vertex > 0.0 && vertex < stroke {
                lo2 = lo2.min(th2(vertex));
                hi2 = hi2.max(th2(vertex));
            }
        }
        for (field, rods, turn) in [
            ("load.theta1_fit_deg", "1 and 3", turn1),
            ("load.theta2_fit_deg", "2.1 and 2.2", hi2 - lo2),
        ] {
            if !(turn <= MAX_ROD_TURN_DEG) {
                return Err(ParamError {
                    field,
                    index: None,
                    value: turn,
                    problem: Problem::RodTurn {
                        rods,
                        stroke_m: stroke,
                        max_deg: MAX_ROD_TURN_DEG,
                    },
                });
            }
        }
        let f_max = self.max_cylinder_force_n();
        let last = (STROKE_CHECK_POINTS - 1) as f64;
        for k in 0..STROKE_CHECK_POINTS {
            let x = stroke * k as f64 / last;
            let t = load_terms_exact(g, x);
            let load = |what, value, min, max, unit| ParamError {
                field: "load.masses_kg",
                index: None,
                value,
                problem: Problem::Load {
                    what,
                    x_m: x,
                    min,
                    max,
                    unit,
                },
            };
            let (m_lo, m_hi) = EFFECTIVE_MASS_KG;
            if !(t.mass_kg >= m_lo && t.mass_kg <= m_hi) {
                return Err(load(
                    "an effective moving mass M(x) of",
                    t.mass_kg,
                    m_lo,
                    m_hi,
                    "kg",
                ));
            }
            if !(t.c2_kg_m.abs() <= MAX_C2_KG_M) {
                return Err(load(
                    "a velocity-squared coefficient ½M'(x) of",
                    t.c2_kg_m,
                    -MAX_C2_KG_M,
                    MAX_C2_KG_M,
                    "kg/m",
                ));
            }
            if !(t.gravity_n.abs() <= f_max) {
                return Err(load(
                    "a gravity load G(x) beyond the largest cylinder force (sensors.pressure_range_bar[1] × cylinder.piston_area_m2):",
                    t.gravity_n,
                    -f_max,
                    f_max,
                    "N",
                ));
            }
        }
        Ok(())
    }
}
