//! Signal conditioning: sensor offsets, plausibility ranges and fault
//! tracking for one sample in engineering units.
//!
//! A reading that is missing (the acquisition marked it invalid), outside
//! its plausible range, or frozen while the plant moves ([`frozen`]) faults
//! its channel: the monitor then reports a sensor
//! fault, never a leak and never "healthy". The oil temperature is optional
//! (its fault is reported but does not stop the estimation) unless the
//! installation holds the laminar-leakage factor
//! ([`Params::laminar_factor_held`]): then the viscosity rests on it alone,
//! and a missing or implausible temperature is a required channel's fault.

use crate::params::Params;
use crate::sample::{Channel, Sample};
use crate::status::{Event, Events};

/// Valve commands beyond ±1 by more than this are implausible.
const U_VALVE_LIMIT: f32 = 1.1;
/// Every channel's bit.
const ALL_CHANNELS: u8 = (1 << Channel::ALL.len()) - 1;
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
    /// Channels whose reading may be frozen (`frozen`), or was an outlier,
    /// or whose command the motion contradicts (`plausible`): not leak
    /// evidence.
    pub suspect: u8,
    /// A reading was rejected as an outlier at this sample.
    pub outlier: bool,
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
    spikes: plausible::PositionSpikes,
    command: plausible::CommandAgreement,
    /// Noise of the position, piston- and rod-chamber readings.
    noise: [noise::NoiseEstimate; 3],
    faulted: u8,
    /// Channels whose fault stops the estimation (`Channel::bit`).
    required: u8,
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
            spikes: plausible::PositionSpikes::default(),
            command: plausible::CommandAgreement::new(
                params.valve.dead_zone as f32,
                params.valve.null_offset as f32,
            ),
            noise: {
                let f = &params.filter;
                let (tc, period) = (f.noise_time_constant_s as f32, f.sample_period_s as f32);
                let px = s.position_noise_m as f32;
                let pp = s.pressure_noise_bar as f32;
                [
                    noise::NoiseEstimate::new(px, s.position_noise_floor_m as f32, tc, period),
                    noise::NoiseEstimate::new(pp, s.pressure_noise_floor_bar as f32, tc, period),
                    noise::NoiseEstimate::new(pp, s.pressure_noise_floor_bar as f32, tc, period),
                ]
            },
            faulted: 0,
            required: if params.laminar_factor_held() {
                ALL_CHANNELS
            } else {
                ALL_CHANNELS & !Channel::TempOil.bit()
            },
        }
    }

    /// The channels whose fault stops the estimation (`Channel::bit`):
    /// all but the oil temperature, unless the laminar factor is held.
    pub fn required(&self) -> u8 {
        self.required
    }

    /// The estimated white-noise σ of the position (m) and of the piston-
    /// and rod-chamber pressures (bar).
    pub fn noise_sigma(&self) -> [f32; 3] {
        [
            self.noise[0].sigma(),
            self.noise[1].sigma(),
            self.noise[2].sigma(),
        ]
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
        let (x_piston_m, plausibility) = self.plausibility(x_piston_m, u_valve, dt_s, faulted);
        faulted |= plausibility.faulted;
        let readings = (faulted == 0).then_some(frozen::Readings {
            p_supply_bar,
            p_piston_bar,
            p_rod_bar,
            x_piston_m,
            u_valve,
        });
        let frozen = self.frozen.update(s, dt_s, readings.as_ref());
        faulted |= frozen.frozen;
        let temp_oil_c = match s.temp_oil_c {
            Some(t) if t.is_finite() && t >= TEMP_RANGE_C.0 && t <= TEMP_RANGE_C.1 => Some(t),
            None if self.required & Channel::TempOil.bit() == 0 => None,
            _ => {
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
        let values = (faulted & self.required == 0).then_some(Conditioned {
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
            suspect: frozen.suspect | plausibility.suspect,
            outlier: plausibility.outlier,
        }
    }

    /// Spikes on the position, the command against the motion, and the
    /// noise levels of the readings that passed.
    fn plausibility(&mut self, x_m: f32, u: f32, dt_s: f32, faulted: u8) -> (f32, Plausibility) {
        let mut out = Plausibility::default();
        let x_bit = Channel::XPiston.bit();
        if faulted & x_bit != 0 {
            self.spikes.break_sequence();
            self.command.break_sequence();
            self.noise[0].break_sequence();
            return (x_m, out);
        }
        if dt_s <= 0.0 {
            // An ignored sample (time not advancing): nothing to learn.
            return (x_m, out);
        }
        let spike = self.spikes.check(x_m, dt_s, self.noise[0].sigma());
        if spike.outlier {
            out.outlier = true;
            out.suspect |= x_bit;
        } else {
            self.noise[0].update(x_m);
        }
        if spike.faulted {
            out.faulted |= x_bit;
        }
        if faulted & Channel::UValve.bit() == 0 {
            let c = self.command.check(spike.x_m, u, dt_s);
            if c.contradicted {
                out.suspect |= Channel::UValve.bit();
            }
            if c.faulted {
                out.faulted |= Channel::UValve.bit();
            }
        }
        (spike.x_m, out)
    }

    /// Forget the sequence of chamber readings (a fault or a gap).
    pub fn break_pressure_sequence(&mut self) {
        self.noise[1].break_sequence();
        self.noise[2].break_sequence();
    }

    /// Take the chamber readings of a sample into the noise estimates.
    pub fn observe_pressures(&mut self, p_piston_bar: f32, p_rod_bar: f32) {
        self.noise[1].update(p_piston_bar);
        self.noise[2].update(p_rod_bar);
    }
}

/// What the plausibility checks found in one sample.
#[derive(Clone, Copy, Debug, Default)]
struct Plausibility {
    faulted: u8,
    suspect: u8,
    outlier: bool,
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
    fn a_noisy_tank_reading_is_no_fault_but_a_broken_loop_is() {
        // A 400 bar NE43 transmitter on the tank line: 0.3 bar with 0.7 bar
        // of noise, clamped at its lowest measurement, 3.8 mA = −5 bar.
        // No calibration widened the range (a provisional set).
        let mut c = SampleChecker::new(&Params::nominal());
        let mut ev = Events::new();
        let mut rng = crate::testutil::Lcg::new(17);
        let mut s = good();
        for _ in 0..100_000 {
            let p = (0.3 + 0.7 * rng.gaussian() as f32).max(-5.0);
            s.p_tank_bar = Some(p);
            assert_eq!(c.check(&s, 1e-3, &mut ev).faulted, 0, "{p} bar");
        }
        // 3.6 mA, a broken loop, on a 250 bar transmitter.
        s.p_tank_bar = Some(-6.25);
        assert_eq!(c.check(&s, 1e-3, &mut ev).faulted, Channel::PTank.bit());
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
    fn with_the_laminar_factor_held_the_temperature_is_required() {
        let mut p = Params::nominal();
        p.filter.q_laminar = 0.0;
        let mut c = SampleChecker::new(&p);
        let mut ev = Events::new();
        let mut s = good();
        s.temp_oil_c = Some(40.0);
        assert_eq!(
            c.check(&s, 1e-3, &mut ev).values.unwrap().temp_oil_c,
            Some(40.0)
        );
        for bad in [None, Some(f32::NAN), Some(900.0)] {
            s.temp_oil_c = bad;
            let r = c.check(&s, 1e-3, &mut ev);
            assert!(r.values.is_none(), "{bad:?}");
            assert_eq!(r.faulted, Channel::TempOil.bit());
        }
        assert_eq!(ev.as_slice(), &[Event::SensorFault(Channel::TempOil)]);
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
// Each reading's noise level, for the filters' measurement noise.
pub mod noise;
// Whether the machine's position loop hunts.
pub mod oscillation;
// Position spikes and a valve command the motion contradicts.
pub mod plausible;
