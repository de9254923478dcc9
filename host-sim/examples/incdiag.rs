//! Why a run ends `inconclusive`: replays runs of an `eval --json` file
//! from its `--cache` (as `eval` did) and prints, per run, the final
//! verdict and, over the run's last 20 s, the share of samples whose
//! verdict was `inconclusive` and, of those, the share with each health
//! flag that can withhold `healthy`.
//!
//! `cargo run --release -p host-sim --example incdiag -- RUNS.json CACHE [ID-SUBSTRING...]`
#[path = "common/eval_runs.rs"]
mod eval_runs;

use eval_runs::{replay_params, EvalRun, EvalRuns};
use monitor::status::health;
use monitor::{Monitor, Verdict};

const FLAGS: [(u16, &str); 7] = [
    (health::MODEL_MISMATCH, "mism"),
    (health::HOLD_COMMAND_SHIFTED, "hold"),
    (health::LEAK_WARNING, "warn"),
    (health::LOOP_OSCILLATING, "osc"),
    (health::VALVE_MISFIT, "misfit"),
    (health::EVIDENCE_PAUSED, "paused"),
    (health::PROVISIONAL, "prov"),
];

fn main() -> anyhow::Result<()> {
    let runs = EvalRuns::from_args()?;
    print!("{:<50} {:>6} {:>5}", "run", "final", "inc");
    for (_, n) in FLAGS {
        print!(" {n:>6}");
    }
    println!(" {:>6}", "health");
    for EvalRun { spec, params } in runs.runs()? {
        let params = replay_params(params, &spec)?;
        let mut rd = runs.recording(&spec)?;
        let mut m: Monitor<f32> = Monitor::new(&params).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut rows = Vec::new();
        while let Some(row) = rd.next_row()? {
            rows.push(row);
        }
        let t_end = rows.last().map_or(0.0, |(s, _)| s.t_s);
        let (mut n, mut inc) = (0u32, 0u32);
        let mut with = [0u32; FLAGS.len()];
        let mut last = (Verdict::Inconclusive, 0u16);
        for (s, _) in &rows {
            let st = m.step(s);
            last = (st.verdict, st.health);
            if s.t_s < t_end - 20.0 {
                continue;
            }
            n += 1;
            if st.verdict == Verdict::Inconclusive {
                inc += 1;
                for (j, (f, _)) in FLAGS.iter().enumerate() {
                    with[j] += (st.health & f != 0) as u32;
                }
            }
        }
        print!(
            "{:<50} {:>6} {:>5.2}",
            spec.id,
            &last.0.name()[..last.0.name().len().min(6)],
            inc as f64 / n.max(1) as f64
        );
        for w in with {
            print!(" {:>6.2}", w as f64 / inc.max(1) as f64);
        }
        println!(" {:>#6x}", last.1);
    }
    Ok(())
}
