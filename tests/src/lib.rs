//! Harness for the monitor's on-target tests in QEMU (`netduinoplus2`, an
//! STM32F405 Cortex-M4F): output and exit status over semihosting, panic
//! and fault handlers that fail the run, the golden cases in flash, an
//! exact instruction counter and stack painting.
//!
//! Run with `cargo qemu-test` (bit-identity with the host) and
//! `cargo qemu-bench` (the per-millisecond budget); `scripts/qemu-run.sh`
//! is the cargo runner.
#![no_std]
#![deny(missing_docs)]

pub mod cases;
pub mod counter;
pub mod stack;

use core::fmt::Write;
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio};

pub use cortex_m_semihosting::hprintln as println;

/// The host's standard output as a `fmt::Write` (for multi-line reports).
pub struct Out;

impl Write for Out {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        hio::hstdout()
            .and_then(|mut o| o.write_all(s.as_bytes()))
            .map_err(|_| core::fmt::Error)
    }
}

/// End the run: QEMU exits with status 0 if `passed`, 1 otherwise.
pub fn exit(passed: bool) -> ! {
    debug::exit(if passed {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached without a semihosting host.
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m_semihosting::hprintln!("FAILED: panic: {}", info);
    exit(false)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    cortex_m_semihosting::hprintln!("FAILED: HardFault at pc {:#010x}", frame.pc());
    exit(false)
}
