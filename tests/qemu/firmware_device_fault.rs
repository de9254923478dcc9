//! The firmware's application tasks on the emulated board with a device
//! fault injected (the program image's background checksum fails, as a
//! flipped flash bit would make it) once the healthy case has energised the
//! relay: the relay must drop and an alarm frame must name the fault. See
//! `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

use monitor::device::diagnostics::DeviceFault;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run_with_fault(&emu::case::HEALTHY, DeviceFault::FlashImage)
}
