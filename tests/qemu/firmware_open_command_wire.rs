//! The firmware's application tasks on the emulated board with the valve
//! command's wire broken: from 100 ms after the healthy case energised the
//! relay, the command input converts to the code the board map's
//! wire-break bias gives an open input (the ADC rail, `boards::h405`). The
//! front end must fault the channel within its debounce, the relay drop
//! and an alarm frame in state `sensor_fault` name `u_valve`. Without the
//! bias the open input would read a command of +0.19, which nothing flags
//! while the piston holds. See `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run_with_open_command_wire(&emu::case::HEALTHY)
}
