//! Parameter validation as an installation file meets it (issue 12, item 2):
//! TOML → `Params` → `Params::validate`, the one check used by `replay`
//! (`host_sim::load_params`, `Monitor::new`), `calibrate` (its start and its
//! result) and the firmware build script.
//!
//! - the defects of the issue, each a test that failed before the bounds;
//! - every field of the bounds table enforced from TOML, and every TOML
//!   field in the table;
//! - property tests: hostile values (NaN, ±inf, huge, negative, just outside)
//!   are rejected naming a real field; random values are either rejected
//!   consistently with the table or accepted and give a monitor; small
//!   perturbations of the examples' own (nominal) parameters give a monitor
//!   that tells the healthy example from the internal-leak one.

use std::path::{Path, PathBuf};

use host_sim::calibrate::{Calibration, CalibrationError};
use host_sim::recording::RecordingReader;
use host_sim::replay::{replay, ReplayError};
use monitor::params::{ParamError, Problem};
use monitor::{Monitor, Params};
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngSeed};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

/// Parse and validate a TOML text as `load_params` does.
fn check(text: &str) -> Result<Params, ParamError> {
    let p: Params = toml::from_str(text).unwrap_or_else(|e| panic!("{text}: {e}"));
    p.validate().map(|()| p)
}

/// `load_params` on a temporary file holding `text`: the error message.
fn load_error(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, text).unwrap();
    match host_sim::load_params(&path) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Replay an example through the real `replay` with `params`.
fn replay_example(name: &str, params: &Params) -> Result<&'static str, ReplayError> {
    let reader = RecordingReader::open(&example(name))?;
    replay::<f32, _>(reader, name, params, &mut ()).map(|s| s.verdict)
}

fn all_fields() -> Vec<&'static str> {
    Params::bounds().map(|b| b.field).collect()
}

#[test]
fn nominal_and_calibrated_rig21_are_valid() {
    Params::nominal().validate().unwrap();
    let p = host_sim::load_params(&example("calibrated-rig21.toml")).unwrap();
    p.validate().unwrap();
    Monitor::<f32>::new(&p).unwrap();
}

#[test]
fn issue12_masses_of_1e30_kg_are_rejected() {
    let text = "[load]\nmasses_kg = [1e30, 1e30, 1e30, 1e30]\n";
    let e = check(text).unwrap_err();
    assert_eq!((e.field, e.index), ("load.masses_kg", Some(0)));
    let msg = load_error(text);
    assert!(
        msg.ends_with("load.masses_kg[0] = 1e30 is outside 0 … 50000 kg"),
        "{msg}"
    );
    // `replay` with such parameters (given directly) refuses before the
    // first sample.
    let mut p = Params::nominal();
    p.load.masses_kg = [1e30; 4];
    match replay_example("internal.csv.gz", &p) {
        Err(ReplayError::Params(e)) => assert_eq!(e.field, "load.masses_kg"),
        other => panic!("replayed: {other:?}"),
    }
}

#[test]
fn issue12_natural_frequency_of_1e30_is_rejected() {
    let text = "[valve]\nnatural_frequency_rad_s = 1e30\n";
    assert_eq!(
        check(text).unwrap_err().field,
        "valve.natural_frequency_rad_s"
    );
    let msg = load_error(text);
    assert!(
        msg.ends_with("valve.natural_frequency_rad_s = 1e30 is outside 30 … 5000 rad/s"),
        "{msg}"
    );
    let mut p = Params::nominal();
    p.valve.natural_frequency_rad_s = 1e30;
    assert!(matches!(
        replay_example("healthy.csv.gz", &p),
        Err(ReplayError::Params(_))
    ));
}

#[test]
fn issue12_warm_up_of_1e300_s_is_rejected() {
    let text = "[filter]\nwarm_up_s = 1e300\n";
    assert_eq!(check(text).unwrap_err().field, "filter.warm_up_s");
    let msg = load_error(text);
    assert!(
        msg.ends_with("filter.warm_up_s = 1e300 is outside 0 … 600 s"),
        "{msg}"
    );
}

#[test]
fn issue12_fields_never_checked_before_are_checked() {
    for (text, field) in [
        (
            "[load]\ntheta1_fit_deg = [nan, -19.99]\n",
            "load.theta1_fit_deg",
        ),
        (
            "[load]\ntheta1_fit_deg = [1e7, -19.99]\n",
            "load.theta1_fit_deg",
        ),
        (
            "[load]\ntheta2_fit_deg = [-664.6, 163.9, inf]\n",
            "load.theta2_fit_deg",
        ),
        ("[load]\nbase_to_r21_y_m = 1e30\n", "load.base_to_r21_y_m"),
        ("[load]\nr21_to_r1_m = -0.125\n", "load.r21_to_r1_m"),
        ("[load]\nr3_to_cg3_m = nan\n", "load.r3_to_cg3_m"),
        (
            "[load]\ninertias_kg_m2 = [0.07, 1.3, 0.88, 1e30]\n",
            "load.inertias_kg_m2",
        ),
        ("[load]\ngravity_m_s2 = -9.81\n", "load.gravity_m_s2"),
        (
            "[sensors]\nposition_margin_m = -0.5\n",
            "sensors.position_margin_m",
        ),
        (
            "[sensors]\nposition_margin_m = nan\n",
            "sensors.position_margin_m",
        ),
        (
            "[filter]\nquiet_rate_bar_s = -10.0\n",
            "filter.quiet_rate_bar_s",
        ),
        (
            "[filter]\nquiet_rate_bar_s = inf\n",
            "filter.quiet_rate_bar_s",
        ),
        (
            "[filter]\nlearning_recovery_s = -0.3\n",
            "filter.learning_recovery_s",
        ),
        (
            "[filter]\nlearning_recovery_s = 1e300\n",
            "filter.learning_recovery_s",
        ),
        // A geometry whose rods would turn 2.5 times round over the stroke.
        (
            "[load]\ntheta1_fit_deg = [5000.0, -19.99]\n",
            "load.theta1_fit_deg",
        ),
    ] {
        let e = check(text).expect_err(text);
        assert_eq!(e.field, field, "{text}: {e}");
    }
}

/// The nominal parameters as a TOML table.
fn nominal_table() -> toml::Table {
    toml::Table::try_from(Params::nominal()).unwrap()
}

/// Set entry `index` of dotted `field` in `table` to `v` (an integer field
/// gets `v` rounded; `v` is then within the integer range by construction).
fn set(table: &mut toml::Table, field: &str, index: usize, v: f64) {
    let (section, name) = field.split_once('.').unwrap();
    let slot = table
        .get_mut(section)
        .and_then(|s| s.as_table_mut())
        .and_then(|s| s.get_mut(name))
        .unwrap_or_else(|| panic!("{field} not in the TOML"));
    let slot = match slot {
        toml::Value::Array(a) => &mut a[index],
        other => other,
    };
    *slot = match slot {
        toml::Value::Integer(_) => toml::Value::Integer(v as i64),
        _ => toml::Value::Float(v),
    };
}

fn is_integer(table: &toml::Table, field: &str) -> bool {
    let (section, name) = field.split_once('.').unwrap();
    table[section][name].is_integer()
}

#[test]
fn every_toml_field_is_in_the_bounds_table() {
    let table = nominal_table();
    let mut in_toml = Vec::new();
    for (section, fields) in &table {
        for (name, value) in fields.as_table().unwrap() {
            let entries = value.as_array().map_or(1, Vec::len);
            in_toml.push((format!("{section}.{name}"), entries));
        }
    }
    let mut in_table: Vec<(String, usize)> = Params::bounds()
        .map(|b| (b.field.to_string(), b.entries))
        .collect();
    in_toml.sort();
    in_table.sort();
    assert_eq!(in_toml, in_table);
    assert_eq!(in_table.len(), 99);
}

#[test]
fn every_bound_in_the_table_is_enforced_from_toml() {
    let mut checked = 0;
    for b in Params::bounds() {
        for i in 0..b.entries {
            let r = b.range(i);
            let integer = is_integer(&nominal_table(), b.field);
            let step = |x: f64| {
                if integer {
                    1.0
                } else {
                    (x.abs() * 1e-3).max(1e-9)
                }
            };
            for v in [r.min - step(r.min), r.max + step(r.max)] {
                let mut t = nominal_table();
                set(&mut t, b.field, i, v);
                let text = toml::to_string(&t).unwrap();
                if integer && v < 0.0 {
                    // Not representable in the field's unsigned type:
                    // refused by the parser, naming the field.
                    let e = toml::from_str::<Params>(&text).expect_err(b.field);
                    let name = b.field.split_once('.').unwrap().1;
                    assert!(e.to_string().contains(name), "{e}");
                    checked += 1;
                    continue;
                }
                let e = check(&text).expect_err(b.field);
                assert_eq!(e.field, b.field, "{e}");
                assert_eq!(e.index, (b.entries > 1).then_some(i), "{e}");
                assert!(matches!(e.problem, Problem::OutOfBounds { .. }), "{e}");
                // Readable: the name, the value and the range.
                let msg = e.to_string();
                assert!(
                    msg.starts_with(b.field) && msg.contains(" is outside "),
                    "{msg}"
                );
                checked += 1;
            }
            // The bounds are inclusive: at either end the field itself is
            // not out of bounds (a relation may still refuse the set).
            for v in [r.min, r.max] {
                let mut t = nominal_table();
                set(&mut t, b.field, i, v);
                if let Err(e) = check(&toml::to_string(&t).unwrap()) {
                    assert!(
                        !(e.field == b.field && matches!(e.problem, Problem::OutOfBounds { .. })),
                        "{e}"
                    );
                }
            }
        }
    }
    // Two sides of every entry of every field.
    assert_eq!(checked, 2 * slots().len());
    assert_eq!(slots().len(), 121);
}

#[test]
fn calibrate_refuses_a_fit_outside_the_bounds_with_the_reason() {
    // E.g. a pressure range widened for very noisy transmitters beyond
    // what is plausible: the result is refused, not written.
    let mut cal = Calibration {
        params: Params::nominal(),
        ..Calibration::default()
    };
    cal.params.sensors.pressure_range_bar[0] = -350.0;
    match cal.checked() {
        Err(CalibrationError::InvalidFit { error, report }) => {
            assert_eq!(error.field, "sensors.pressure_range_bar");
            assert!(report.contains("refused because the fitted parameters fail validation: sensors.pressure_range_bar[0] = -350 is outside -200 … 0 bar"), "{report}");
        }
        other => panic!("not refused: {other:?}"),
    }
    let good = Calibration {
        params: Params::nominal(),
        ..Calibration::default()
    };
    assert!(good.checked().is_ok());
}

// ---- property tests ------------------------------------------------------

/// Every (field, entry) of the table, with whether it is an integer.
fn slots() -> Vec<(&'static str, usize, bool)> {
    let t = nominal_table();
    Params::bounds()
        .flat_map(|b| (0..b.entries).map(move |i| (b.field, i)))
        .map(|(f, i)| (f, i, is_integer(&t, f)))
        .collect()
}

/// A value certainly outside the bounds of slot `k`.
fn outside(k: usize, kind: u8, r: f64) -> f64 {
    let (field, i, integer) = slots()[k];
    let range = Params::bounds_of(field).unwrap().range(i);
    if integer {
        // Below an unsigned field's 0 is not even a value of its type.
        return match kind % 2 {
            0 if range.min >= 1.0 => range.min - 1.0,
            _ => range.max + 1.0 + (r * 1e9).floor(),
        };
    }
    match kind % 8 {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 1e30 * (1.0 + r),
        4 => -1e300 * (1.0 + r),
        5 => f64::MAX,
        // Just above / below, by a random margin.
        6 => range.max + range.max.abs().max(1e-9) * (1e-6 + r),
        _ => range.min - range.min.abs().max(1e-9) * (1e-6 + r),
    }
}

/// Any value for slot `k`: hostile, random finite of any magnitude and
/// sign, or a perturbation of the nominal value.
fn anything(k: usize, kind: u8, r: f64, exp: i32, nominal: f64) -> f64 {
    if slots()[k].2 {
        return (r * 40.0).floor();
    }
    match kind % 4 {
        0 => outside(k, kind / 4, r),
        1 => (2.0 * r - 1.0) * 10f64.powi(exp),
        2 => nominal * (1.0 + 0.5 * (2.0 * r - 1.0)),
        _ => -r * 10f64.powi(exp),
    }
}

fn nominal_value(field: &str, i: usize) -> f64 {
    let (section, name) = field.split_once('.').unwrap();
    let v = &nominal_table()[section][name];
    let v = v.as_array().map_or(v, |a| &a[i]);
    v.as_float()
        .or_else(|| v.as_integer().map(|n| n as f64))
        .unwrap()
}

fn config(cases: u32) -> Config {
    Config {
        cases,
        failure_persistence: Some(Box::new(FileFailurePersistence::Off)),
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config(2000))]

    /// A hostile value in one field (plus up to three more fields set to
    /// anything) is rejected, naming a real field; an out-of-bounds error
    /// names one of the fields that were set.
    #[test]
    fn hostile_values_are_rejected_naming_a_real_field(
        bad in (0..slots().len(), any::<u8>(), 0.0..1.0f64),
        more in prop::collection::vec((0..slots().len(), any::<u8>(), 0.0..1.0f64, -40..40i32), 0..4),
    ) {
        let mut t = nominal_table();
        let s = slots();
        let mut touched = vec![(s[bad.0].0, s[bad.0].1)];
        for &(k, kind, r, exp) in &more {
            let (f, i, _) = s[k];
            if (f, i) != touched[0] {
                set(&mut t, f, i, anything(k, kind, r, exp, nominal_value(f, i)));
                touched.push((f, i));
            }
        }
        set(&mut t, s[bad.0].0, s[bad.0].1, outside(bad.0, bad.1, bad.2));
        let text = toml::to_string(&t).unwrap();
        let e = check(&text).expect_err(&text);
        prop_assert!(all_fields().contains(&e.field), "{e}");
        if matches!(e.problem, Problem::OutOfBounds { .. }) {
            let index = e.index.unwrap_or(0);
            prop_assert!(touched.contains(&(e.field, index)), "{e} not among {touched:?}");
        }
        // Display names the field first.
        prop_assert!(e.to_string().starts_with(e.field));
    }

    /// Random values in one to four fields: rejected with an error
    /// consistent with the table, or accepted with every value inside the
    /// table's bounds and a monitor built from them.
    #[test]
    fn random_values_are_rejected_consistently_or_give_a_monitor(
        set_to in prop::collection::vec((0..slots().len(), any::<u8>(), 0.0..1.0f64, -40..40i32), 1..5),
    ) {
        let mut t = nominal_table();
        let s = slots();
        for &(k, kind, r, exp) in &set_to {
            let (f, i, _) = s[k];
            set(&mut t, f, i, anything(k, kind, r, exp, nominal_value(f, i)));
        }
        let text = toml::to_string(&t).unwrap();
        let p: Params = toml::from_str(&text).unwrap();
        match p.validate() {
            Err(e) => {
                prop_assert!(all_fields().contains(&e.field), "{e}");
                if let Problem::OutOfBounds { min, max, .. } = e.problem {
                    prop_assert!(!(e.value >= min && e.value <= max), "{e}");
                }
            }
            Ok(()) => {
                for &(k, _, _, _) in &set_to {
                    let (f, i, _) = s[k];
                    let v = toml::from_str::<toml::Table>(&text).unwrap();
                    let (section, name) = f.split_once('.').unwrap();
                    let v = &v[section][name];
                    let v = v.as_array().map_or(v, |a| &a[i]);
                    let v = v.as_float().or_else(|| v.as_integer().map(|n| n as f64)).unwrap();
                    prop_assert!(Params::bounds_of(f).unwrap().range(i).contains(v), "{f}[{i}] = {v}");
                }
                prop_assert!(Monitor::<f32>::new(&p).is_ok());
            }
        }
    }
}

/// Relative size of the perturbations of the accepted cases.
const PERTURBATION: f64 = 0.03;

proptest! {
    #![proptest_config(Config { rng_seed: RngSeed::Fixed(12), ..config(12) })]

    /// Perturbations of up to ±3 % of several non-zero fields of the
    /// examples' own parameters (they were simulated with the nominal rig)
    /// are accepted and give a monitor that calls the healthy example not
    /// a leak and alarms on the internal-leak example. (Fixed seed: each
    /// case costs two replays; 150 random-seed cases passed when written.)
    #[test]
    fn perturbed_parameters_pass_the_healthy_and_the_leak_example(
        picks in prop::collection::vec((0..slots().len(), -1.0..1.0f64), 1..7),
    ) {
        let mut t = nominal_table();
        let s = slots();
        let mut what = Vec::new();
        for &(k, r) in &picks {
            let (f, i, integer) = s[k];
            let v = nominal_value(f, i);
            if integer || v == 0.0 {
                continue;
            }
            let v = v * (1.0 + PERTURBATION * r);
            set(&mut t, f, i, v);
            what.push(format!("{f}[{i}] = {v}"));
        }
        let text = toml::to_string(&t).unwrap();
        let p = check(&text).unwrap_or_else(|e| panic!("{what:?}: {e}"));
        let healthy = replay_example("healthy.csv.gz", &p).unwrap();
        prop_assert!(matches!(healthy, "healthy" | "inconclusive"), "{what:?}: healthy example → {healthy}");
        let internal = replay_example("internal.csv.gz", &p).unwrap();
        prop_assert!(matches!(internal, "internal" | "both"), "{what:?}: internal example → {internal}");
    }
}
