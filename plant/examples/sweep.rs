//! Robustness sweep over rigs: `cargo run --release -p plant --example sweep -- N`.
use plant::*;

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let mut total_sim = 0.0;
    let mut total_wall = 0.0;
    for seed in 0..n {
        let supply = [50.0, 100.0, 150.0][(seed % 3) as usize];
        let temp = 20.0 + (seed % 5) as f64 * 8.0;
        let rig = RigSpec::random(seed, supply, temp);
        for (i, scenario) in [
            Scenario::ClosedLoop {
                duration_s: 30.0,
                seed,
            },
            Scenario::StepTest {
                duration_s: 6.0,
                step_at_s: 1.0,
                amplitude: if seed % 2 == 0 { 1.0 } else { -1.0 },
            },
        ]
        .into_iter()
        .enumerate()
        {
            let leak = if seed % 4 == 1 && i == 0 {
                Leak {
                    internal_lpm: 0.2,
                    external_lpm: 0.1,
                    onset_s: 5.0,
                }
            } else {
                Leak::default()
            };
            let run = Run {
                rig: rig.clone(),
                scenario,
                leak,
                faults: vec![],
                temp_column: false,
                sample_rate_hz: 1000.0,
                noise_seed: seed,
            };
            let t0 = std::time::Instant::now();
            let (rows, rep) = simulate_with_report(&run);
            let wall = t0.elapsed().as_secs_f64();
            total_sim += rows.len() as f64 / 1000.0;
            total_wall += wall;
            let finite = rows.iter().all(|r| {
                r.truth.x_m.is_finite() && r.truth.p_chambers_bar.iter().all(|p| p.is_finite())
            });
            let xmin = rows.iter().map(|r| r.truth.x_m).fold(f64::MAX, f64::min);
            let xmax = rows.iter().map(|r| r.truth.x_m).fold(f64::MIN, f64::max);
            let pmin = rows
                .iter()
                .flat_map(|r| r.truth.p_chambers_bar)
                .fold(f64::MAX, f64::min);
            let pmax = rows
                .iter()
                .flat_map(|r| r.truth.p_chambers_bar)
                .fold(f64::MIN, f64::max);
            let rms = (rows
                .iter()
                .map(|r| (r.truth.x_m - r.truth.x_ref_m).powi(2))
                .sum::<f64>()
                / rows.len() as f64)
                .sqrt();
            let vmax = rows.iter().map(|r| r.truth.v_m_s.abs()).fold(0.0, f64::max);
            println!(
                "seed {seed:3} ps {supply:5} T {temp:4} sc {i} fin {finite} fr x [{:7.3},{:7.3}]mm p [{:7.2},{:7.2}] rms {:6.2}mm vmax {:5.0}mm/s {} law {} passes {} ri {:.3} re {:.3} {:.0}x",
                xmin * 1e3, xmax * 1e3, pmin, pmax, rms * 1e3, vmax * 1e3,
                if matches!(rig.friction.law, FrictionLaw::LuGre { .. }) { "LuGre" } else { "Karnopp" }, format!("{:?}", rep.law).chars().take(8).collect::<String>(), rep.passes,
                rep.realised_internal_lpm, rep.realised_external_lpm, rows.len() as f64 / 1000.0 / wall
            );
        }
    }
    println!("overall {:.0}x real time", total_sim / total_wall);
}
