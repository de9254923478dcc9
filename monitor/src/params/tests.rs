//! Unit tests of the parameter bounds, relations and load check. (The
//! TOML-level tests — every field just outside its bound, the defects of
//! issue 12, the property test — are `host-sim/tests/params_bounds.rs`.)

extern crate std;
use super::*;
use crate::physics::load::load_terms_exact;

/// A field and a change of the nominal parameters that must be refused,
/// naming it.
type Case = (&'static str, fn(&mut Params));

#[test]
fn nominal_is_valid() {
    Params::nominal().validate().unwrap();
}

#[test]
fn rejects_nonsense_naming_the_field() {
    let mut p = Params::nominal();
    p.cylinder.rod_side_area_m2 = 4e-3;
    assert_eq!(p.validate().unwrap_err().field, "cylinder.rod_side_area_m2");
    let mut p = Params::nominal();
    p.fluid.bulk_modulus_bar = f64::NAN;
    assert_eq!(p.validate().unwrap_err().field, "fluid.bulk_modulus_bar");
    let mut p = Params::nominal();
    p.alarm.warning_lpm = 0.5;
    assert_eq!(p.validate().unwrap_err().field, "alarm.warning_lpm");
}

#[test]
fn thesis_unit_conversions() {
    // K_v1 = 4.165e-7 m³/(s·√Pa) in l/min/√bar.
    let kv = 4.165e-7 * 60_000.0 * 1e5_f64.sqrt();
    assert!((kv - Valve::NOMINAL.flow_gain_extend_lpm_sqrt_bar).abs() < 1e-3);
    let kv2 = 3.91e-7 * 60_000.0 * 1e5_f64.sqrt();
    assert!((kv2 - Valve::NOMINAL.flow_gain_retract_lpm_sqrt_bar).abs() < 1e-3);
    // K_Lp = 1e-12 m³/(s·Pa) in l/min/bar.
    assert!((1e-12 * 60_000.0 * 1e5 - Leakage::NOMINAL.seal_lpm_per_bar).abs() < 1e-9);
    // Slender-bar inertias m·(2d)²/12.
    let p = Pantograph::NOMINAL;
    let d = [
        p.r1_to_cg1_m,
        p.r21_to_cg21_m,
        p.r22_to_cg22_m,
        p.r3_to_cg3_m,
    ];
    for i in 0..4 {
        let want = p.masses_kg[i] * (2.0 * d[i]) * (2.0 * d[i]) / 12.0;
        assert!((want - p.inertias_kg_m2[i]).abs() < 1e-4, "rod {i}: {want}");
    }
}

#[cfg(feature = "serde")]
#[test]
fn partial_toml_overrides_only_what_it_names() {
    extern crate std;
    use std::string::ToString;
    let p: Params = toml::from_str("[valve]\nnull_offset = 0.002\n").unwrap();
    assert_eq!(p.valve.null_offset, 0.002);
    assert_eq!(p.cylinder, Cylinder::NOMINAL);
    let err = toml::from_str::<Params>("[valve]\nnul_offset = 0.002\n").unwrap_err();
    assert!(err.to_string().contains("nul_offset"), "{err}");
}

#[test]
fn every_field_has_bounds_containing_its_nominal_value() {
    // 99 fields in 11 sections; the table is generated from the same
    // field list as the structs, so a new field cannot lack bounds.
    assert_eq!(Params::bounds().count(), 99);
    for b in Params::bounds() {
        assert!(b.field.contains('.'), "{}", b.field);
        assert!(
            b.ranges.len() == 1 || b.ranges.len() == b.entries,
            "{}",
            b.field
        );
        for i in 0..b.entries {
            let r = b.range(i);
            assert!(
                r.min.is_finite() && r.max.is_finite() && r.min < r.max,
                "{}",
                b.field
            );
        }
    }
    let mut names: [&str; 86] = [""; 86];
    for (n, b) in names.iter_mut().zip(Params::bounds()) {
        *n = b.field;
    }
    names.sort_unstable();
    assert!(names.windows(2).all(|w| w[0] != w[1]), "duplicate field");
}

#[test]
fn out_of_bounds_names_field_value_and_range() {
    let mut p = Params::nominal();
    p.load.masses_kg[3] = 1e30;
    let e = p.validate().unwrap_err();
    assert_eq!(
        (e.field, e.index, e.value),
        ("load.masses_kg", Some(3), 1e30)
    );
    let text = std::format!("{e}");
    assert_eq!(text, "load.masses_kg[3] = 1e30 is outside 0 … 50000 kg");

    let mut p = Params::nominal();
    p.valve.natural_frequency_rad_s = 1e30;
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "valve.natural_frequency_rad_s");
    assert_eq!(
        std::format!("{e}"),
        "valve.natural_frequency_rad_s = 1e30 is outside 30 … 5000 rad/s"
    );

    let mut p = Params::nominal();
    p.filter.warm_up_s = 1e300;
    assert_eq!(
        std::format!("{}", p.validate().unwrap_err()),
        "filter.warm_up_s = 1e300 is outside 0 … 600 s"
    );

    let mut p = Params::nominal();
    p.sensors.position_margin_m = f64::NAN;
    assert_eq!(
        std::format!("{}", p.validate().unwrap_err()),
        "sensors.position_margin_m = NaN is not a finite number; allowed 0 … 1 m"
    );
}

#[test]
fn fields_unchecked_before_are_checked() {
    // Issue 12: load geometry, angle fits, position margin, quiet rate and
    // learning recovery were never checked.
    let cases: [Case; 12] = [
        ("load.theta1_fit_deg", |p| {
            p.load.theta1_fit_deg[0] = f64::NAN
        }),
        ("load.theta2_fit_deg", |p| p.load.theta2_fit_deg[2] = 1e9),
        ("load.base_to_r21_y_m", |p| {
            p.load.base_to_r21_y_m = f64::INFINITY
        }),
        ("load.r21_to_r3_m", |p| p.load.r21_to_r3_m = -1.0),
        ("load.r3_to_cg3_m", |p| p.load.r3_to_cg3_m = 1e6),
        ("load.masses_kg", |p| p.load.masses_kg[1] = 1e30),
        ("load.inertias_kg_m2", |p| p.load.inertias_kg_m2[0] = 1e30),
        ("load.gravity_m_s2", |p| p.load.gravity_m_s2 = -9.81),
        ("sensors.position_margin_m", |p| {
            p.sensors.position_margin_m = -0.01
        }),
        ("filter.quiet_rate_bar_s", |p| {
            p.filter.quiet_rate_bar_s = f64::NAN
        }),
        ("filter.learning_recovery_s", |p| {
            p.filter.learning_recovery_s = -1.0
        }),
        ("filter.learning_recovery_s", |p| {
            p.filter.learning_recovery_s = 1e300
        }),
    ];
    for (field, set) in cases {
        let mut p = Params::nominal();
        set(&mut p);
        let e = p.validate().expect_err(field);
        assert_eq!(e.field, field, "{e}");
    }
}

#[test]
fn relations_name_the_field_and_the_limit() {
    let mut p = Params::nominal();
    p.cylinder.rod_side_area_m2 = 4e-3;
    let e = p.validate().unwrap_err();
    assert_eq!(
        std::format!("{e}"),
        "cylinder.rod_side_area_m2 = 0.004 m² must be smaller than cylinder.piston_area_m2 = 0.003117 m²"
    );
    let cases: [Case; 7] = [
        ("alarm.warning_lpm", |p| p.alarm.warning_lpm = 0.5),
        ("valve.dead_zone", |p| {
            p.valve.null_offset = 0.2;
            p.valve.dead_zone = 0.35;
        }),
        ("friction.breakaway_n", |p| p.friction.breakaway_n = 400.0),
        // 400 bar on 3.1e-3 m² is 125 kN.
        ("friction.breakaway_n", |p| {
            p.friction.coulomb_n = 2e5;
            p.friction.breakaway_n = 2e5;
        }),
        ("load.force_offset_n", |p| p.load.force_offset_n = -2e5),
        // 1 kHz: 4 ms at least.
        ("filter.learning_recovery_s", |p| {
            p.filter.learning_recovery_s = 0.002
        }),
        ("filter.detection_window_s", |p| {
            p.filter.detection_window_s = 5.0
        }),
    ];
    for (field, set) in cases {
        let mut p = Params::nominal();
        set(&mut p);
        let e = p.validate().expect_err(field);
        assert_eq!(e.field, field, "{e}");
    }
    // The shortest time constant scales with the sample period.
    let mut p = Params::nominal();
    p.filter.detection_window_s = 0.006;
    p.filter.sample_period_s = 0.002;
    assert_eq!(p.validate().unwrap_err().field, "filter.detection_window_s");
    p.filter.sample_period_s = 0.001;
    p.validate().unwrap();
}

#[test]
fn load_geometry_must_be_buildable_over_the_stroke() {
    // Nominal: plausible everywhere, with margin.
    let p = Params::nominal();
    for k in 0..STROKE_CHECK_POINTS {
        let x = p.cylinder.stroke_m * k as f64 / (STROKE_CHECK_POINTS - 1) as f64;
        let t = load_terms_exact(&p.load, x);
        assert!(t.mass_kg > 1.0 && t.mass_kg < 1e4, "{t:?}");
        assert!(t.gravity_n.abs() < 0.5 * p.max_cylinder_force_n(), "{t:?}");
    }
    // Rods turning several times round over the stroke.
    let mut p = Params::nominal();
    p.load.theta1_fit_deg[0] = 5000.0;
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "load.theta1_fit_deg");
    assert!(std::format!("{e}").contains("900° over the stroke"), "{e}");
    let mut p = Params::nominal();
    p.load.theta2_fit_deg = [-50_000.0, 9000.0, 0.0];
    assert_eq!(p.validate().unwrap_err().field, "load.theta2_fit_deg");
    // Each mass within bounds, but a load the cylinder cannot lift.
    let mut p = Params::nominal();
    p.load.masses_kg = [50_000.0; 4];
    let e = p.validate().unwrap_err();
    assert!(matches!(e.problem, Problem::Load { .. }), "{e}");
    assert!(std::format!("{e}").contains("gravity load"), "{e}");
    // No moving mass at all: the velocity equation would divide by zero.
    let mut p = Params::nominal();
    p.load.masses_kg = [0.0; 4];
    p.load.inertias_kg_m2 = [0.0; 4];
    let e = p.validate().unwrap_err();
    assert!(std::format!("{e}").contains("effective moving mass"), "{e}");
}

#[test]
fn figures_read_well() {
    use bounds::{Num, Sig};
    let s = |x: f64| std::format!("{}", Sig(x));
    assert_eq!(s(2_608_453.472_542_186_3), "2608453");
    assert_eq!(s(124_680.0), "124680");
    assert_eq!(s(0.499_729_13), "0.499729");
    assert_eq!(s(0.3), "0.3");
    assert_eq!(s(-1.234_567e30), "-1.23457e30");
    assert_eq!(s(2.5e-7), "2.5e-7");
    let n = |x: f64| std::format!("{}", Num(x));
    assert_eq!(n(1e30), "1e30");
    assert_eq!(n(0.003117), "0.003117");
    assert_eq!(n(-350.0), "-350");
    assert_eq!(n(f64::NAN), "NaN");
}

#[test]
fn the_hold_band_is_where_the_command_puts_the_spool_in_the_dead_zone() {
    // The spool sits at command + null offset (as the model has it): a
    // valve whose null offset exceeds its dead zone holds at −null, and a
    // zero command already opens it.
    let mut p = Params::nominal();
    p.valve.dead_zone = 0.005;
    p.valve.null_offset = -0.01;
    let band = p.hold_band();
    let region = |u: f32| operating_region(u, band);
    assert_eq!(region(0.01), 1, "spool centred");
    assert_eq!(region(0.0), 0, "spool at −0.01: retracting");
    assert_eq!(region(0.02), 2, "spool at +0.01: extending");
}
