//! Faults of the measurement chain, applied to the recorded rows (the
//! machine itself is not affected: an open valve-command wire still drives
//! the real valve with the real command).

use crate::rng::{stream, Rand};
use crate::{Channel, Fault, Row};

/// The recorded field of `channel` in `row`.
fn field(row: &mut Row, channel: Channel) -> &mut Option<f64> {
    match channel {
        Channel::PSupply => &mut row.p_supply,
        Channel::PPiston => &mut row.p_piston,
        Channel::PRod => &mut row.p_rod,
        Channel::PTank => &mut row.p_tank,
        Channel::XPiston => &mut row.x_piston,
        Channel::UValve => &mut row.u_valve,
        Channel::TempOil => &mut row.temp_oil,
    }
}

/// Spike amplitude range of a channel, channel units (bar, m, command, °C).
pub fn spike_range(channel: Channel) -> [f64; 2] {
    match channel {
        Channel::XPiston => [0.005, 0.03],
        Channel::UValve => [0.1, 0.5],
        Channel::TempOil => [5.0, 30.0],
        _ => [5.0, 50.0],
    }
}

/// First sample index at or after `t` (s) at sample period `dt`.
fn index_at(t: f64, dt: f64) -> usize {
    (t / dt - 1e-9).ceil().max(0.0) as usize
}

/// Apply `faults` to `rows` (sample period `dt`, s), in order.
pub(crate) fn apply(rows: &mut [Row], faults: &[Fault], dt: f64, noise_seed: u64) {
    for (i, fault) in faults.iter().enumerate() {
        let mut r = Rand::new(noise_seed, stream::FAULTS + 100 * i as u64);
        match *fault {
            Fault::Spikes {
                channel,
                rate_hz,
                at_s,
            } => {
                let [lo, hi] = spike_range(channel);
                let mut k = index_at(at_s, dt);
                while k < rows.len() {
                    if r.chance(rate_hz * dt) {
                        let len = r.int(1, 3) as usize;
                        let a = r.sign() * r.uniform(lo, hi);
                        for row in rows.iter_mut().skip(k).take(len) {
                            if let Some(v) = field(row, channel) {
                                *v += a;
                            }
                        }
                        k += len;
                    } else {
                        k += 1;
                    }
                }
            }
            Fault::OpenWire { channel, at_s } => {
                let value = if channel == Channel::UValve {
                    Some(0.0)
                } else {
                    None
                };
                for row in rows.iter_mut().skip(index_at(at_s, dt)) {
                    *field(row, channel) = value;
                }
            }
            Fault::Frozen { channel, at_s } => {
                let k0 = index_at(at_s, dt);
                if k0 < rows.len() {
                    let held = *field(&mut rows[k0.saturating_sub(1)], channel);
                    for row in rows.iter_mut().skip(k0) {
                        *field(row, channel) = held;
                    }
                }
            }
            Fault::StuckTime { at_s, for_s } => {
                let k0 = index_at(at_s, dt);
                let k1 = index_at(at_s + for_s, dt).min(rows.len());
                if k0 < k1 {
                    let t0 = rows[k0].t;
                    for row in &mut rows[k0..k1] {
                        row.t = t0;
                    }
                }
            }
            Fault::NanTime { at_s, for_s } => {
                let k0 = index_at(at_s, dt);
                let k1 = index_at(at_s + for_s, dt).min(rows.len());
                for row in rows.iter_mut().take(k1).skip(k0) {
                    row.t = f64::NAN;
                }
            }
            Fault::RandomNoise => {
                for row in rows.iter_mut() {
                    row.p_supply = Some(r.uniform(-2.0, 250.0));
                    row.p_piston = Some(r.uniform(-2.0, 250.0));
                    row.p_rod = Some(r.uniform(-2.0, 250.0));
                    row.p_tank = Some(r.uniform(-2.0, 250.0));
                    row.x_piston = Some(r.uniform(0.0, 0.2));
                    row.u_valve = Some(r.uniform(-1.0, 1.0));
                    if row.temp_oil.is_some() {
                        row.temp_oil = Some(r.uniform(0.0, 80.0));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Leak, RigSpec, Run, Scenario};

    fn base() -> Vec<Row> {
        crate::simulate(&Run {
            rig: RigSpec::random(71, 50.0, 25.0),
            scenario: Scenario::ClosedLoop {
                duration_s: 2.0,
                seed: 1,
            },
            leak: Leak::default(),
            faults: vec![],
            temp_column: true,
            sample_rate_hz: 1000.0,
            noise_seed: 1,
        })
    }

    fn get(mut r: Row, ch: Channel) -> Option<f64> {
        *field(&mut r, ch)
    }

    fn with(rows: &[Row], f: Fault) -> Vec<Row> {
        let mut out = rows.to_vec();
        apply(&mut out, &[f], 1e-3, 5);
        out
    }

    const ALL: [Channel; 7] = [
        Channel::PSupply,
        Channel::PPiston,
        Channel::PRod,
        Channel::PTank,
        Channel::XPiston,
        Channel::UValve,
        Channel::TempOil,
    ];

    #[test]
    fn each_fault_shows_in_the_rows_as_specified() {
        let rows = base();
        let k0 = 1000; // at_s = 1.0
        for ch in ALL {
            // Spikes: only after at_s, 1–3 samples, of the specified size.
            let f = with(
                &rows,
                Fault::Spikes {
                    channel: ch,
                    rate_hz: 20.0,
                    at_s: 1.0,
                },
            );
            let [lo, hi] = spike_range(ch);
            let mut n = 0;
            for k in 0..rows.len() {
                let (a, b) = (rows[k], f[k]);
                let d = get(b, ch).unwrap() - get(a, ch).unwrap();
                if d != 0.0 {
                    assert!(k >= k0, "{ch:?} spike before at_s");
                    assert!(
                        d.abs() >= lo * 0.999 && d.abs() <= hi * 1.001,
                        "{ch:?} spike {d}"
                    );
                    n += 1;
                }
            }
            assert!((5..=60).contains(&n), "{ch:?}: {n} spike samples");
            // Open wire.
            let f = with(
                &rows,
                Fault::OpenWire {
                    channel: ch,
                    at_s: 1.0,
                },
            );
            for (k, r) in f.iter().enumerate() {
                let v = get(*r, ch);
                if k < k0 {
                    assert!(v.is_some());
                } else if ch == Channel::UValve {
                    assert_eq!(v, Some(0.0));
                } else {
                    assert_eq!(v, None);
                }
                // The machine still moves as before.
                assert_eq!(r.truth, rows[k].truth);
            }
            // Frozen: bit-identical repeat of the last reading before at_s.
            let f = with(
                &rows,
                Fault::Frozen {
                    channel: ch,
                    at_s: 1.0,
                },
            );
            let held = get(f[k0 - 1], ch).unwrap().to_bits();
            for r in &f[k0..] {
                assert_eq!(get(*r, ch).unwrap().to_bits(), held);
            }
            assert_eq!(f[..k0], rows[..k0]);
        }
        // Stuck time.
        let f = with(
            &rows,
            Fault::StuckTime {
                at_s: 0.5,
                for_s: 0.2,
            },
        );
        assert!(f[500..700].iter().all(|r| r.t == f[500].t));
        assert_eq!(f[700].t, rows[700].t);
        assert!(f[700].t > f[699].t);
        // NaN time.
        let f = with(
            &rows,
            Fault::NanTime {
                at_s: 0.5,
                for_s: 0.2,
            },
        );
        assert!(f[500..700].iter().all(|r| r.t.is_nan()));
        assert!(f[..500].iter().chain(&f[700..]).all(|r| !r.t.is_nan()));
        // Random noise on every channel.
        let f = with(&rows, Fault::RandomNoise);
        for ch in ALL {
            let v: Vec<f64> = f.iter().map(|r| get(*r, ch).unwrap()).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            let [lo, hi] = match ch {
                Channel::XPiston => [0.0, 0.2],
                Channel::UValve => [-1.0, 1.0],
                Channel::TempOil => [0.0, 80.0],
                _ => [-2.0, 250.0],
            };
            // Uniform over the range: σ = range/√12.
            assert!(
                (sd / ((hi - lo) / 12f64.sqrt()) - 1.0).abs() < 0.1,
                "{ch:?} sd {sd}"
            );
        }
    }
}
