//! From ADC counts to engineering units: the ADC, 4–20 mA current loops
//! read across a shunt resistor, bipolar voltages read through an offset
//! divider, and the NAMUR NE43 limits of a current loop.
//!
//! NE43: a transmitter signals a measurement with 3.8–20.5 mA and a
//! failure with ≤ 3.6 mA or ≥ 21 mA. Currents in between (3.6–3.8 and
//! 20.5–21 mA) are saturated measurements: kept, converted linearly, and
//! left to the monitor's plausibility ranges.

/// NE43: at or below this current, the loop is broken or the transmitter
/// signals a failure, mA.
pub const NE43_FAULT_LOW_MA: f32 = 3.6;
/// NE43: at or above this current, the loop is shorted or the transmitter
/// signals a failure, mA.
pub const NE43_FAULT_HIGH_MA: f32 = 21.0;

/// Why an input has no valid reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InputFault {
    /// Loop current ≤ 3.6 mA (open loop, failed transmitter, no supply).
    LoopLow,
    /// Loop current ≥ 21 mA (short, failed transmitter).
    LoopHigh,
    /// A voltage input at the ADC's rail: the true value is out of range.
    Saturated,
    /// No such input on this board.
    NotFitted,
}

/// Classify a loop current per NE43: the current if it is a measurement.
pub fn ne43_classify(milliamps: f32) -> Result<f32, InputFault> {
    if !(milliamps > NE43_FAULT_LOW_MA) {
        Err(InputFault::LoopLow)
    } else if milliamps >= NE43_FAULT_HIGH_MA {
        Err(InputFault::LoopHigh)
    } else {
        Ok(milliamps)
    }
}

/// The ADC's transfer function.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdcSpec {
    /// Reference voltage (VREF+), V.
    pub vref_v: f32,
    /// Code at the reference voltage (4095 for 12 bits).
    pub full_scale_counts: f32,
}

impl AdcSpec {
    /// Voltage at the pin for a (possibly averaged) code, V.
    pub fn volts(&self, counts: f32) -> f32 {
        counts * self.vref_v / self.full_scale_counts
    }

    /// The code for a pin voltage (for tests and emulated boards).
    pub fn counts(&self, volts: f32) -> f32 {
        volts * self.full_scale_counts / self.vref_v
    }

    /// Is this (averaged) code at either rail?
    pub fn at_rail(&self, counts: f32) -> bool {
        !(counts > 0.5 && counts < self.full_scale_counts - 0.5)
    }
}

/// A 4–20 mA transmitter read across a shunt: 4 mA means `at_4ma`, 20 mA
/// means `at_20ma` (engineering units, e.g. bar or m), linear between and
/// beyond.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CurrentLoop {
    /// Shunt resistance, Ω.
    pub shunt_ohm: f32,
    /// Value at 4 mA, engineering units.
    pub at_4ma: f32,
    /// Value at 20 mA, engineering units.
    pub at_20ma: f32,
}

impl CurrentLoop {
    /// Loop current for the voltage across the shunt, mA.
    pub fn milliamps(&self, volts: f32) -> f32 {
        volts / self.shunt_ohm * 1000.0
    }

    /// Value for a loop current, engineering units.
    pub fn value(&self, milliamps: f32) -> f32 {
        self.at_4ma + (milliamps - 4.0) * ((self.at_20ma - self.at_4ma) / 16.0)
    }

    /// Loop current for a value (for tests and emulated boards), mA.
    pub fn milliamps_for(&self, value: f32) -> f32 {
        4.0 + (value - self.at_4ma) * (16.0 / (self.at_20ma - self.at_4ma))
    }

    /// Shunt voltage for a loop current, V.
    pub fn volts_for(&self, milliamps: f32) -> f32 {
        milliamps * 1e-3 * self.shunt_ohm
    }
}

/// A bipolar voltage (e.g. a ±10 V valve command) brought into the ADC
/// range by three resistors meeting at the ADC pin: `r_in_ohm` from the
/// input, `r_up_ohm` to VREF, `r_down_ohm` to ground.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OffsetDivider {
    /// Resistor from the input to the pin, Ω.
    pub r_in_ohm: f32,
    /// Resistor from the pin to VREF, Ω.
    pub r_up_ohm: f32,
    /// Resistor from the pin to ground, Ω.
    pub r_down_ohm: f32,
    /// Engineering units per input volt (0.1 /V: ±10 V is a ±1 command).
    pub units_per_volt: f32,
}

impl OffsetDivider {
    fn conductance(&self) -> f32 {
        1.0 / self.r_in_ohm + 1.0 / self.r_up_ohm + 1.0 / self.r_down_ohm
    }

    /// Pin volts per input volt.
    pub fn gain(&self) -> f32 {
        (1.0 / self.r_in_ohm) / self.conductance()
    }

    /// Pin voltage at 0 V input, V.
    pub fn offset_v(&self, vref_v: f32) -> f32 {
        (vref_v / self.r_up_ohm) / self.conductance()
    }

    /// Input voltage for a pin voltage, V.
    pub fn input_volts(&self, pin_v: f32, vref_v: f32) -> f32 {
        (pin_v - self.offset_v(vref_v)) / self.gain()
    }

    /// Pin voltage for an input voltage (for tests and emulated boards), V.
    pub fn pin_volts(&self, input_v: f32, vref_v: f32) -> f32 {
        self.offset_v(vref_v) + input_v * self.gain()
    }

    /// Pin voltage for a source of `source_v` behind `source_ohm` at the
    /// input (for a board's design checks: an open input pulled by a bias
    /// resistor is such a source), V.
    pub fn pin_volts_behind(&self, source_v: f32, source_ohm: f32, vref_v: f32) -> f32 {
        let g_in = 1.0 / (self.r_in_ohm + source_ohm);
        (source_v * g_in + vref_v / self.r_up_ohm)
            / (g_in + 1.0 / self.r_up_ohm + 1.0 / self.r_down_ohm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ne43_thresholds() {
        assert_eq!(ne43_classify(3.6), Err(InputFault::LoopLow));
        assert_eq!(ne43_classify(0.0), Err(InputFault::LoopLow));
        assert_eq!(ne43_classify(f32::NAN), Err(InputFault::LoopLow));
        assert_eq!(ne43_classify(3.61), Ok(3.61));
        assert_eq!(
            ne43_classify(3.7),
            Ok(3.7),
            "saturated low: still a reading"
        );
        assert_eq!(
            ne43_classify(20.8),
            Ok(20.8),
            "saturated high: still a reading"
        );
        assert_eq!(ne43_classify(20.99), Ok(20.99));
        assert_eq!(ne43_classify(21.0), Err(InputFault::LoopHigh));
        assert_eq!(ne43_classify(f32::INFINITY), Err(InputFault::LoopHigh));
    }

    #[test]
    fn counts_to_current_to_pressure() {
        let adc = AdcSpec {
            vref_v: 3.3,
            full_scale_counts: 4095.0,
        };
        let p = CurrentLoop {
            shunt_ohm: 120.0,
            at_4ma: 0.0,
            at_20ma: 250.0,
        };
        // 12 mA across 120 Ω = 1.44 V = 1786.9 counts → 125 bar.
        let counts = adc.counts(1.44);
        assert!((counts - 1_786.909).abs() < 1e-2);
        let ma = p.milliamps(adc.volts(counts));
        assert!((ma - 12.0).abs() < 1e-5);
        assert!((p.value(ma) - 125.0).abs() < 1e-3);
        assert!((p.milliamps_for(125.0) - 12.0).abs() < 1e-6);
        assert!((p.volts_for(20.0) - 2.4).abs() < 1e-6);
        // The NE43 limits fit the ADC range with this shunt: 21 mA = 2.52 V.
        assert!(p.volts_for(NE43_FAULT_HIGH_MA) < adc.vref_v);
    }

    #[test]
    fn offset_divider_maps_plus_minus_10v_into_the_adc_range() {
        let d = OffsetDivider {
            r_in_ohm: 100e3,
            r_up_ohm: 30.1e3,
            r_down_ohm: 43.2e3,
            units_per_volt: 0.1,
        };
        let vref = 3.3;
        assert!((d.gain() - 0.15067).abs() < 1e-4);
        assert!((d.offset_v(vref) - 1.6519).abs() < 1e-3);
        let lo = d.pin_volts(-10.0, vref);
        let hi = d.pin_volts(10.0, vref);
        assert!(
            lo > 0.1 && hi < vref - 0.1,
            "±10 V inside 0..3.3 V: {lo} {hi}"
        );
        for v in [-10.0f32, -3.3, 0.0, 5.0, 10.0] {
            assert!((d.input_volts(d.pin_volts(v, vref), vref) - v).abs() < 1e-4);
            assert!((d.pin_volts_behind(v, 0.0, vref) - d.pin_volts(v, vref)).abs() < 1e-5);
        }
        let adc = AdcSpec {
            vref_v: vref,
            full_scale_counts: 4095.0,
        };
        assert!(adc.at_rail(0.0) && adc.at_rail(4095.0) && !adc.at_rail(2048.0));
    }
}
