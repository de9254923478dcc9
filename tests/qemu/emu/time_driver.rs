//! The embassy-time driver of the emulated board: SysTick interrupts
//! every 100 µs; between them the time is read from SysTick's current
//! value, so `Instant::now()` has µs resolution. Timers expire on the
//! first tick at or after their deadline (at most 100 µs late, on time
//! for deadlines on the 100 µs grid; a deadline already past wakes its
//! task at once). embassy-stm32's TIM2 driver cannot be used: QEMU does
//! not emulate the STM32's clock tree, and its timers raise no compare
//! interrupts.

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::scb::SystemHandler;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::{Driver, TICK_HZ};
use embassy_time_queue_utils::Queue;

/// SysTick's clock on QEMU's netduinoplus2: the processor clock, 168 MHz
/// of virtual time (checked at start-up against TIM2, see
/// [`super::run`]).
pub const SYSTICK_HZ: u32 = 168_000_000;
/// Interrupt period, µs.
const PERIOD_US: u64 = 100;
/// SysTick counts per µs.
const COUNTS_PER_US: u32 = SYSTICK_HZ / 1_000_000;
/// Reload value for one period.
const RELOAD: u32 = COUNTS_PER_US * PERIOD_US as u32 - 1;

const _: () = assert!(TICK_HZ == 1_000_000, "the driver counts µs");

struct SysTickDriver {
    /// Completed periods since [`start`].
    periods: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
}

impl SysTickDriver {
    fn now_us(&self, cs: CriticalSection<'_>) -> u64 {
        let mut periods = self.periods.borrow(cs).get();
        let mut current = SYST::get_current();
        // Wrapped since the last interrupt, which has not run yet (we are
        // in a critical section or a higher-priority handler).
        if SCB::is_pendst_pending() {
            periods += 1;
            current = SYST::get_current();
        }
        periods * PERIOD_US + ((RELOAD - current) / COUNTS_PER_US) as u64
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.now_us(cs))
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut queue = self.queue.borrow(cs).borrow_mut();
            queue.schedule_wake(at, waker);
            let now = self.now_us(cs);
            if at <= now {
                queue.next_expiration(now);
            }
        })
    }
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    periods: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// Start the tick. `priority`: SysTick's exception priority (it
/// must preempt every executor, as the STM32 board's timer interrupt
/// does).
pub fn start(mut syst: SYST, scb: &mut SCB, priority: u8) {
    // SAFETY: set before the tick starts; nothing depends on the old value.
    unsafe { scb.set_priority(SystemHandler::SysTick, priority) };
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

#[exception]
fn SysTick() {
    critical_section::with(|cs| {
        let periods = DRIVER.periods.borrow(cs);
        periods.set(periods.get() + 1);
        let now = DRIVER.now_us(cs);
        DRIVER.queue.borrow(cs).borrow_mut().next_expiration(now);
    });
}
