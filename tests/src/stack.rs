//! Stack high-water mark by painting: fill the unused stack with a pattern,
//! run, then find the lowest word that no longer holds it.
//!
//! cortex-m-rt places the stack at the top of RAM (`_stack_start`),
//! growing down towards the end of the static data (`_stack_end`).

use core::ptr::{addr_of, read_volatile, write_volatile};

const PAINT: u32 = 0x5A17_C0DE;
/// Bytes below the stack pointer left unpainted (the painting function's
/// own calls).
const MARGIN: usize = 256;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
    static __sdata: u32;
    static __edata: u32;
    static __sbss: u32;
    static __ebss: u32;
    static __suninit: u32;
    static __euninit: u32;
}

fn addr(sym: *const u32) -> usize {
    sym as usize
}

/// Static RAM of the image, bytes: `.data`, `.bss`, `.uninit`.
pub fn static_ram() -> [usize; 3] {
    [
        addr(addr_of!(__edata)) - addr(addr_of!(__sdata)),
        addr(addr_of!(__ebss)) - addr(addr_of!(__sbss)),
        addr(addr_of!(__euninit)) - addr(addr_of!(__suninit)),
    ]
}

/// The current stack pointer.
#[inline(always)]
pub fn sp() -> usize {
    cortex_m::register::msp::read() as usize
}

/// A painted stack region.
#[derive(Clone, Copy, Debug)]
pub struct Painted {
    low: usize,
    high: usize,
}

/// Paint the free stack from its lowest address to [`MARGIN`] bytes below
/// the caller's stack pointer.
#[inline(never)]
pub fn paint() -> Painted {
    let low = addr(addr_of!(_stack_end));
    let high = (sp() - MARGIN) & !3;
    let mut p = low;
    while p < high {
        // SAFETY: [low, high) is RAM below the live stack, unused.
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
    Painted { low, high }
}

impl Painted {
    /// The lowest address written since painting (the deepest the stack
    /// reached), or `None` if the painted region is untouched.
    pub fn lowest_touched(&self) -> Option<usize> {
        let mut p = self.low;
        while p < self.high {
            // SAFETY: inside the painted region.
            if unsafe { read_volatile(p as *const u32) } != PAINT {
                return Some(p);
            }
            p += 4;
        }
        None
    }

    /// Bytes of stack in use at the deepest point, from its top.
    pub fn high_water(&self) -> usize {
        let top = addr(addr_of!(_stack_start));
        top - self.lowest_touched().unwrap_or(self.high)
    }

    /// Bytes that were left to the painted floor at the deepest point.
    pub fn headroom(&self) -> usize {
        self.lowest_touched().unwrap_or(self.high) - self.low
    }
}
