//! The commissioning link's flash storage: the parameter sets in sectors
//! 6–7 and the event memory in sectors 8–9 of the internal flash
//! (`board_map::flash_layout`; the program image keeps sectors 0–5).
//!
//! embassy-stm32's blocking flash driver, wrapped so that it
//! - only writes and erases inside the storage sectors (a wrong offset
//!   can never touch the program image), and
//! - stretches the independent watchdog around every sector erase,
//!
//! then adapted to the async `NorFlash` the `link` crate takes
//! (`BlockingAsync`) and split into two partitions over one mutex. Both
//! partitions are used from the one link task (and at boot, before the
//! executors run), so the mutex never contends: a `NoopRawMutex`.
//!
//! Before an erase the relay is de-energised (nothing runs while the
//! core is stalled, the estimator included) and embassy's clock is
//! stopped (see `PausedClock`).
//!
//! The driver is blocking on purpose: the STM32F405 has a single flash
//! bank, so while it programs or erases, every instruction fetch from
//! flash waits anyway; an "async" erase would not let anything else run.

use embassy_embedded_hal::adapter::BlockingAsync;
use embassy_embedded_hal::flash::partition::Partition;
use embassy_stm32::flash::{Blocking, Error, Flash, FLASH_SIZE};
use embassy_stm32::pac;
use embassy_stm32::pac::iwdg::vals::{Key, Pr};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::mutex::Mutex;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use firmware::board_map::flash_layout::{
    EVENTS_OFFSET, EVENTS_SIZE, PARAMS_OFFSET, PARAMS_SIZE, SECTOR_SIZE,
};
use static_cell::StaticCell;

use super::system::watchdog_started;

/// The first byte (offset from the flash base) the storage may change.
const STORAGE_START: u32 = PARAMS_OFFSET;
/// One past the last byte the storage may change.
const STORAGE_END: u32 = EVENTS_OFFSET + EVENTS_SIZE;

// Every storage sector is one of the 128 KiB sectors 5–11, which is also
// the erase size the whole-flash driver reports: an erase of
// `ERASE_SIZE` at a storage offset is exactly one sector.
const _: () = assert!(<Flash<'static, Blocking> as NorFlash>::ERASE_SIZE == SECTOR_SIZE as usize);
const _: () =
    assert!(STORAGE_START.is_multiple_of(SECTOR_SIZE) && STORAGE_END.is_multiple_of(SECTOR_SIZE));
const _: () = assert!(STORAGE_END as usize <= FLASH_SIZE);

/// The internal flash, writable only in the storage sectors, with the
/// watchdog stretched around every sector erase.
pub struct StorageFlash(Flash<'static, Blocking>);

impl StorageFlash {
    /// `from..to` (offsets from the flash base) inside the storage?
    fn check(from: u32, to: u32) -> Result<(), Error> {
        if STORAGE_START <= from && from <= to && to <= STORAGE_END {
            Ok(())
        } else {
            Err(Error::Protected)
        }
    }
}

impl ErrorType for StorageFlash {
    type Error = Error;
}

impl ReadNorFlash for StorageFlash {
    const READ_SIZE: usize = <Flash<'static, Blocking> as ReadNorFlash>::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        self.0.blocking_read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        FLASH_SIZE
    }
}

impl NorFlash for StorageFlash {
    const WRITE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::ERASE_SIZE;

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        Self::check(offset, offset.saturating_add(bytes.len() as u32))?;
        // A word takes ~16 µs: no watchdog concern.
        self.0.blocking_write(offset, bytes)
    }

    /// Erase sector by sector, each with the watchdog stretched: a
    /// 128 KiB sector erase stalls the core for 1 s typical, 2 s at most
    /// (RM0090 / datasheet t_ERASE128KB), and nothing runs meanwhile, not
    /// even the interrupts (their vectors and code are in flash) — the
    /// supervisor cannot feed the watchdog, whose normal timeout is
    /// 250 ms (170–470 ms over the LSI's range). Without the stretch
    /// every erase in service would reset the board.
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        Self::check(from, to)?;
        // The estimator cannot run during the erase: the relay must not
        // stay energised ("healthy") on a monitor that is blind for
        // seconds. Erases come only out of service (at boot, where the
        // relay is off anyway, or in a parameter upload, after which the
        // monitor restarts with the relay off); the estimator drives the
        // relay again from its next block.
        super::relay::force_off();
        let _clock = PausedClock::new();
        let mut sector = from;
        while sector < to {
            let _stretched = StretchedWatchdog::new();
            self.0.blocking_erase(sector, sector + SECTOR_SIZE)?;
            sector += SECTOR_SIZE;
        }
        Ok(())
    }
}

/// embassy's clock (the time driver, TIM2) stopped while this lives.
///
/// Nothing runs while the core is stalled; if the clock ran on, every
/// periodic task would find itself 1–2 s late afterwards. embassy's
/// `Ticker` catches up, so the supervisor would run some hundred checks
/// back to back, far faster than the estimator's 1 ms blocks, see the
/// sample count stand still for two checks in a row and take the
/// estimator for stalled: relay off for good, a stall alarm on CAN and a
/// watchdog reset. With the clock stopped the tasks resume where they
/// were; the estimator counts the samples the erase cost (an ADC
/// overrun), and embassy time (the event memory's uptime stamps) lags
/// the real time by the erase. The time driver itself stops TIM2 the
/// same way in its low-power mode; its interrupt handler never touches
/// CR1.
struct PausedClock;

impl PausedClock {
    fn new() -> Self {
        cortex_m::interrupt::free(|_| pac::TIM2.cr1().modify(|w| w.set_cen(false)));
        Self
    }
}

impl Drop for PausedClock {
    fn drop(&mut self) {
        cortex_m::interrupt::free(|_| pac::TIM2.cr1().modify(|w| w.set_cen(true)));
    }
}

/// The watchdog with its longest timeout, while this lives; the normal
/// timeout again, reloaded, when it is dropped.
///
/// Only the prescaler changes: /256 instead of the normal /4 (embassy's
/// `IndependentWatchdog` picks /4 with a reload value of 1999 for
/// 250 ms). With the same reload value that is a timeout 64 times as
/// long: 16 s at the LSI's nominal 32 kHz, 10.9 s at its fastest (47 kHz)
/// and 30 s at its slowest (17 kHz), well above the 2 s an erase may take.
/// So a hung erase is still caught, only later. The watchdog itself cannot
/// be stopped once started, and it cannot be left at the long timeout:
/// in service it must catch a stalled estimator within 250 ms.
///
/// Only thread-mode code touches the IWDG (the supervisor's feed and this
/// guard, in tasks of the same executor, so never in the middle of each
/// other); no interrupt handler does, so the unlock-write-lock sequences
/// below cannot be split by another write to the key register.
struct StretchedWatchdog {
    /// The prescaler to restore (None: the watchdog is not running).
    normal: Option<Pr>,
}

impl StretchedWatchdog {
    fn new() -> Self {
        if !watchdog_started() {
            // Boot, before the watchdog starts: nothing to stretch (and
            // its clock, the LSI, may still be off: PVU would never clear).
            // With the hardware watchdog (option bytes) it runs from reset
            // and is stretched here at boot too.
            return Self { normal: None };
        }
        let iwdg = pac::IWDG;
        // The prescaler reads back valid only when no update is under way.
        while iwdg.sr().read().pvu() {}
        let normal = iwdg.pr().read().pr();
        set_prescaler(Pr::DIVIDE_BY256);
        Self {
            normal: Some(normal),
        }
    }
}

impl Drop for StretchedWatchdog {
    fn drop(&mut self) {
        if let Some(normal) = self.normal {
            set_prescaler(normal);
        }
    }
}

/// Set the IWDG's prescaler and reload it (RM0090 §21.3: unlock PR and
/// RLR with 0x5555, write, wait until the value reached the watchdog's
/// clock domain (SR.PVU clear, up to 5 LSI periods), reload with 0xAAAA,
/// which also locks the registers again).
fn set_prescaler(pr: Pr) {
    let iwdg = pac::IWDG;
    // Reload first: a full period at the old prescaler covers the update.
    iwdg.kr().write(|w| w.set_key(Key::RESET));
    iwdg.kr().write(|w| w.set_key(Key::ENABLE));
    while iwdg.sr().read().pvu() {}
    iwdg.pr().write(|w| w.set_pr(pr));
    while iwdg.sr().read().pvu() {}
    iwdg.kr().write(|w| w.set_key(Key::RESET));
}

/// The flash driver the partitions share.
pub type SharedFlash = BlockingAsync<StorageFlash>;

/// A partition of the storage flash, as the link task takes it.
pub type StoragePartition = Partition<'static, NoopRawMutex, SharedFlash>;

static FLASH_MUTEX: StaticCell<Mutex<NoopRawMutex, SharedFlash>> = StaticCell::new();

/// The parameter partition (sectors 6–7) and the event partition
/// (sectors 8–9); each counts its offsets from its own start.
pub fn partitions(flash: Peri<'static, FLASH>) -> (StoragePartition, StoragePartition) {
    let flash = FLASH_MUTEX.init(Mutex::new(BlockingAsync::new(StorageFlash(
        Flash::new_blocking(flash),
    ))));
    (
        Partition::new(flash, PARAMS_OFFSET, PARAMS_SIZE),
        Partition::new(flash, EVENTS_OFFSET, EVENTS_SIZE),
    )
}
