//! The boundary between the rig simulator and the monitor: a simulated
//! row ([`SimRow`], the simulator's own type) becomes a `monitor::Sample`
//! here and nowhere inside `sim`, which shares no types with the monitor.
//! `host-sim simulate` converts each row as it writes it to a recording;
//! tests that feed the monitor directly convert the same way.

use crate::sim::SimRow;
use monitor::Sample;

impl From<&SimRow> for Sample {
    /// Every channel present (the temperature when the scenario writes
    /// it), each reading rounded to `f32` as the monitor takes it; the
    /// truth flows are not part of a sample.
    fn from(r: &SimRow) -> Self {
        Sample {
            t_s: r.t_s,
            p_supply_bar: Some(r.p_supply_bar as f32),
            p_piston_bar: Some(r.p_piston_bar as f32),
            p_rod_bar: Some(r.p_rod_bar as f32),
            p_tank_bar: Some(r.p_tank_bar as f32),
            x_piston_m: Some(r.x_piston_m as f32),
            u_valve: Some(r.u_valve as f32),
            temp_oil_c: r.temp_oil_c.map(|t| t as f32),
        }
    }
}

impl From<SimRow> for Sample {
    fn from(r: SimRow) -> Self {
        Sample::from(&r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_becomes_a_sample_with_every_reading_and_no_truth() {
        let row = SimRow {
            t_s: 1.5,
            p_supply_bar: 50.1,
            p_piston_bar: 21.4,
            p_rod_bar: 12.9,
            p_tank_bar: 0.8,
            x_piston_m: 0.0412,
            u_valve: -0.25,
            temp_oil_c: None,
            q_internal_lpm: 0.3,
            q_external_lpm: 0.0,
        };
        let s = Sample::from(row);
        assert_eq!(s.t_s, 1.5);
        assert_eq!(s.p_supply_bar, Some(50.1f32));
        assert_eq!(s.p_piston_bar, Some(21.4f32));
        assert_eq!(s.p_rod_bar, Some(12.9f32));
        assert_eq!(s.p_tank_bar, Some(0.8f32));
        assert_eq!(s.x_piston_m, Some(0.0412f32));
        assert_eq!(s.u_valve, Some(-0.25f32));
        assert_eq!(s.temp_oil_c, None);
        let warm = Sample::from(SimRow {
            temp_oil_c: Some(40.0),
            ..row
        });
        assert_eq!(warm.temp_oil_c, Some(40.0f32));
    }
}
