//! Why a leak run is (not) detected. Replays runs of an `eval --json`
//! file from its `--cache` with the cell's calibrated parameters (as
//! `eval` did) and prints, per run, what the alarm looks at after the onset
//! (from 2 s after it): the alarm level (the user's, raised to the cell's
//! lowest detection floor; a region's floor may be higher), the true
//! flow, the mean evidence weight `w`, the w-weighted detection reading
//! `det` and its 1σ `sd`, the w-weighted share of time the probability
//! gate holds (`pgate`) and that `det − 2·sd`
//! exceeds the alarm level (`lowOK`, an approximation of the CUSUM's
//! input), the reported sizes and σ of both leaks, the final verdict and the
//! first alarm's time after the onset. A second line gives the `both`
//! filter's flow (leak state less the region's baseline, times the pressure
//! difference; unclipped, w-weighted) before and after the onset and the
//! response (after − before) / true flow: 1 when the estimate follows the
//! leak, 0 when something else absorbs it.
//! A third line splits that response by operating region (retracting,
//! holding, extending, from the valve command as the monitor sees it) with
//! each region's share of the post-onset evidence: where the leak is seen,
//! and where it is taken for something else.
//!
//! `cargo run --release -p host-sim --example detdiag -- RUNS.json CACHE [ID-SUBSTRING...]`
//! (no substring: every leak run). `DETDIAG_TRACE=PREFIX` writes a
//! per-10-sample CSV per run with the `both` filter's raw states;
//! `DETDIAG_SET="filter.q_laminar=0;baseline.detection_floor_lpm=[0,0]"`
//! overrides calibrated parameters (JSON values) for ablations.
#[path = "common/eval_runs.rs"]
mod eval_runs;

use eval_runs::{replay_params, EvalRun, EvalRuns};
use monitor::Monitor;

fn main() -> anyhow::Result<()> {
    let runs = EvalRuns::from_args()?;
    let trace = std::env::var("DETDIAG_TRACE").ok();
    println!(
        "{:<46} {:>5} {:>5} {:>5} | {:>5} {:>5} | {:>5} {:>5} {:>5} {:>5} {:>5} {:>5} {:>5} | {:>5} {:>5}",
        "run", "alarm", "truth", "w", "det", "sd", "pgate", "lowOK", "both", "ekfI", "ekfE", "sdI", "sdE", "verd", "t_al"
    );
    for EvalRun {
        spec,
        params: mut pv,
    } in runs.runs()?
    {
        if !spec.has_leak() && !runs.filtered() {
            continue;
        }
        // DETDIAG_SET="filter.q_laminar=0;baseline.detection_floor_lpm=[0,0]"
        if let Ok(set) = std::env::var("DETDIAG_SET") {
            for kv in set.split(';').filter(|s| !s.is_empty()) {
                let (k, val) = kv.split_once('=').unwrap();
                let mut node = &mut pv;
                for part in k.split('.') {
                    node = &mut node[part];
                }
                *node = serde_json::from_str(val)?;
            }
        }
        let params = replay_params(pv, &spec)?;
        let floor = params.baseline.detection_floor_lpm;
        let alarm = [
            params.alarm.alarm_lpm.max(floor[0]),
            params.alarm.alarm_lpm.max(floor[1]),
        ];
        let mut rd = runs.recording(&spec)?;
        let mut m: Monitor<f32> = Monitor::new(&params).map_err(|e| anyhow::anyhow!("{e}"))?;
        let onset = spec.leak.onset_s;
        let k = if spec.internal() { 0 } else { 1 };
        // Sums after onset + 2 s (the leak is there): plain and w-weighted.
        let (mut n, mut sw, mut strue, mut sdet, mut ssd, mut spg, mut slow) =
            (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut sflow = [0.0f64; 2];
        let mut ssds = [0.0f64; 2];
        let mut t_alarm = None;
        let hb = params.hold_band();
        let base = [
            params.baseline.internal_lpm_per_10bar,
            params.baseline.external_lpm_per_10bar,
        ];
        // w-weighted unclipped flow of the leak kind, before [5, onset) and
        // after [onset+2, end), per operating region (retracting, holding,
        // extending): [pre, pre weight, post, post weight, truth, truth weight].
        let mut by_region = [[0.0f64; 6]; 3];
        let mut pre_max = 0.0f64;
        let mut fast = 0.0f64;
        let mut verdict = String::new();
        let mut tw = trace
            .as_ref()
            .map(|p| std::fs::File::create(format!("{p}-{}.csv", spec.id.replace('/', "_"))))
            .transpose()?
            .map(std::io::BufWriter::new);
        if let Some(w) = tw.as_mut() {
            use std::io::Write;
            writeln!(w, "t,q_int,q_ext,w,det_i,det_e,sd_i,sd_e,li,le,pH,pI,pE,pB,verdict,p3,p4,u,th_i,th_e,lam,g_ext,g_ret,thI_i,thE_e,v_true,lvl_i,lvl_e,health,vgd_e,vgd_r,v_healthy,v_both,region,sg_e,sg_r,s_thi,s_the,llH,llI,llE,llB,nisH,nisI,nisE,nisB,ps,pt,x")?;
        }
        let mut i = 0u64;
        while let Some((s, truth)) = rd.next_row()? {
            let st = m.step(&s);
            i += 1;
            verdict = st.verdict.name().to_string();
            if t_alarm.is_none() && st.verdict.is_leak() {
                t_alarm = Some(s.t_s - onset);
            }
            let p: Vec<f64> = st.evidence.iter().map(|e| e.probability as f64).collect();
            let fs =
                m.filter_states()
                    .map_or((0.0f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), |f| {
                        let b = &f[3];
                        (
                            b.x[4] * 100.0,
                            b.x[5] * 100.0,
                            b.x[9],
                            b.x[10],
                            b.x[8],
                            b.x[6],
                            b.x[7],
                            f[1].x[9],
                            f[2].x[9],
                        )
                    });
            // Estimated piston speeds (healthy, both filters), m/s.
            let vel = m
                .filter_states()
                .map_or([f32::NAN; 2], |f| [f[0].x[1] * 0.1, f[3].x[1] * 0.1]);
            // 1σ of the `both` filter's valve gains (relative) and leak states.
            let sd = m.filter_states().map_or([f32::NAN; 4], |f| {
                let b = &f[3];
                let n = b.x.len();
                let d = |i: usize| b.p[i * n + i].max(0.0).sqrt();
                [d(6) * 0.1, d(7) * 0.1, d(9), d(10)]
            });
            if let Some(w) = tw.as_mut() {
                if i.is_multiple_of(10) {
                    use std::io::Write;
                    writeln!(
                        w,
                        "{:.3},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{:.2},{:.2},{:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:#x},{:.4},{:.4},{:.5},{:.5},{},{:.4},{:.4},{:.4},{:.4},{:.1},{:.1},{:.1},{:.1},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.4}",
                        s.t_s,
                        truth[0],
                        truth[1],
                        st.evidence_weight,
                        st.detect_internal_lpm.unwrap_or(f32::NAN),
                        st.detect_external_lpm.unwrap_or(f32::NAN),
                        st.leak_internal_sd_lpm.unwrap_or(f32::NAN),
                        st.leak_external_sd_lpm.unwrap_or(f32::NAN),
                        st.leak_internal_lpm.unwrap_or(f32::NAN),
                        st.leak_external_lpm.unwrap_or(f32::NAN),
                        p[0],
                        p[1],
                        p[2],
                        p[3],
                        st.verdict.name(),
                        fs.0, fs.1, s.u_valve.unwrap_or(f32::NAN), fs.2, fs.3, fs.4, fs.5, fs.6, fs.7, fs.8, truth[2], st.alarm_level_lpm[0], st.alarm_level_lpm[1], st.health, st.valve_gain_deviation[0], st.valve_gain_deviation[1], vel[0], vel[1], m.region(), sd[0], sd[1], sd[2], sd[3], st.evidence[0].log_likelihood, st.evidence[1].log_likelihood, st.evidence[2].log_likelihood, st.evidence[3].log_likelihood, st.evidence[0].mean_nis, st.evidence[1].mean_nis, st.evidence[2].mean_nis, st.evidence[3].mean_nis, s.p_supply_bar.unwrap_or(f32::NAN), s.p_tank_bar.unwrap_or(f32::NAN), s.x_piston_m.unwrap_or(f32::NAN)
                    )?;
                }
            }
            if let Some(f) = m.filter_states() {
                let b = &f[3];
                let region = monitor::params::operating_region(s.u_valve.unwrap_or(0.0), hb);
                let dpi = ((b.x[4] - b.x[5]) as f64).abs() * 10.0;
                let dpe =
                    ((b.x[5] as f64) * 100.0 - s.p_tank_bar.unwrap_or(0.0) as f64).abs() / 10.0;
                let th = if k == 0 { b.x[9] } else { b.x[10] } as f64;
                let flow = (th - base[k][region]) * if k == 0 { dpi } else { dpe };
                let w = st.evidence_weight as f64;
                let a = (0.001 * w / 0.25).min(1.0);
                fast += a * (flow - fast);
                let r = &mut by_region[region];
                if s.t_s >= 5.0 && s.t_s < onset {
                    r[0] += w * flow;
                    r[1] += w;
                    pre_max = pre_max.max(fast.abs());
                } else if s.t_s >= onset + 2.0 {
                    r[2] += w * flow;
                    r[3] += w;
                    r[4] += w * truth[k].abs();
                    r[5] += w;
                }
            }
            if s.t_s < onset + 2.0 {
                continue;
            }
            let det = [st.detect_internal_lpm, st.detect_external_lpm][k].unwrap_or(0.0) as f64;
            let sd = [st.leak_internal_sd_lpm, st.leak_external_sd_lpm][k].unwrap_or(0.0) as f64;
            let pg = if k == 0 { p[1] + p[3] } else { p[2] + p[3] };
            let w = st.evidence_weight as f64;
            n += 1.0;
            sw += w;
            strue += truth[k];
            sdet += w * det;
            ssd += w * sd;
            spg += w * (pg >= 0.9) as u8 as f64;
            slow += w * ((det - 2.0 * sd) > alarm[k]) as u8 as f64;
            sflow[0] += st.leak_internal_lpm.unwrap_or(0.0) as f64;
            sflow[1] += st.leak_external_lpm.unwrap_or(0.0) as f64;
            ssds[0] += st.leak_internal_sd_lpm.unwrap_or(0.0) as f64;
            ssds[1] += st.leak_external_sd_lpm.unwrap_or(0.0) as f64;
        }
        let sw1 = sw.max(1e-9);
        println!(
            "{:<46} {:>5.3} {:>5.3} {:>5.2} | {:>5.3} {:>5.3} | {:>5.2} {:>5.2} {:>5} {:>5.3} {:>5.3} {:>5.3} {:>5.3} | {:>5} {:>5}",
            spec.id.trim_start_matches("dev/"),
            alarm[k],
            strue / n,
            sw / n,
            sdet / sw1,
            ssd / sw1,
            spg / sw1,
            slow / sw1,
            if spec.internal() && spec.external() { "Y" } else { "" },
            sflow[0] / n,
            sflow[1] / n,
            ssds[0] / n,
            ssds[1] / n,
            &verdict[..verdict.len().min(5)],
            t_alarm.map_or("-".to_string(), |t| format!("{t:.1}")),
        );
        let all: [f64; 6] = std::array::from_fn(|j| by_region.iter().map(|r| r[j]).sum());
        let m = |a: f64, b: f64| a / b.max(1e-9);
        let response = |r: &[f64; 6]| (m(r[2], r[3]) - m(r[0], r[1])) / m(r[4], r[5]);
        println!(
            "    flow(w-wtd, unclipped): pre {:+.3} (|fast| max {:.3})  post {:+.3}  truth(w) {:.3}  response (post-pre)/truth {:.2}",
            m(all[0], all[1]), pre_max, m(all[2], all[3]), m(all[4], all[5]), response(&all)
        );
        let share = |r: &[f64; 6]| m(r[3], all[3]);
        println!(
            "    response by region (share of post-onset evidence): retracting {:.2} ({:.0} %)  holding {:.2} ({:.0} %)  extending {:.2} ({:.0} %)",
            response(&by_region[0]), 100.0 * share(&by_region[0]),
            response(&by_region[1]), 100.0 * share(&by_region[1]),
            response(&by_region[2]), 100.0 * share(&by_region[2]),
        );
    }
    Ok(())
}
