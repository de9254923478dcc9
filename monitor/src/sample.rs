//! One sample of the analogue inputs, in engineering units: one row of a
//! recording (`recording-csv.md`), or one conditioned ADC scan on the device.

/// Identifies an input channel (in errors, faults and events).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Channel {
    /// Supply pressure at the valve P port.
    PSupply = 0,
    /// Piston-side chamber pressure.
    PPiston = 1,
    /// Rod-side chamber pressure.
    PRod = 2,
    /// Tank pressure at the valve T port.
    PTank = 3,
    /// Piston position.
    XPiston = 4,
    /// Valve command.
    UValve = 5,
    /// Oil temperature (optional sensor).
    TempOil = 6,
}

impl Channel {
    /// All channels, in `Channel as usize` order.
    pub const ALL: [Channel; 7] = [
        Self::PSupply,
        Self::PPiston,
        Self::PRod,
        Self::PTank,
        Self::XPiston,
        Self::UValve,
        Self::TempOil,
    ];

    /// The column name in a recording.
    pub const fn name(self) -> &'static str {
        match self {
            Self::PSupply => "p_supply",
            Self::PPiston => "p_piston",
            Self::PRod => "p_rod",
            Self::PTank => "p_tank",
            Self::XPiston => "x_piston",
            Self::UValve => "u_valve",
            Self::TempOil => "temp_oil",
        }
    }

    /// Bit of this channel in fault masks.
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// One sample. `None` marks a reading the acquisition could not trust (an
/// empty field in a recording, a 4–20 mA loop outside NAMUR NE43 limits on
/// the device): a sensor fault at this sample, never a zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Time since the start of the recording, s.
    pub t_s: f64,
    /// Supply pressure p2, bar (gauge).
    pub p_supply_bar: Option<f32>,
    /// Piston-chamber pressure p3, bar (gauge).
    pub p_piston_bar: Option<f32>,
    /// Rod-chamber pressure p4, bar (gauge).
    pub p_rod_bar: Option<f32>,
    /// Tank pressure p5, bar (gauge).
    pub p_tank_bar: Option<f32>,
    /// Piston position, m, 0 = fully retracted.
    pub x_piston_m: Option<f32>,
    /// Valve command, normalised to [-1, 1], positive extends.
    pub u_valve: Option<f32>,
    /// Oil temperature, °C, if a sensor is fitted.
    pub temp_oil_c: Option<f32>,
}

impl Sample {
    /// The reading of `channel`.
    pub fn get(&self, channel: Channel) -> Option<f32> {
        match channel {
            Channel::PSupply => self.p_supply_bar,
            Channel::PPiston => self.p_piston_bar,
            Channel::PRod => self.p_rod_bar,
            Channel::PTank => self.p_tank_bar,
            Channel::XPiston => self.x_piston_m,
            Channel::UValve => self.u_valve,
            Channel::TempOil => self.temp_oil_c,
        }
    }

    /// Every reading, in [`Channel::ALL`] order.
    pub fn readings(&self) -> [Option<f32>; 7] {
        Channel::ALL.map(|c| self.get(c))
    }
}
