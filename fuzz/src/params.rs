//! The parameter loader: what `host_sim::load_params` does with a file's
//! text (`toml::from_str::<Params>`, then `Params::validate`), on arbitrary
//! bytes.
//!
//! Properties: no panic; a refused value names its field (the message
//! starts with the dotted field name); a parameter set that validates
//! gives a `Monitor` (`Monitor::new` validates again and must agree) that
//! runs on samples without panicking; and it survives the TOML round trip
//! `calibrate` relies on (written, read back, equal and still valid).

use monitor::{Monitor, Params, Sample};

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(p) = toml::from_str::<Params>(text) else {
        return;
    };
    if let Err(e) = p.validate() {
        assert!(!e.field.is_empty());
        let msg = e.to_string();
        assert!(
            msg.starts_with(e.field),
            "{msg:?} does not name {}",
            e.field
        );
        assert!(
            Monitor::<f32>::new(&p).is_err(),
            "Monitor::new accepts {msg}"
        );
        return;
    }
    let written = toml::to_string(&p).expect("valid parameters serialise");
    let back: Params = toml::from_str(&written).expect("written parameters read back");
    assert_eq!(back, p, "TOML round trip");
    let mut m = Monitor::<f32>::new(&p).expect("validated parameters give a monitor");
    // A cylinder at rest mid-stroke, then moving, then a data gap and a
    // faulted channel: every path of a step runs once.
    let mut s = Sample {
        t_s: 0.0,
        p_supply_bar: Some(150.0),
        p_piston_bar: Some(40.0),
        p_rod_bar: Some(45.0),
        p_tank_bar: Some(1.0),
        x_piston_m: Some((p.cylinder.stroke_m / 2.0) as f32),
        u_valve: Some(0.0),
        temp_oil_c: Some(40.0),
    };
    for k in 0..20 {
        s.t_s = k as f64 * 1e-3 + if k >= 15 { 1.0 } else { 0.0 };
        s.u_valve = Some(if k >= 10 { 0.3 } else { 0.0 });
        s.p_rod_bar = (k != 15).then_some(45.0);
        m.step(&s);
    }
}
