//! The board map of the STM32F405 leak monitor: every pin and every
//! analogue component, in one place. The README's wiring table is this
//! file; change both together.
//!
//! | signal | pin | ADC1 | front end |
//! |---|---|---|---|
//! | supply pressure p_supply | PA0 | IN0 | 4–20 mA, 0–250 bar, 120 Ω shunt |
//! | piston-chamber pressure p_piston | PA1 | IN1 | 4–20 mA, 0–250 bar, 120 Ω shunt |
//! | rod-chamber pressure p_rod | PA2 | IN2 | 4–20 mA, 0–250 bar, 120 Ω shunt |
//! | tank pressure p_tank | PA3 | IN3 | 4–20 mA, 0–16 bar, 120 Ω shunt |
//! | piston position x_piston | PC0 | IN10 | 4–20 mA, 0–200 mm, 120 Ω shunt |
//! | valve command u_valve | PC1 | IN11 | ±10 V via 100 kΩ / 30.1 kΩ to 3.3 V / 43.2 kΩ to GND; 100 kΩ from the terminal to the 24 V loop supply (wire break → rail) |
//! | oil temperature temp_oil (optional) | PC2 | IN12 | 4–20 mA, −20…130 °C, 120 Ω shunt |
//! | fail-safe relay driver | PB12 | | high = energised = healthy; 100 kΩ pull-down on the driver input |
//! | relay read-back | PB13 | | the relay's auxiliary NO contact to GND, 10 kΩ pull-up to 3.3 V: low = energised |
//! | status LED | PC12 | | high = on (Olimex STM32-H405 STAT LED) |
//! | CAN1 RX / TX | PB8 / PB9 | | 3.3 V transceiver (e.g. TJA1051T/3, SN65HVD230), 500 kbit/s |
//! | USB OTG FS DM / DP | PA11 / PA12 | | commissioning link (USB CDC-ACM, Olimex STM32-H405 mini-USB socket); no VBUS sensing |
//! | HSE | PH0 / PH1 | | 8 MHz crystal → 168 MHz, PLL Q → 48 MHz for USB |
//! | SWD | PA13 / PA14 | | probe (flashing, RTT log) |
//!
//! Each analogue input has a 1 kΩ series resistor, 10 nF to ground at the
//! pin (fc ≈ 16 kHz, anti-aliasing for the 4 kHz scan) and a clamp to the
//! 3.3 V rail. A 120 Ω shunt turns 4–20 mA into 0.48–2.4 V; the NE43
//! fault limits 3.6 / 21 mA are 0.43 / 2.52 V, inside the ADC range, so a
//! broken or shorted loop is seen as such.
//!
//! This crate holds no HAL code, so the firmware, the build script of the
//! on-target tests and the emulated board all use this one map; the
//! firmware's `stm32::pins` hands out the pins listed here.

use monitor::signal::current_loop::{AdcSpec, CurrentLoop, OffsetDivider};
use monitor::signal::frontend::{FrontendConfig, Input, CHANNELS};
use monitor::signal::ne43::DebounceConfig;

/// The monitor's sample period, µs (1 kHz).
pub const SAMPLE_PERIOD_US: u32 = 1000;
/// Scans of all channels per 1 ms sample, averaged (oversampling).
pub const SCANS_PER_SAMPLE: usize = 4;
/// ADC trigger rate (TIM3 update → TRGO), Hz.
pub const SCAN_RATE_HZ: u32 = 1000 * SCANS_PER_SAMPLE as u32;
/// Codes per 1 ms block.
pub const BLOCK_LEN: usize = SCANS_PER_SAMPLE * CHANNELS;
/// ADC sample time per channel, ADC clocks: 144 at 21 MHz (6.9 µs; a scan
/// of 7 channels takes 52 µs of the 250 µs between triggers).
pub const ADC_SAMPLE_CYCLES: u16 = 144;

/// Is the optional oil-temperature transmitter fitted? If not, PC2 is
/// not read and the monitor runs without temperature compensation.
pub const TEMP_OIL_FITTED: bool = false;

/// Flash layout of the STM32F405RG (1 MiB, one bank: sectors 0–3 of
/// 16 KiB, sector 4 of 64 KiB, sectors 5–11 of 128 KiB). Offsets are from
/// the flash base 0x0800_0000 (as the flash driver counts them):
///
/// | sectors | addresses | use |
/// |---|---|---|
/// | 0–5 | 0x0800_0000–0x0803_FFFF | program image, 256 KiB (`firmware/image.x` fails the link beyond) |
/// | 6–7 | 0x0804_0000–0x0807_FFFF | parameter sets and boot counter (`link::Storage` map) |
/// | 8–9 | 0x0808_0000–0x080B_FFFF | event memory (`link::Storage` queue) |
/// | 10–11 | 0x080C_0000–0x080F_FFFF | free |
///
/// An erase of a 128 KiB sector stalls the core for 1–2 s (single bank):
/// the link erases only out of service (`link::storage::Erase`).
pub mod flash_layout {
    /// Flash base address.
    pub const BASE: u32 = 0x0800_0000;
    /// The program image's room (sectors 0–5; `firmware/image.x`).
    pub const IMAGE_SIZE: u32 = 256 * 1024;
    /// Size of the sectors the storage uses (5–11).
    pub const SECTOR_SIZE: u32 = 128 * 1024;
    /// Parameter storage (sectors 6–7): offset from [`BASE`].
    pub const PARAMS_OFFSET: u32 = 0x4_0000;
    /// Parameter storage size.
    pub const PARAMS_SIZE: u32 = 2 * SECTOR_SIZE;
    /// Event memory (sectors 8–9): offset from [`BASE`].
    pub const EVENTS_OFFSET: u32 = 0x8_0000;
    /// Event memory size.
    pub const EVENTS_SIZE: u32 = 2 * SECTOR_SIZE;

    const _: () = assert!(PARAMS_OFFSET == IMAGE_SIZE);
    const _: () = assert!(EVENTS_OFFSET == PARAMS_OFFSET + PARAMS_SIZE);
    const _: () = assert!(EVENTS_OFFSET + EVENTS_SIZE <= 1024 * 1024);
}

/// GPIO port of the relay driver (0 = A, 1 = B, …), for the fault handler.
pub const RELAY_PORT: u8 = 1;
/// GPIO pin of the relay driver.
pub const RELAY_PIN: u8 = 12;

const SHUNT_OHM: f32 = 120.0;

const fn pressure(full_scale_bar: f32) -> Input {
    Input::Loop(CurrentLoop {
        shunt_ohm: SHUNT_OHM,
        at_4ma: 0.0,
        at_20ma: full_scale_bar,
    })
}

/// The valve-command input's divider (`FRONTEND`'s `u_valve`).
const U_VALVE_DIVIDER: OffsetDivider = OffsetDivider {
    r_in_ohm: 100e3,
    r_up_ohm: 30.1e3,
    r_down_ohm: 43.2e3,
    units_per_volt: 0.1,
};

/// Wire-break bias of the valve-command input, Ω: from the input terminal
/// to the transmitters' loop supply ([`LOOP_SUPPLY_V`]). Without it an
/// open input floats to the divider's own bias, 1.94 V at the terminal: a
/// command of +0.19 that nothing contradicts while the piston holds. With
/// it an open input is pulled past +10 V and the pin onto the 3.3 V clamp,
/// a code at the rail, which the front end reports as a fault
/// (`InputFault::Saturated`). A driven input moves by (24 V − u)·R_source
/// ⁄ 100 kΩ: 24 mV (a command offset of 0.0024, which calibration's null
/// takes up) behind a 100 Ω controller output.
pub const U_VALVE_BREAK_BIAS_OHM: f32 = 100e3;

/// The 4–20 mA transmitters' loop supply, V (nominal; the bias must reach
/// the rail down to −10 %).
pub const LOOP_SUPPLY_V: f32 = 24.0;

/// Pin voltage of the valve-command input with its wire open and the loop
/// supply at `supply_v`, V (before the clamp): the supply behind the bias
/// resistor is the input's only source.
pub fn u_valve_open_pin_volts(supply_v: f32) -> f32 {
    U_VALVE_DIVIDER.pin_volts_behind(supply_v, U_VALVE_BREAK_BIAS_OHM, FRONTEND.adc.vref_v)
}

/// The analogue front end, in `Channel::ALL` order.
pub const FRONTEND: FrontendConfig = FrontendConfig {
    adc: AdcSpec {
        vref_v: 3.3,
        full_scale_counts: 4095.0,
    },
    inputs: [
        pressure(250.0),
        pressure(250.0),
        pressure(250.0),
        pressure(16.0),
        Input::Loop(CurrentLoop {
            shunt_ohm: SHUNT_OHM,
            at_4ma: 0.0,
            at_20ma: 0.2,
        }),
        Input::Divider(U_VALVE_DIVIDER),
        if TEMP_OIL_FITTED {
            Input::Loop(CurrentLoop {
                shunt_ohm: SHUNT_OHM,
                at_4ma: -20.0,
                at_20ma: 130.0,
            })
        } else {
            Input::NotFitted
        },
    ],
    debounce: DebounceConfig::DEFAULT,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_open_valve_command_wire_reads_at_the_rail_down_to_a_low_loop_supply() {
        let adc = FRONTEND.adc;
        for supply in [0.9 * LOOP_SUPPLY_V, LOOP_SUPPLY_V, 1.1 * LOOP_SUPPLY_V] {
            let pin = u_valve_open_pin_volts(supply);
            // The clamp holds the pin at VREF or above: the top code.
            let code = adc.counts(pin.min(adc.vref_v));
            assert!(
                pin > adc.vref_v && adc.at_rail(code),
                "{supply} V: pin {pin} V"
            );
        }
        // Without the bias the open input reads the divider's own bias:
        // +1.94 V at the terminal, a command of +0.19, inside the range.
        let d = U_VALVE_DIVIDER;
        let vref = adc.vref_v;
        let floating = vref * d.r_down_ohm / (d.r_up_ohm + d.r_down_ohm);
        let command = d.input_volts(floating, vref) * d.units_per_volt;
        assert!((command - 0.194).abs() < 0.002, "{command}");
        assert!(!adc.at_rail(adc.counts(floating)));
    }

    #[test]
    fn the_bias_moves_a_driven_command_by_a_few_thousandths() {
        // A controller output of 100 Ω at −10, 0 and +10 V.
        for u in [-10.0f32, 0.0, 10.0] {
            let shift = (LOOP_SUPPLY_V - u) * 100.0 / U_VALVE_BREAK_BIAS_OHM;
            assert!(
                shift * U_VALVE_DIVIDER.units_per_volt < 0.004,
                "{u} V: {shift} V"
            );
        }
    }
}
