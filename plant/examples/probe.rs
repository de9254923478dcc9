//! Quick look at a run: `cargo run --release -p plant --example probe -- SEED`.
use plant::*;

fn main() {
    let seed: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let kind = std::env::args().nth(2).unwrap_or_else(|| "closed".into());
    let rig = RigSpec::random(seed, 50.0, 25.0);
    let scenario = match kind.as_str() {
        "step" => Scenario::StepTest {
            duration_s: 10.0,
            step_at_s: 3.0,
            amplitude: 0.6,
        },
        "hold" => Scenario::LongHold {
            hold_s: 600.0,
            seed,
        },
        _ => Scenario::ClosedLoop {
            duration_s: 60.0,
            seed,
        },
    };
    let leak_lpm: f64 = std::env::args()
        .nth(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    let run = Run {
        rig,
        scenario,
        leak: Leak {
            internal_lpm: leak_lpm,
            external_lpm: 0.0,
            onset_s: 5.0,
        },
        faults: vec![],
        temp_column: true,
        sample_rate_hz: 1000.0,
        noise_seed: seed,
    };
    let t0 = std::time::Instant::now();
    let (rows, rep) = simulate_with_report(&run);
    let el = t0.elapsed().as_secs_f64();
    let dur = rows.len() as f64 / 1000.0;
    println!(
        "{} rows in {:.3} s ({:.0}x real time)  {:?}",
        rows.len(),
        el,
        dur / el,
        rep
    );
    let step = (rows.len() / 40).max(1);
    for r in rows.iter().step_by(step) {
        let t = &r.truth;
        println!(
            "t={:7.2} x={:7.2}mm v={:7.2}mm/s pa={:6.2} pb={:6.2} ps={:6.2} pt={:5.2} u={:6.3} s={:6.3} qi={:7.4} stop={} | xm={:?} pam={:?}",
            r.t, t.x_m * 1e3, t.v_m_s * 1e3, t.p_chambers_bar[0], t.p_chambers_bar[1], t.p_supply_bar, t.p_tank_bar,
            r.u_valve.unwrap_or(f64::NAN), t.spool, t.internal_lpm, t.at_end_stop, r.x_piston, r.p_piston
        );
    }
}
