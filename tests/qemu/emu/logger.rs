//! The firmware's defmt log on the emulated board: counted, not kept.
//! (Decoding defmt needs `defmt-print` on the host; the test reports what
//! it checks over plain semihosting instead.)

use core::sync::atomic::{AtomicU32, Ordering};

static RECORDS: AtomicU32 = AtomicU32::new(0);

/// Log records the firmware wrote.
pub fn records() -> u32 {
    RECORDS.load(Ordering::Relaxed)
}

#[defmt::global_logger]
struct CountingLogger;

// SAFETY: nothing is buffered, so there is no state for concurrent
// records to corrupt; the count is atomic.
unsafe impl defmt::Logger for CountingLogger {
    fn acquire() {
        RECORDS.fetch_add(1, Ordering::Relaxed);
    }

    unsafe fn flush() {}

    unsafe fn release() {}

    unsafe fn write(_bytes: &[u8]) {}
}
