//! Exact instruction counts in QEMU: TIM2 of the emulated STM32F405.
//!
//! QEMU's STM32 timers count a fixed 1 GHz clock derived from virtual
//! time; with `-icount shift=0` (set by `scripts/qemu-run.sh`) virtual
//! time advances exactly 1 ns per guest instruction, so with PSC = 0 and
//! ARR = 0xFFFF_FFFF the counter advances one tick per executed
//! instruction, identically on every run. The fixed cost of the two
//! counter reads is measured once ([`Counter::overhead`]) and subtracted.
//! On silicon this is *not* a cycle counter: use DWT CYCCNT there.

use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{compiler_fence, Ordering};

const TIM2: usize = 0x4000_0000;
const CR1: usize = 0x00;
const EGR: usize = 0x14;
const CNT: usize = 0x24;
const PSC: usize = 0x28;
const ARR: usize = 0x2C;

fn reg(offset: usize) -> *mut u32 {
    (TIM2 + offset) as *mut u32
}

/// The instruction counter, started and calibrated.
#[derive(Clone, Copy, Debug)]
pub struct Counter {
    overhead: u32,
}

/// The raw counter value.
#[inline(always)]
pub fn now() -> u32 {
    // SAFETY: TIM2's CNT register, a plain read-only-side-effect-free MMIO read.
    unsafe { read_volatile(reg(CNT)) }
}

impl Counter {
    /// Start TIM2 free-running (prescaler 1, full 32-bit reload) and
    /// measure the cost of an empty measurement.
    pub fn start() -> Self {
        // SAFETY: TIM2 registers of the STM32F405 memory map; nothing else
        // uses TIM2 in the test images.
        unsafe {
            write_volatile(reg(CR1), 0);
            write_volatile(reg(PSC), 0);
            write_volatile(reg(ARR), u32::MAX);
            write_volatile(reg(EGR), 1); // UG: load PSC, restart the count
            write_volatile(reg(CR1), 1); // CEN
        }
        let mut c = Self { overhead: 0 };
        let (_, raw) = c.measure(|| ());
        c.overhead = raw;
        c
    }

    /// Instructions of an empty measurement (two counter reads and what
    /// is between them), subtracted from every [`Self::measure`].
    pub fn overhead(&self) -> u32 {
        self.overhead
    }

    /// Run `f` and return its result and the instructions it executed.
    /// Not inlined, so that the caller's code cannot be scheduled between
    /// the two counter reads: only `f` (and its argument set-up) is counted.
    #[inline(never)]
    pub fn measure<R>(&self, f: impl FnOnce() -> R) -> (R, u32) {
        compiler_fence(Ordering::SeqCst);
        let a = now();
        compiler_fence(Ordering::SeqCst);
        let r = f();
        compiler_fence(Ordering::SeqCst);
        let b = now();
        compiler_fence(Ordering::SeqCst);
        (r, b.wrapping_sub(a).wrapping_sub(self.overhead))
    }
}

/// Exactly 64 `nop` instructions (a known cost to validate the counter).
#[inline(always)]
pub fn nop64() {
    // SAFETY: no-ops.
    unsafe {
        core::arch::asm!(
            ".rept 64",
            "nop",
            ".endr",
            options(nomem, nostack, preserves_flags)
        );
    }
}

/// A `subs`/`bne` loop of `n` ≥ 1 iterations: 2·n instructions plus a
/// constant set-up.
#[inline(always)]
pub fn loop2(n: u32) {
    // SAFETY: register-only loop.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {n}, {n}, #1",
            "bne 1b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}
