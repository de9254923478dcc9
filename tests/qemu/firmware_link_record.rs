//! The commissioning link, recording: the combined-leak case starts when
//! the host starts the stream; `scripts/qemu-link-e2e.sh` captures it with
//! `host-sim record` over QEMU's socket and compares the recording with
//! the samples the host's pipeline steps. In QEMU every frame is checked
//! as in `firmware_leak`, then the stream (every block sent, none
//! dropped). Needs a host on USART1: run by the script, not by
//! `cargo qemu-test`. See `emu/linked.rs`.
#![no_std]
#![no_main]

mod emu;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::linked_run(&emu::case::BOTH, emu::Link::Record)
}
