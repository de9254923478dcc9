//! The reader and writer on small texts.

use super::*;

fn read_all(text: &str) -> Result<Vec<Sample>, RecordingError> {
    RecordingReader::new(text.as_bytes(), "test.csv")?.collect()
}

const GOOD: &str = "# format=leak-recording/1\n# sample_rate_hz=1000\n\
    t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve,temp_oil\n\
    0.000,50.12,21.40,12.95,0.80,0.0412,0.000,25.1\n\
    0.001,50.10,21.43,12.93,0.81,0.0412,0.000,25.1\n";

#[test]
fn reads_the_spec_example() {
    let r = RecordingReader::new(GOOD.as_bytes(), "x.csv").unwrap();
    assert_eq!(r.meta("sample_rate_hz"), Some("1000"));
    let s: Vec<Sample> = r.collect::<Result<_, _>>().unwrap();
    assert_eq!(s.len(), 2);
    assert_eq!(s[1].t_s, 0.001);
    assert_eq!(s[0].p_rod_bar, Some(12.95));
    assert_eq!(s[0].temp_oil_c, Some(25.1));
}

#[test]
fn column_order_is_free_unknown_columns_ignored_crlf_ok() {
    let text = "u_valve,t,note,x_piston,p_tank,p_rod,p_piston,p_supply\r\n0.1,0.5,hello,0.05,1,13,21,50\r\n";
    let s = read_all(text).unwrap();
    assert_eq!(s[0].t_s, 0.5);
    assert_eq!(s[0].u_valve, Some(0.1));
    assert_eq!(s[0].p_supply_bar, Some(50.0));
    assert_eq!(s[0].temp_oil_c, None);
}

#[test]
fn empty_field_is_a_missing_reading_not_zero() {
    let text = "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,,13,1,0.05,0\n";
    let s = read_all(text).unwrap();
    assert_eq!(s[0].p_piston_bar, None);
}

fn err(text: &str) -> String {
    read_all(text).unwrap_err().to_string()
}

#[test]
fn missing_column_is_named() {
    let e = err("t,p_supply,p_piston,p_tank,x_piston,u_valve\n0,1,2,3,4,5\n");
    assert!(e.contains("test.csv:1") && e.contains("`p_rod`"), "{e}");
}

#[test]
fn bad_number_names_line_and_column() {
    let e = err("# c\nt,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n0.001,50,2l.5,13,1,0.05,0\n");
    assert!(
        e.contains("test.csv:4") && e.contains("column 3 `p_piston`") && e.contains("2l.5"),
        "{e}"
    );
}

#[test]
fn nan_and_infinity_are_rejected() {
    for bad in ["NaN", "nan", "inf", "-Infinity"] {
        let e = err(&format!(
            "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,{bad},1,0.05,0\n"
        ));
        assert!(
            e.contains("test.csv:2") && e.contains("`p_rod`") && e.contains("finite"),
            "{e}"
        );
    }
}

#[test]
fn time_must_strictly_increase() {
    let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n0.002,50,21,13,1,0.05,0\n0.002,50,21,13,1,0.05,0\n");
    assert!(
        e.contains("test.csv:4") && e.contains("`t`") && e.contains("does not increase"),
        "{e}"
    );
    let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n,50,21,13,1,0.05,0\n");
    assert!(
        e.contains("test.csv:3") && e.contains("`t` is empty"),
        "{e}"
    );
}

#[test]
fn structural_errors() {
    assert!(err("# only comments\n").contains("no header"));
    let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05\n");
    assert!(
        e.contains("test.csv:2") && e.contains("expected 7 fields"),
        "{e}"
    );
    let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n# late\n");
    assert!(
        e.contains("test.csv:3") && e.contains("after the header"),
        "{e}"
    );
    let e = err("t,t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n");
    assert!(e.contains("appears twice"), "{e}");
}

#[test]
fn write_then_read_round_trips() {
    let mut buf = Vec::new();
    let mut w = RecordingWriter::new(
        &mut buf,
        &[("note", "a\nb".into())],
        true,
        &["q_internal_lpm"],
    )
    .unwrap();
    let s = Sample {
        t_s: 0.123,
        p_supply_bar: Some(50.125),
        p_piston_bar: None,
        p_rod_bar: Some(12.5),
        p_tank_bar: Some(0.75),
        x_piston_m: Some(0.041_234),
        u_valve: Some(-0.125),
        temp_oil_c: Some(40.0),
    };
    w.write(&s, &[0.4]).unwrap();
    w.finish().unwrap();
    let text = String::from_utf8(buf).unwrap();
    let r = RecordingReader::new(text.as_bytes(), "rt.csv").unwrap();
    assert_eq!(r.meta("note"), Some("a b"));
    assert_eq!(r.extra_columns(), &[("q_internal_lpm".to_string(), 8)]);
    let back: Vec<Sample> = r.collect::<Result<_, _>>().unwrap();
    assert_eq!(back[0], s);
}
