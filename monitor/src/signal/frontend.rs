//! The analogue front end: one millisecond of raw ADC scans in, one
//! [`Sample`] in engineering units out.
//!
//! The ADC scans the channels in [`Channel::ALL`] order; several scans
//! per sample are averaged (oversampling). Each channel is converted by
//! its [`Input`] description, checked (NE43 for current loops, rails for
//! voltage inputs) and debounced ([`Debouncer`]). A required channel that
//! is faulted becomes `None`; a fitted optional temperature sensor that is
//! faulted becomes `Some(NaN)` (a sensor that is not fitted is `None`).
//! Either way the monitor reports a sensor fault of that channel.

use super::current_loop::{ne43_classify, AdcSpec, CurrentLoop, InputFault, OffsetDivider};
use super::ne43::{DebounceConfig, Debounced, Debouncer};
use crate::sample::{Channel, Sample};

/// Number of input channels (one per [`Channel`]).
pub const CHANNELS: usize = Channel::ALL.len();

/// How one channel is wired.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Input {
    /// A 4–20 mA transmitter across a shunt (NE43 checked).
    Loop(CurrentLoop),
    /// A voltage through an offset divider.
    Divider(OffsetDivider),
    /// Nothing connected (only allowed for the optional temperature).
    NotFitted,
}

/// The front end of a board.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrontendConfig {
    /// The ADC.
    pub adc: AdcSpec,
    /// The inputs, in [`Channel::ALL`] order.
    pub inputs: [Input; CHANNELS],
    /// Fault debounce.
    pub debounce: DebounceConfig,
}

/// One converted sample and what the front end saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acquired {
    /// The sample for the monitor.
    pub sample: Sample,
    /// Loop currents (current-loop inputs only), mA, for diagnostics.
    pub loop_ma: [Option<f32>; CHANNELS],
    /// Channels faulted by the front end after debounce (`Channel::bit`).
    pub faulted: u8,
}

/// Mean of each channel over `scans` interleaved scans
/// (`[ch0, ch1, …, ch0, ch1, …]`). Missing trailing data counts as
/// fewer scans; `raw` shorter than one scan gives NaN (a fault).
pub fn average_scans(raw: &[u16]) -> [f32; CHANNELS] {
    let mut sum = [0u32; CHANNELS];
    let scans = raw.len() / CHANNELS;
    for scan in raw.chunks_exact(CHANNELS) {
        for (s, &v) in sum.iter_mut().zip(scan) {
            *s += v as u32;
        }
    }
    let mut out = [f32::NAN; CHANNELS];
    if scans > 0 {
        for (o, s) in out.iter_mut().zip(sum) {
            *o = s as f32 / scans as f32;
        }
    }
    out
}

/// The front end's state (debounce per channel).
#[derive(Clone, Debug)]
pub struct Frontend {
    cfg: FrontendConfig,
    debounce: [Debouncer; CHANNELS],
}

impl Frontend {
    /// A front end for `cfg`.
    pub fn new(cfg: FrontendConfig) -> Self {
        Self {
            cfg,
            debounce: [Debouncer::new(); CHANNELS],
        }
    }

    /// The configuration.
    pub fn config(&self) -> &FrontendConfig {
        &self.cfg
    }

    /// Convert one sample's raw interleaved scans (`[ch0, ch1, …, ch0, …]`,
    /// as [`average_scans`] takes them), taken at `t_s`. NE43 and the rails
    /// are checked on **every scan**, not only on the average: an
    /// intermittent contact that drops one scan of four to 0 mA averages to
    /// a plausible 15 mA, but it is a fault of that channel in this sample.
    pub fn convert_scans(&mut self, t_s: f64, raw: &[u16]) -> Acquired {
        let mut scan_fault = [None; CHANNELS];
        for scan in raw.chunks_exact(CHANNELS) {
            for (i, &code) in scan.iter().enumerate() {
                if scan_fault[i].is_none() {
                    scan_fault[i] = self.check_code(i, code as f32).err();
                }
            }
        }
        self.convert_checked(t_s, &average_scans(raw), scan_fault)
    }

    /// Convert one sample's averaged codes (in [`Channel::ALL`] order),
    /// taken at `t_s`, without the per-scan check of
    /// [`Self::convert_scans`] (the device always has the scans): tests.
    #[cfg(test)]
    pub(crate) fn convert(&mut self, t_s: f64, counts: &[f32; CHANNELS]) -> Acquired {
        self.convert_checked(t_s, counts, [None; CHANNELS])
    }

    /// The fault one code of channel `i` shows on its own, if any.
    fn check_code(&self, i: usize, code: f32) -> Result<(), InputFault> {
        let adc = self.cfg.adc;
        match self.cfg.inputs[i] {
            Input::Loop(l) => ne43_classify(l.milliamps(adc.volts(code))).map(|_| ()),
            Input::Divider(_) if adc.at_rail(code) => Err(InputFault::Saturated),
            Input::Divider(_) | Input::NotFitted => Ok(()),
        }
    }

    fn convert_checked(
        &mut self,
        t_s: f64,
        counts: &[f32; CHANNELS],
        scan_fault: [Option<InputFault>; CHANNELS],
    ) -> Acquired {
        let adc = self.cfg.adc;
        let mut values = [None; CHANNELS];
        let mut loop_ma = [None; CHANNELS];
        let mut faulted = 0u8;
        let mut temp_fitted = true;
        for ch in Channel::ALL {
            let i = ch as usize;
            let c = counts[i];
            let reading = match self.cfg.inputs[i] {
                Input::Loop(l) => {
                    let ma = l.milliamps(adc.volts(c));
                    loop_ma[i] = Some(ma);
                    ne43_classify(ma).map(|ma| l.value(ma))
                }
                Input::Divider(d) if !adc.at_rail(c) => {
                    Ok(d.input_volts(adc.volts(c), adc.vref_v) * d.units_per_volt)
                }
                Input::Divider(_) => Err(InputFault::Saturated),
                Input::NotFitted => {
                    if ch == Channel::TempOil {
                        temp_fitted = false;
                        continue;
                    }
                    Err(InputFault::NotFitted)
                }
            };
            // A fault in any single scan overrides the average.
            let reading = match scan_fault[i] {
                Some(f) if self.cfg.inputs[i] != Input::NotFitted => Err(f),
                _ => reading,
            };
            match self.debounce[i].update(&self.cfg.debounce, reading) {
                Debounced::Valid(v) | Debounced::Held(v) => values[i] = Some(v),
                Debounced::Faulted(_) => faulted |= ch.bit(),
            }
        }
        let temp = Channel::TempOil as usize;
        let sample = Sample {
            t_s,
            p_supply_bar: values[Channel::PSupply as usize],
            p_piston_bar: values[Channel::PPiston as usize],
            p_rod_bar: values[Channel::PRod as usize],
            p_tank_bar: values[Channel::PTank as usize],
            x_piston_m: values[Channel::XPiston as usize],
            u_valve: values[Channel::UValve as usize],
            temp_oil_c: match (temp_fitted, values[temp]) {
                (false, _) => None,
                (true, Some(t)) => Some(t),
                (true, None) => Some(f32::NAN),
            },
        };
        Acquired {
            sample,
            loop_ma,
            faulted,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::{Monitor, Params, Verdict};

    const ADC: AdcSpec = AdcSpec {
        vref_v: 3.3,
        full_scale_counts: 4095.0,
    };
    const BAR: CurrentLoop = CurrentLoop {
        shunt_ohm: 120.0,
        at_4ma: 0.0,
        at_20ma: 250.0,
    };
    const POS: CurrentLoop = CurrentLoop {
        shunt_ohm: 120.0,
        at_4ma: 0.0,
        at_20ma: 0.2,
    };
    const TEMP: CurrentLoop = CurrentLoop {
        shunt_ohm: 120.0,
        at_4ma: -20.0,
        at_20ma: 130.0,
    };
    const CMD: OffsetDivider = OffsetDivider {
        r_in_ohm: 100e3,
        r_up_ohm: 30.1e3,
        r_down_ohm: 43.2e3,
        units_per_volt: 0.1,
    };

    pub(crate) fn config(temp: Input) -> FrontendConfig {
        FrontendConfig {
            adc: ADC,
            inputs: [
                Input::Loop(BAR),
                Input::Loop(BAR),
                Input::Loop(BAR),
                Input::Loop(BAR),
                Input::Loop(POS),
                Input::Divider(CMD),
                temp,
            ],
            debounce: DebounceConfig::DEFAULT,
        }
    }

    /// Codes for a sample in engineering units (what an ideal board reads).
    fn codes(p: [f32; 4], x_m: f32, u: f32, temp_c: f32) -> [f32; CHANNELS] {
        let l = |c: &CurrentLoop, v: f32| ADC.counts(c.volts_for(c.milliamps_for(v)));
        [
            l(&BAR, p[0]),
            l(&BAR, p[1]),
            l(&BAR, p[2]),
            l(&BAR, p[3]),
            l(&POS, x_m),
            ADC.counts(CMD.pin_volts(u / CMD.units_per_volt, ADC.vref_v)),
            l(&TEMP, temp_c),
        ]
    }

    fn close(a: Option<f32>, b: f32, tol: f32) -> bool {
        a.is_some_and(|a| (a - b).abs() <= tol)
    }

    #[test]
    fn averaging_deinterleaves_scans() {
        let raw: [u16; 14] = [1, 2, 3, 4, 5, 6, 7, 3, 4, 5, 6, 7, 8, 9];
        assert_eq!(average_scans(&raw), [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert!(average_scans(&raw[..3]).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn codes_become_engineering_units() {
        let mut f = Frontend::new(config(Input::Loop(TEMP)));
        let a = f.convert(0.25, &codes([50.0, 21.4, 12.9, 0.8], 0.04, -0.3, 40.0));
        let s = a.sample;
        assert_eq!(s.t_s, 0.25);
        assert!(close(s.p_supply_bar, 50.0, 1e-3));
        assert!(close(s.p_piston_bar, 21.4, 1e-3));
        assert!(close(s.p_rod_bar, 12.9, 1e-3));
        assert!(close(s.p_tank_bar, 0.8, 1e-3));
        assert!(close(s.x_piston_m, 0.04, 1e-6));
        assert!(close(s.u_valve, -0.3, 1e-4));
        assert!(close(s.temp_oil_c, 40.0, 1e-3));
        assert_eq!(a.faulted, 0);
        assert!(close(a.loop_ma[0], 7.2, 1e-4));
        assert_eq!(a.loop_ma[5], None, "the command is not a loop");
    }

    #[test]
    fn an_intermittent_contact_is_a_fault_although_its_average_is_valid() {
        let mut f = Frontend::new(config(Input::Loop(TEMP)));
        let good = codes([200.0, 100.0, 80.0, 2.0], 0.1, 0.0, 40.0);
        let mut raw = [0u16; 4 * CHANNELS];
        for (k, v) in raw.iter_mut().enumerate() {
            *v = good[k % CHANNELS].round() as u16;
        }
        let p = Channel::PPiston as usize;
        // One scan of four reads 0 mA (the contact opens for 60 µs): the
        // average is ~75 % of the true current, inside 3.6…21 mA.
        raw[2 * CHANNELS + p] = 0;
        let avg = average_scans(&raw);
        let l = match config(Input::Loop(TEMP)).inputs[p] {
            Input::Loop(l) => l,
            _ => unreachable!(),
        };
        let ma = l.milliamps(ADC.volts(avg[p]));
        assert!(
            ne43_classify(ma).is_ok(),
            "the average alone looks valid: {ma} mA"
        );
        let mut faulted = 0;
        for k in 0..20 {
            let a = f.convert_scans(k as f64 * 1e-3, &raw);
            faulted |= a.faulted;
        }
        assert_eq!(faulted, Channel::PPiston.bit(), "only the piston channel");
        // The same codes averaged first pass unnoticed: what `convert` does.
        let mut g = Frontend::new(config(Input::Loop(TEMP)));
        for k in 0..20 {
            assert_eq!(g.convert(k as f64 * 1e-3, &avg).faulted, 0);
        }
    }

    #[test]
    fn a_broken_loop_faults_its_channel_after_the_debounce() {
        let mut f = Frontend::new(config(Input::NotFitted));
        let good = codes([50.0, 21.4, 12.9, 0.8], 0.04, 0.0, 25.0);
        assert!(f.convert(0.0, &good).sample.p_rod_bar.is_some());
        let mut broken = good;
        broken[Channel::PRod as usize] = ADC.counts(BAR.volts_for(3.5));
        for k in 1..5 {
            let a = f.convert(k as f64 * 1e-3, &broken);
            assert!(
                close(a.sample.p_rod_bar, 12.9, 1e-3),
                "held during the debounce"
            );
            assert_eq!(a.faulted, 0);
        }
        let a = f.convert(0.005, &broken);
        assert_eq!(a.sample.p_rod_bar, None);
        assert_eq!(a.faulted, Channel::PRod.bit());
        assert_eq!(a.sample.temp_oil_c, None, "not fitted: no fault");
    }

    #[test]
    fn an_overdriven_loop_and_a_railed_command_fault() {
        let cfg = FrontendConfig {
            debounce: DebounceConfig {
                fault_samples: 1,
                recover_samples: 1,
            },
            ..config(Input::Loop(TEMP))
        };
        let mut f = Frontend::new(cfg);
        let mut c = codes([50.0, 21.4, 12.9, 0.8], 0.04, 0.0, 25.0);
        c[Channel::PSupply as usize] = ADC.counts(BAR.volts_for(21.0));
        c[Channel::UValve as usize] = 4095.0;
        c[Channel::TempOil as usize] = 0.0;
        let a = f.convert(0.0, &c);
        assert_eq!(a.sample.p_supply_bar, None);
        assert_eq!(a.sample.u_valve, None);
        assert!(a.sample.temp_oil_c.is_some_and(f32::is_nan));
        assert_eq!(
            a.faulted,
            Channel::PSupply.bit() | Channel::UValve.bit() | Channel::TempOil.bit()
        );
    }

    #[test]
    fn the_monitor_reports_a_front_end_fault_as_a_sensor_fault() {
        let mut f = Frontend::new(config(Input::Loop(TEMP)));
        let mut m = Monitor::<f32>::new(&Params::nominal()).unwrap();
        let good = codes([50.0, 21.4, 12.9, 0.8], 0.04, 0.0, 25.0);
        let st = m.step(&f.convert(0.0, &good).sample);
        assert_ne!(st.verdict, Verdict::SensorFault);
        let mut open = good;
        open[Channel::XPiston as usize] = 0.0;
        let mut last = None;
        for k in 1..=5 {
            last = Some(m.step(&f.convert(k as f64 * 1e-3, &open).sample));
        }
        let st = last.unwrap();
        assert_eq!(st.verdict, Verdict::SensorFault);
        assert_eq!(st.faulted_channels, Channel::XPiston.bit());
        // A fitted temperature sensor that faults is reported, but the
        // monitor does not need it: the verdict stays with the estimation.
        let mut hot = good;
        hot[Channel::TempOil as usize] = 4095.0;
        let mut g = Frontend::new(FrontendConfig {
            debounce: DebounceConfig {
                fault_samples: 1,
                recover_samples: 1,
            },
            ..config(Input::Loop(TEMP))
        });
        let mut m = Monitor::<f32>::new(&Params::nominal()).unwrap();
        let st = m.step(&g.convert(0.0, &hot).sample);
        assert_eq!(st.faulted_channels, Channel::TempOil.bit());
        assert_ne!(st.health & crate::status::health::SENSOR_FAULT, 0);
        assert_ne!(st.verdict, Verdict::SensorFault);
    }
}
