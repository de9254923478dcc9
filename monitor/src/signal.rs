//! Signal conditioning: sensor offsets, plausibility ranges and fault
//! tracking for one sample in engineering units.
//!
//! A reading that is missing (the acquisition marked it invalid), outside
//! its plausible range, or frozen while the plant moves ([`frozen`]) faults
//! its channel: the monitor then reports a sensor
//! fault, never a leak and never "healthy". The oil temperature is optional:
//! its fault is reported but does not stop the estimation.

use crate::params::Params;
use crate::sample::{Channel, Sample};
use crate::status::{Event, Events};

/// Valve commands beyond ±1 by more than this are implausible.
const U_VALVE_LIMIT: f32 = 1.1;
/// Plausible oil temperatures, °C.
const TEMP_RANGE_C: (f32, f32) = (-30.0, 150.0);

/// A sample with every required channel present, plausible and corrected
/// for sensor offsets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioned {
    /// Supply pressure, bar.
    pub p_supply_bar: f32,
    /// Piston-chamber pressure, bar.
    pub p_piston_bar: f32,
    /// Rod-chamber pressure, bar.
    pub p_rod_bar: f32,
    /// Tank pressure, bar.
    pub p_tank_bar: f32,
    /// Piston position, m.
    pub x_piston_m: f32,
    /// Valve command clamped to [-1, 1].
    pub u_valve: f32,
    /// Oil temperature, °C, if fitted and plausible.
    pub temp_oil_c: Option<f32>,
}

/// Result of checking one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checked {
    /// The conditioned values, `None` if a required channel is faulted.
    pub values: Option<Conditioned>,
    /// Faulted channels (`Channel::bit`).
    pub faulted: u8,
    /// Channels whose reading may be frozen (`frozen`): not leak evidence.
    pub suspect: u8,
}

/// Checks samples and remembers which channels are faulted, to report
/// transitions as events.
#[derive(Clone, Debug)]
pub struct SampleChecker {
    pressure_offsets: [f32; 4],
    position_offset: f32,
    pressure_range: (f32, f32),
    position_range: (f32, f32),
    frozen: frozen::FrozenDetector,
    faulted: u8,
}

impl SampleChecker {
    /// A checker for the sensors described in `params`.
    pub fn new(params: &Params) -> Self {
        let s = &params.sensors;
        let stroke = params.cylinder.stroke_m as f32;
        let margin = s.position_margin_m as f32;
        Self {
            pressure_offsets: s.pressure_offsets_bar.map(|v| v as f32),
            position_offset: s.position_offset_m as f32,
            pressure_range: (
                s.pressure_range_bar[0] as f32,
                s.pressure_range_bar[1] as f32,
            ),
            position_range: (-margin, stroke + margin),
            frozen: frozen::FrozenDetector::new(frozen::FrozenConfig {
                stroke_m: stroke,
                dead_zone: params.valve.dead_zone as f32,
                null_offset: params.valve.null_offset as f32,
            }),
            faulted: 0,
        }
    }

    /// Condition `s`, pushing fault and recovery events. `dt_s` is the
    /// time since the previous sample on the monitor's clock (0 for the
    /// first sample and for one it ignores), for the frozen-reading test.
    pub fn check(&mut self, s: &Sample, dt_s: f32, events: &mut Events) -> Checked {
        let mut faulted = 0u8;
        let mut read = |ch: Channel, offset: f32, lo: f32, hi: f32| -> f32 {
            match s.get(ch) {
                Some(v) if v.is_finite() && (v - offset) >= lo && (v - offset) <= hi => v - offset,
                _ => {
                    faulted |= ch.bit();
                    0.0
                }
            }
        };
        let (plo, phi) = self.pressure_range;
        let p_supply_bar = read(Channel::PSupply, self.pressure_offsets[0], plo, phi);
        let p_piston_bar = read(Channel::PPiston, self.pressure_offsets[1], plo, phi);
        let p_rod_bar = read(Channel::PRod, self.pressure_offsets[2], plo, phi);
        let p_tank_bar = read(Channel::PTank, self.pressure_offsets[3], plo, phi);
        let x_piston_m = read(
            Channel::XPiston,
            self.position_offset,
            self.position_range.0,
            self.position_range.1,
        );
        let u_valve = read(Channel::UValve, 0.0, -U_VALVE_LIMIT, U_VALVE_LIMIT).clamp(-1.0, 1.0);
        let readings = (faulted == 0).then_some(frozen::Readings {
            p_supply_bar,
            p_piston_bar,
            p_rod_bar,
            x_piston_m,
            u_valve,
        });
        let frozen = self.frozen.update(s, dt_s, readings.as_ref());
        faulted |= frozen.frozen;
        let required = faulted;
        let temp_oil_c = match s.temp_oil_c {
            None => None,
            Some(t) if t.is_finite() && t >= TEMP_RANGE_C.0 && t <= TEMP_RANGE_C.1 => Some(t),
            Some(_) => {
                faulted |= Channel::TempOil.bit();
                None
            }
        };
        for ch in Channel::ALL {
            let was = self.faulted & ch.bit() != 0;
            let is = faulted & ch.bit() != 0;
            if is && !was {
                let _ = events.push(Event::SensorFault(ch));
            } else if was && !is {
                let _ = events.push(Event::SensorRecovered(ch));
            }
        }
        self.faulted = faulted;
        let values = (required == 0).then_some(Conditioned {
            p_supply_bar,
            p_piston_bar,
            p_rod_bar,
            p_tank_bar,
            x_piston_m,
            u_valve,
            temp_oil_c,
        });
        Checked {
            values,
            faulted,
            suspect: frozen.suspect,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> Sample {
        Sample {
            t_s: 0.0,
            p_supply_bar: Some(50.0),
            p_piston_bar: Some(21.4),
            p_rod_bar: Some(12.9),
            p_tank_bar: Some(0.8),
            x_piston_m: Some(0.04),
            u_valve: Some(0.0),
            temp_oil_c: None,
        }
    }

    #[test]
    fn missing_or_implausible_readings_fault_their_channel() {
        let mut c = SampleChecker::new(&Params::nominal());
        let mut ev = Events::new();
        assert!(c.check(&good(), 1e-3, &mut ev).values.is_some());
        assert!(ev.is_empty());
        let mut s = good();
        s.p_rod_bar = None;
        s.x_piston_m = Some(0.5);
        let r = c.check(&s, 1e-3, &mut ev);
        assert!(r.values.is_none());
        assert_eq!(r.faulted, Channel::PRod.bit() | Channel::XPiston.bit());
        assert_eq!(
            ev.as_slice(),
            &[
                Event::SensorFault(Channel::PRod),
                Event::SensorFault(Channel::XPiston)
            ]
        );
        ev.clear();
        let r = c.check(&good(), 1e-3, &mut ev);
        assert_eq!(r.faulted, 0);
        assert_eq!(ev.len(), 2);
    }

    #[test]
    fn a_bad_temperature_is_reported_but_not_blocking() {
        let mut c = SampleChecker::new(&Params::nominal());
        let mut ev = Events::new();
        let mut s = good();
        s.temp_oil_c = Some(900.0);
        let r = c.check(&s, 1e-3, &mut ev);
        assert!(r.values.is_some());
        assert_eq!(r.values.unwrap().temp_oil_c, None);
        assert_eq!(r.faulted, Channel::TempOil.bit());
    }

    #[test]
    fn offsets_are_subtracted() {
        let mut p = Params::nominal();
        p.sensors.pressure_offsets_bar = [0.5, -0.2, 0.1, 0.3];
        p.sensors.position_offset_m = 0.002;
        let mut c = SampleChecker::new(&p);
        let v = c.check(&good(), 1e-3, &mut Events::new()).values.unwrap();
        assert_eq!(v.p_supply_bar, 49.5);
        assert_eq!(v.p_piston_bar, 21.6);
        assert_eq!(v.x_piston_m, 0.038);
    }
}

// The device side of the signal chain: ADC codes → loop current →
// engineering units, NAMUR NE43 limits and fault debounce.
pub mod current_loop;
pub mod frontend;
pub mod ne43;
// Frozen readings, checked by `SampleChecker` on the device and the host.
pub mod frozen;
