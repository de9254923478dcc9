//! The firmware's application tasks on the emulated board, replaying the
//! healthy golden case: no leak announced, the relay energised after the
//! warm-up, every frame as the host computes it. See `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run(&emu::case::HEALTHY)
}
