//! Core services of the STM32 board: reset cause, DWT cycle counter,
//! independent watchdog, status LED, and the fault handler that
//! de-energises the relay.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::pac;
use embassy_stm32::peripherals::{IWDG, PC12, RNG};
use embassy_stm32::rng::{self, Rng};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, Peri};
use monitor::device::diagnostics::brownout::{self, BorLevel};
use monitor::protocol::ResetCause;

use super::clocks::SYSCLK_HZ;
use firmware::app::SAMPLE_PERIOD_US;
use firmware::board::{CycleCounter, StatusLed, Watchdog};

/// Watchdog timeout, µs. The LSI clock of the F405 may run anywhere from
/// 17 to 47 kHz, so the real timeout is 170–470 ms; the supervisor feeds
/// every 10 ms while the estimator keeps its deadline.
pub const WATCHDOG_TIMEOUT_US: u32 = 250_000;

bind_interrupts!(struct RngIrqs {
    RNG => rng::InterruptHandler<embassy_stm32::peripherals::RNG>;
});

/// The seed of this boot's acknowledge challenges: 64 bits from the true
/// RNG (analogue noise, so it differs at every boot), mixed with the
/// chip's 96-bit unique ID so that two units never share a sequence even
/// if one RNG were stuck. The RNG is switched off again afterwards.
pub fn challenge_seed(rng: Peri<'static, RNG>) -> u64 {
    let mut r = Rng::new(rng, RngIrqs);
    let random = r.next_u64();
    let uid = embassy_stm32::uid::uid();
    let mut mixed = random;
    for chunk in uid.chunks(8) {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        // A multiply-xorshift round per word (mixing, not secrecy: the
        // challenges are keyed by the acknowledge key).
        mixed = (mixed ^ u64::from_le_bytes(b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        mixed ^= mixed >> 29;
    }
    mixed
}

/// Why the chip last reset; clears the flags so the next reset reads
/// fresh ones.
pub fn take_reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read();
    let cause = if csr.wdgrstf() {
        ResetCause::Watchdog
    } else if csr.wwdgrstf() {
        ResetCause::WindowWatchdog
    } else if csr.lpwrrstf() {
        ResetCause::LowPower
    } else if csr.sftrstf() {
        ResetCause::Software
    } else if csr.porrstf() {
        ResetCause::PowerOn
    } else if csr.borrstf() {
        ResetCause::BrownOut
    } else if csr.padrstf() {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    };
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    cause
}

/// Make sure the brown-out reset level is the one the monitor requires
/// (`monitor::device::diagnostics::brownout`), programming the option bytes
/// once if it is lower (a factory-fresh part has it off). Returns the level
/// now in force; a level still too low after programming is a device fault
/// for the caller.
pub fn ensure_brownout_level() -> BorLevel {
    let optcr = pac::FLASH.optcr().read().0;
    let Some(wanted) = brownout::required_optcr(optcr) else {
        return brownout::level(optcr);
    };
    // RM0090 §3.6.2: unlock the option bytes, write, start, wait, lock.
    pac::FLASH.optkeyr().write_value(0x0819_2A3B);
    pac::FLASH.optkeyr().write_value(0x4C5D_6E7F);
    pac::FLASH
        .optcr()
        .write_value(pac::flash::regs::Optcr(wanted));
    pac::FLASH.optcr().modify(|w| w.set_optstrt(true));
    while pac::FLASH.sr().read().bsy() {}
    pac::FLASH.optcr().modify(|w| w.set_optlock(true));
    brownout::level(pac::FLASH.optcr().read().0)
}

/// The DWT cycle counter.
pub struct Dwt;

impl Dwt {
    /// Enable the cycle counter.
    pub fn new(mut dcb: cortex_m::peripheral::DCB, mut dwt: cortex_m::peripheral::DWT) -> Self {
        dcb.enable_trace();
        dwt.enable_cycle_counter();
        Self
    }
}

impl CycleCounter for Dwt {
    const CYCLES_PER_SAMPLE: u32 = (SYSCLK_HZ as u64 * SAMPLE_PERIOD_US as u64 / 1_000_000) as u32;

    fn cycles(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}

/// The independent watchdog, started.
pub struct Iwdg(IndependentWatchdog<'static, IWDG>);

/// Set once the independent watchdog runs (`Iwdg::start`): the flash
/// storage stretches its timeout around a sector erase only while it runs
/// (before, the LSI that clocks it may still be off: a prescaler update
/// would never complete).
static WATCHDOG_STARTED: AtomicBool = AtomicBool::new(false);

/// Is the independent watchdog running? Started by `Iwdg::start`, or from
/// reset when the option bytes select the hardware watchdog (WDG_SW
/// clear; this firmware does not set it, a programmer might): then it
/// runs at boot already, with its reset timeout (/4, 0xFFF: 350–960 ms).
pub fn watchdog_started() -> bool {
    WATCHDOG_STARTED.load(Ordering::Acquire) || !pac::FLASH.optcr().read().wdg_sw()
}

impl Iwdg {
    /// Start the watchdog (it cannot be stopped again). In a debug build it
    /// pauses while a debugger halts the core, so a breakpoint does not
    /// reset the board; a release build never freezes it.
    pub fn start(iwdg: Peri<'static, IWDG>) -> Self {
        if cfg!(debug_assertions) {
            pac::DBGMCU.apb1fzr().modify(|w| w.set_iwdg(true));
        }
        let mut w = IndependentWatchdog::new(iwdg, WATCHDOG_TIMEOUT_US);
        w.unleash();
        WATCHDOG_STARTED.store(true, Ordering::Release);
        Self(w)
    }
}

impl Watchdog for Iwdg {
    fn feed(&mut self) {
        self.0.pet();
    }
}

/// The status LED on PC12.
pub struct Led(Output<'static>);

impl Led {
    /// Configure the pin, LED off.
    pub fn new(pin: Peri<'static, PC12>) -> Self {
        Self(Output::new(pin, Level::Low, Speed::Low))
    }
}

impl StatusLed for Led {
    fn set(&mut self, on: bool) {
        self.0.set_level(if on { Level::High } else { Level::Low });
    }
}

/// Set by the NMI when the clock security system tripped.
static CLOCK_FAILED: AtomicBool = AtomicBool::new(false);

/// Switch the clock security system on: if the crystal stops, the chip
/// switches the core to its 16 MHz RC oscillator (every period of the
/// sample clock then lasts 10.5 times as long) and raises the NMI, which
/// drops the relay; the supervisor then reports a clock device fault.
pub fn enable_clock_security() {
    pac::RCC.cr().modify(|w| w.set_csson(true));
}

/// Has the clock security system tripped since boot?
pub fn clock_failed() -> bool {
    CLOCK_FAILED.load(Ordering::Relaxed)
}

/// The NMI: on the STM32F405 only the clock security system raises it.
/// Relay off at once; the flag tells the supervisor.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    super::relay::force_off();
    if pac::RCC.cir().read().cssf() {
        CLOCK_FAILED.store(true, Ordering::Relaxed);
        pac::RCC.cir().modify(|w| w.set_cssc(true));
    }
}

/// Hard fault (a panic ends here too, through `panic.rs`'s `udf`):
/// de-energise the relay at once, then reset (the heartbeat then reports a
/// software reset). Only a debug build with a debugger attached stops for
/// it: the debug-enable bit stays set after a probe is unplugged, and a
/// release board that halted there would hang until power-cycled.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    super::relay::force_off();
    if cfg!(debug_assertions) && cortex_m::peripheral::DCB::is_debugger_attached() {
        loop {
            cortex_m::asm::bkpt();
        }
    }
    cortex_m::peripheral::SCB::sys_reset()
}
