//! The panic handler. Where the panic happened goes to the log (defmt over
//! RTT, read with a probe); then the core faults on purpose, and the
//! hard-fault handler (`system.rs`) drops the relay and resets.
//!
//! The panic's message is not formatted: that would link `core::fmt`
//! (≈ 2 KB) into an image whose flash is budgeted. A `defmt::panic!` has
//! logged its own message before it gets here.

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    static PANICKED: AtomicBool = AtomicBool::new(false);
    cortex_m::interrupt::disable();
    // A panic while logging one goes straight to the fault.
    if !PANICKED.swap(true, Ordering::Relaxed) {
        match info.location() {
            Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
            None => defmt::error!("panic"),
        }
    }
    // UDF: a hard fault, like a fault of the program itself.
    cortex_m::asm::udf()
}
