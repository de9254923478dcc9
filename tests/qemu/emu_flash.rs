//! The emulated board's RAM flash (`emu/flash.rs`) on the target: the
//! NOR rules it enforces, then the commissioning link's storage
//! (`link::storage`, sequential-storage) on it as the firmware will use
//! it: a parameter upload, a boot counter and events that survive a
//! "reboot" (a new `Storage` on the same flashes).
#![no_std]
#![no_main]

#[path = "emu/flash.rs"]
mod flash;

use core::future::Future;
use core::pin::pin;
use core::ptr::addr_of_mut;
use core::task::{Context, Poll, Waker};

use embedded_storage_async::nor_flash::{NorFlash, NorFlashErrorKind, ReadNorFlash};
use flash::{RamNorFlash, SECTOR_16K};
use link::{EventKind, EventRecord, Storage};
use monitor::Params;
use qemu_tests::{exit, println};

/// Two 16 KiB sectors for the parameters (the map needs two), two for
/// the events.
const REGION: usize = 2 * SECTOR_16K;
static mut PARAMS_MEM: [u8; REGION] = [0; REGION];
static mut EVENTS_MEM: [u8; REGION] = [0; REGION];

/// The parameters' memory.
///
/// # Safety
/// No other reference to it may be alive.
unsafe fn params_mem() -> &'static mut [u8] {
    // SAFETY: the caller's promise.
    unsafe { &mut *addr_of_mut!(PARAMS_MEM) }
}

/// The events' memory.
///
/// # Safety
/// As [`params_mem`].
unsafe fn events_mem() -> &'static mut [u8] {
    // SAFETY: the caller's promise.
    unsafe { &mut *addr_of_mut!(EVENTS_MEM) }
}

/// Run `f` to completion: the RAM flash never waits, so neither does
/// anything built on it.
fn now<F: Future>(f: F) -> F::Output {
    let mut f = pin!(f);
    match f.as_mut().poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(v) => v,
        Poll::Pending => panic!("a RAM flash operation waited"),
    }
}

macro_rules! check {
    ($ok:expr, $($what:tt)+) => {
        if !$ok {
            println!("FAILED: {}", format_args!($($what)+));
            exit(false);
        }
    };
}

/// The NOR rules on a one-sector flash over `mem` (one sector).
fn nor_rules(mem: &'static mut [u8]) {
    let mut f = RamNorFlash::<SECTOR_16K>::erased(mem);
    let mut word = [0u8; 4];
    check!(
        now(f.read(8, &mut word)).is_ok() && word == [0xFF; 4],
        "erased reads 0xFF"
    );
    check!(now(f.write(8, &[0xA5; 4])).is_ok(), "write a word");
    check!(now(f.write(8, &[0x0F; 4])).is_ok(), "write it again");
    check!(
        now(f.read(8, &mut word)).is_ok() && word == [0x05; 4],
        "writes only clear bits: {word:02x?}"
    );
    check!(
        now(f.write(2, &[0; 4])) == Err(NorFlashErrorKind::NotAligned),
        "write off the word grid"
    );
    check!(
        now(f.write(8, &[0; 3])) == Err(NorFlashErrorKind::NotAligned),
        "write of part of a word"
    );
    check!(
        now(f.write(SECTOR_16K as u32 - 4, &[0; 8])) == Err(NorFlashErrorKind::OutOfBounds),
        "write past the end"
    );
    check!(
        now(f.read(u32::MAX, &mut word)) == Err(NorFlashErrorKind::OutOfBounds),
        "read past the end"
    );
    check!(
        now(f.erase(0, 4096)) == Err(NorFlashErrorKind::NotAligned),
        "erase of part of a sector"
    );
    check!(
        now(f.erase(SECTOR_16K as u32, 0)) == Err(NorFlashErrorKind::OutOfBounds),
        "erase backwards"
    );
    check!(
        now(f.erase(0, 2 * SECTOR_16K as u32)) == Err(NorFlashErrorKind::OutOfBounds),
        "erase past the end"
    );
    check!(
        now(f.erase(0, SECTOR_16K as u32)).is_ok(),
        "erase the sector"
    );
    check!(f.as_bytes().iter().all(|&b| b == 0xFF), "erase sets 0xFF");
    check!(f.capacity() == SECTOR_16K, "capacity");
}

#[cortex_m_rt::entry]
fn main() -> ! {
    // SAFETY: main is the only user of the memories, and this flash is
    // gone before the next one takes the memory.
    nor_rules(&mut unsafe { params_mem() }[..SECTOR_16K]);

    let default = Params::nominal();
    let mut set = default.clone();
    set.can.node = 7;
    let mut enc = [0u8; link::storage::PARAMS_MAX];
    let enc = link::storage::encode_params(&set, &mut enc).expect("the set encodes");
    let ev = EventRecord {
        boot: 1,
        uptime_ms: 1234,
        kind: EventKind::Acknowledged,
    };

    // First boot on an erased flash.
    // SAFETY: as above, and these two flashes live to the end.
    let (p, e) = unsafe { (params_mem(), events_mem()) };
    let (p, e): (RamNorFlash, RamNorFlash) = (RamNorFlash::erased(p), RamNorFlash::erased(e));
    let mut s = Storage::new(p, 0..REGION as u32, e, 0..REGION as u32);
    let loaded = now(s.load_params(&default));
    check!(
        !loaded.stored && loaded.params == default,
        "an erased flash gives the default set"
    );
    check!(now(s.bump_boot()) == 1, "first boot");
    let id = now(s.store_params(enc, loaded.id));
    check!(
        id.as_ref().is_ok_and(|id| id.version == 1),
        "upload stored as version 1: {id:?}"
    );
    check!(
        now(s.append_event(&ev, link::Erase::Never)).is_ok(),
        "event stored"
    );

    // "Reboot": a new storage on the flashes as they are.
    let (p, e) = s.into_flash();
    let mut s = Storage::new(p, 0..REGION as u32, e, 0..REGION as u32);
    let loaded = now(s.load_params(&default));
    check!(
        loaded.stored && loaded.params == set && loaded.id.version == 1,
        "the upload survives the reboot"
    );
    check!(now(s.bump_boot()) == 2, "second boot");
    let mut events = heapless::Vec::<EventRecord, 4>::new();
    let total = now(s.read_events(0, &mut events));
    check!(
        total == Ok(1) && events.as_slice() == [ev],
        "the event survives the reboot: {total:?}"
    );

    println!("emulated flash: NOR rules hold; link::storage keeps parameters, boot counter and events over a reboot");
    exit(true)
}
