//! The firmware's application tasks on the emulated board, replaying the
//! combined-leak golden case (internal and external leak): the alarm and
//! its verdict as the host computes them, every frame's schedule,
//! contents, CRC and counter, the relay, a corrupted, a valid and a
//! replayed acknowledge command, the watchdog, and the supervisor's
//! reaction when the samples stop. See `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run(&emu::case::BOTH)
}
