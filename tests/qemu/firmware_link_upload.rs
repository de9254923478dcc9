//! The commissioning link, uploading: the healthy case plays in a loop
//! while `scripts/qemu-link-e2e.sh` uploads a changed parameter set with
//! `host-sim params upload` over QEMU's socket; `LM_Identity` must switch
//! from the compiled-in set to the uploaded one, once, and the monitor
//! restart on it. Needs a host on USART1: run by the script, not by
//! `cargo qemu-test`. See `emu/linked.rs`.
#![no_std]
#![no_main]

mod emu;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::linked_run(&emu::case::HEALTHY, emu::Link::Upload)
}
