//! The firmware's application tasks on the emulated board with the ADC
//! reference out of range: from 100 ms after the healthy case energised
//! the relay, VREFINT converts to the code VDDA = 2.9 V gives (12 % low;
//! the check allows 5 %), as a sagging analogue supply would. The
//! supervisor's reference check must count 10 such readings (one per
//! 100 ms), then drop the relay and send an alarm frame naming
//! `adc_reference`. See `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

/// VREFINT's code at VDDA = 2.9 V: 1.21 / 2.9 × 4095 = 1708.6.
const VREFINT_AT_2V9: u16 = 1709;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run_with_vrefint(&emu::case::HEALTHY, VREFINT_AT_2V9)
}
