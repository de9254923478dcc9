//! Erases only out of service: in service, an event is appended only where
//! no flash page must be erased (an erase stalls the STM32F405 for
//! 0.25–2 s); boot leaves the queue room for in-service events; what could
//! not be stored waits in RAM for the next upload and is listed meanwhile.

use embassy_futures::block_on;
use link::device::{Device, DeviceInfo, PENDING};
use link::frame::{encode, Decoder, MAX_WIRE};
use link::message::{EventKind, EventRecord, Message, ResetCause};
use link::ram_flash::RamFlash;
use link::storage::{Erase, Storage, StoreError, EVENT_RESERVE};
use monitor::Params;

type PFlash = RamFlash<4096>;
type EFlash = RamFlash<4096>;
const E_PAGES: usize = 3;

fn storage(e: EFlash) -> Storage<PFlash, EFlash> {
    Storage::new(PFlash::new(2), 0..2 * 4096, e, 0..(E_PAGES * 4096) as u32)
}

fn event(i: u32) -> EventRecord {
    EventRecord {
        boot: 1,
        uptime_ms: i,
        kind: EventKind::SensorFault { channels: 1 },
    }
}

fn erases(s: Storage<PFlash, EFlash>) -> (u64, EFlash) {
    let (_, e) = s.into_flash();
    (e.erases, e)
}

fn stored(s: &mut Storage<PFlash, EFlash>) -> Vec<EventRecord> {
    let mut all = Vec::new();
    loop {
        let mut out = heapless::Vec::<EventRecord, 8>::new();
        let total = block_on(s.read_events(all.len() as u32, &mut out)).unwrap();
        all.extend(out.iter().copied());
        if out.is_empty() || all.len() as u32 >= total {
            return all;
        }
    }
}

#[test]
fn in_service_appends_never_erase_and_say_so_when_full() {
    let mut s = storage(EFlash::new(E_PAGES));
    let mut n = 0u32;
    let err = loop {
        match block_on(s.append_event(&event(n), Erase::Never)) {
            Ok(()) => n += 1,
            Err(e) => break e,
        }
        assert!(n < 10_000, "the queue never filled");
    };
    assert_eq!(err, StoreError::NeedsErase);
    let kept = stored(&mut s);
    assert_eq!(kept.len() as u32, n, "every appended event is there");
    let (erased, e) = erases(s);
    assert_eq!(erased, 0, "no erase in service");
    // Out of service the same append erases the oldest page and succeeds.
    let mut s = storage(e);
    block_on(s.append_event(&event(n), Erase::Allowed)).unwrap();
    assert_eq!(erases(s).0, 1);
}

#[test]
fn boot_leaves_room_for_in_service_events() {
    // A queue that went round: every page full, then the oldest erased
    // and filled again until less than half the reserve is left, with
    // the next page full of old events.
    let mut s = storage(EFlash::new(E_PAGES));
    let mut i = 0;
    while block_on(s.append_event(&event(i), Erase::Never)).is_ok() {
        i += 1;
    }
    block_on(s.append_event(&event(i), Erase::Allowed)).unwrap();
    while block_on(s.event_room()).unwrap() >= EVENT_RESERVE / 2 {
        block_on(s.append_event(&event(i), Erase::Allowed)).unwrap();
        i += 1;
    }
    let before = stored(&mut s).len();
    // Boot: the reset record starts a fresh page (padded past the rest).
    let info = DeviceInfo {
        firmware: "test",
        serial: heapless::String::new(),
        period_us: 1000,
    };
    let mut dev = block_on(Device::start(
        s,
        info,
        &Params::nominal(),
        ResetCause::PowerOn,
    ));
    // A reserve's worth of in-service events go to flash, none pending.
    // (Acknowledged events take 12 bytes with their header: 3/4 of it.)
    let many = EVENT_RESERVE as u32 / 16;
    for i in 0..many {
        block_on(dev.log(i, EventKind::Acknowledged)).unwrap();
    }
    assert_eq!(dev.pending_events(), (0, 0));
    let mut s = dev.into_storage();
    let all = stored(&mut s);
    // The reset record's page erase dropped the oldest page's events.
    let reset = all.len() - 1 - many as usize;
    assert!(reset < before, "a page was erased at boot");
    assert_eq!(
        all[reset].kind,
        EventKind::Reset {
            cause: ResetCause::PowerOn
        },
        "the padded reset record decodes"
    );
}

fn ask(dev: &mut Device<PFlash, EFlash>, msg: &Message<'_>) -> Vec<u8> {
    let mut wire = [0u8; MAX_WIRE];
    let n = encode(7, msg, &mut wire).unwrap();
    let mut dec = Decoder::new();
    let mut out = [0u8; MAX_WIRE];
    for &b in &wire[..n] {
        if let Some(frame) = dec.push(b) {
            let m = block_on(dev.handle(&frame.unwrap(), 0, &mut out));
            return out[..m].to_vec();
        }
    }
    panic!("no frame")
}

fn events_total(reply: &[u8]) -> u32 {
    let mut dec = Decoder::new();
    for &b in reply {
        if let Some(frame) = dec.push(b) {
            match frame.unwrap().msg {
                Message::Events { total, .. } => return total,
                other => panic!("not an events reply: {other:?}"),
            }
        }
    }
    panic!("no frame")
}

#[test]
fn events_that_need_an_erase_wait_in_ram_and_are_listed() {
    let info = || DeviceInfo {
        firmware: "test",
        serial: heapless::String::new(),
        period_us: 1000,
    };
    let mut dev = block_on(Device::start(
        storage(EFlash::new(E_PAGES)),
        info(),
        &Params::nominal(),
        ResetCause::PowerOn,
    ));
    // Log until the queue is full in service, then PENDING more.
    let mut i = 0;
    while dev.pending_events().0 == 0 {
        block_on(dev.log(i, EventKind::Acknowledged)).unwrap();
        i += 1;
        assert!(i < 10_000);
    }
    for _ in 1..PENDING {
        block_on(dev.log(i, EventKind::Acknowledged)).unwrap();
        i += 1;
    }
    assert_eq!(dev.pending_events(), (PENDING, 0));
    assert_eq!(
        block_on(dev.log(i, EventKind::Acknowledged)),
        Err(StoreError::NeedsErase)
    );
    assert_eq!(
        dev.pending_events(),
        (PENDING, 1),
        "the overflow is counted"
    );
    // The listing shows stored and pending events.
    let total = events_total(&ask(&mut dev, &Message::EventsRead { skip: 0 }));
    let mut s = dev.into_storage();
    let on_flash = stored(&mut s).len() as u32;
    assert_eq!(total, on_flash + PENDING as u32);
    assert_eq!(erases(s).0, 0, "nothing erased in service");
}
