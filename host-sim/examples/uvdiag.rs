//! How far the piston travels while the valve command reads inside the
//! dead zone. Replays runs of an `eval --json` file from its `--cache`
//! with the cell's calibrated dead zone and null offset and prints, per
//! run, the largest net travel of the (20 ms smoothed) position since the
//! command last read outside the dead zone, after the warm-up; for runs
//! with an open valve-command wire, when that travel first exceeds 1, 2,
//! 3 and 5 mm after the fault, and the monitor's first leak and
//! sensor-fault verdicts after it.
//!
//! `UVDIAG_TRACE=T0,T1,N` also prints every N-th sample from T0 to T1 s:
//! command, opening (less the null offset), position, true and averaged
//! true speed, chamber pressures and the verdict of a stand-alone
//! `CommandAgreement` (contradicted, faulted).
//!
//! `cargo run --release -p host-sim --example uvdiag -- RUNS.json CACHE [ID-SUBSTRING...]`
#[path = "common/eval_runs.rs"]
mod eval_runs;

use eval_runs::{replay_params, EvalRun, EvalRuns};
use monitor::Monitor;

fn main() -> anyhow::Result<()> {
    let runs = EvalRuns::from_args()?;
    const D: [f32; 4] = [1e-3, 2e-3, 3e-3, 5e-3];
    for EvalRun { spec, params } in runs.runs()? {
        let uv = spec.id.contains("u_valve") || spec.id.contains("uvalve");
        if spec.fault.is_some() && !uv {
            continue;
        }
        let params = replay_params(params, &spec)?;
        let dz = params.valve.dead_zone as f32;
        let null = params.valve.null_offset as f32;
        let mut rd = runs.recording(&spec)?;
        let mut m: Option<Monitor<f32>> = if uv {
            Some(Monitor::new(&params).map_err(|e| anyhow::anyhow!("{e}"))?)
        } else {
            None
        };
        let (mut xs, mut anchor, mut last_t): (Option<f32>, f32, f64) = (None, 0.0, 0.0);
        let mut max_disp = 0.0f32;
        let mut max_t = 0.0;
        let mut hit = [None; 4];
        let (mut t_leak, mut t_sf) = (None, None);
        let mut stints = 0u32;
        let mut was_in = false;
        let trace: Option<(f64, f64, usize)> = std::env::var("UVDIAG_TRACE").ok().map(|t| {
            let v: Vec<f64> = t.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2] as usize)
        });
        let mut ca = monitor::signal::plausible::CommandAgreement::new(dz, null);
        let mut i = 0usize;
        let mut vs = 0.0f32;
        while let Some((s, truth)) = rd.next_row()? {
            i += 1;
            if let (Some(x), Some(u)) = (s.x_piston_m, s.u_valve) {
                let c = ca.check(x, u, 1.0 / spec.sample_rate_hz as f32);
                vs += 0.01 * (truth[2] as f32 - vs);
                if let Some((t0, t1, every)) = trace {
                    if s.t_s >= t0 && s.t_s <= t1 && i.is_multiple_of(every) {
                        println!(
                            "  t {:7.3} u {:+.4} op {:+.4} x {:.4} v_true {:+.4} v_true_avg {:+.4} pA {:6.2} pB {:6.2} contra {} fault {}",
                            s.t_s, u, u - null, x, truth[2], vs,
                            s.p_piston_bar.unwrap_or(0.0), s.p_rod_bar.unwrap_or(0.0),
                            c.contradicted as u8, c.faulted as u8
                        );
                    }
                }
            }
            if let Some(m) = m.as_mut() {
                let st = m.step(&s);
                if s.t_s >= 20.0 {
                    if t_leak.is_none() && st.verdict.is_leak() {
                        t_leak = Some(s.t_s - 20.0);
                    }
                    if t_sf.is_none() && st.verdict.name() == "sensor_fault" {
                        t_sf = Some(s.t_s - 20.0);
                    }
                }
            }
            let (Some(x), Some(u)) = (s.x_piston_m, s.u_valve) else {
                xs = None;
                continue;
            };
            let dt = (s.t_s - last_t) as f32;
            last_t = s.t_s;
            let a = (dt / 0.02).clamp(0.0, 1.0);
            let x1 = match xs {
                None => x,
                Some(p) => p + a * (x - p),
            };
            xs = Some(x1);
            let inside = (u - null).abs() <= dz;
            if !inside || s.t_s < 2.0 {
                anchor = x1;
                was_in = false;
                continue;
            }
            if !was_in {
                stints += 1;
                was_in = true;
            }
            let d = (x1 - anchor).abs();
            if d > max_disp && !(uv && s.t_s >= 20.0) {
                max_disp = d;
                max_t = s.t_s;
            }
            if uv && s.t_s >= 20.0 {
                for (h, lim) in hit.iter_mut().zip(D) {
                    if h.is_none() && d > lim {
                        *h = Some(s.t_s - 20.0);
                    }
                }
            }
        }
        let f = |o: Option<f64>| o.map_or("-".to_string(), |t| format!("{t:.2}"));
        println!(
            "{:<52} dz {:.3} null {:+.4} maxdisp {:.2}mm @{:.1} stints {} {}",
            spec.id.trim_start_matches("dev/"),
            dz,
            null,
            max_disp * 1e3,
            max_t,
            stints,
            if uv {
                format!(
                    "| d>1,2,3,5mm at {} {} {} {} | leak {} sf {}",
                    f(hit[0]),
                    f(hit[1]),
                    f(hit[2]),
                    f(hit[3]),
                    f(t_leak),
                    f(t_sf)
                )
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
