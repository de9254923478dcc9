//! Power cuts during parameter uploads and event appends, on a simulated
//! NorFlash: the power fails after every single word write (and page
//! erase) of the operation in turn; the device "reboots" on what the cut
//! left and must find a valid parameter set (the old or the new, never
//! another) and every acknowledged event.

use embassy_futures::block_on;
use link::message::{EventKind, EventRecord, ParamsId, ResetCause};
use link::ram_flash::RamFlash;
use link::storage::{encode_params, Erase, Storage, PARAMS_MAX};
use monitor::Params;

/// Small pages so that uploads and appends cross pages (copy and erase)
/// often: 4 KiB parameter pages (a set is ~1 KiB), 1 KiB event pages.
type PFlash = RamFlash<4096>;
type EFlash = RamFlash<1024>;
const P_PAGES: usize = 2;
const E_PAGES: usize = 4;

fn storage(p: PFlash, e: EFlash) -> Storage<PFlash, EFlash> {
    Storage::new(p, 0..(P_PAGES * 4096) as u32, e, 0..(E_PAGES * 1024) as u32)
}

fn set(i: u32) -> Params {
    let mut p = Params::nominal();
    p.valve.null_offset = f64::from(i) * 1e-4;
    p.fluid.bulk_modulus_bar = 15_000.0 + f64::from(i);
    p
}

fn enc(p: &Params) -> Vec<u8> {
    let mut buf = [0u8; PARAMS_MAX];
    encode_params(p, &mut buf).unwrap().to_vec()
}

#[test]
fn parameter_upload_survives_a_cut_after_every_word() {
    let default = Params::nominal();
    let (mut pf, mut ef) = (PFlash::new(P_PAGES), EFlash::new(E_PAGES));
    let mut active = ParamsId { version: 0, crc: 0 };
    let mut active_set = default.clone();
    let (mut cuts, mut corrupt, mut unrecovered) = (0u64, 0u64, 0u64);
    let mut per_upload = Vec::new();
    eprintln!("parameter encoding: {} bytes", enc(&default).len());
    for i in 1..=12u32 {
        let new = set(i);
        let bytes = enc(&new);
        let mut k = 0u64;
        loop {
            let mut p = pf.clone();
            p.cut_after = Some(k);
            let mut s = storage(p, ef.clone());
            // Boot bumps the counter too: cut those writes as well.
            let r = block_on(async {
                s.bump_boot().await;
                s.store_params(&bytes, active).await
            });
            let (mut p, e) = s.into_flash();
            if !p.is_dead() {
                // Completed before the cut: this is the real upload.
                let id = r.expect("upload without a cut");
                assert_eq!(id.version, active.version + 1);
                pf = p;
                ef = e;
                active = id;
                active_set = new;
                break;
            }
            cuts += 1;
            p.power_on();
            // Reboot on what the cut left.
            let mut s = storage(p, e);
            let got = block_on(s.load_params(&default));
            let old_ok = got.id == active && got.params == active_set
                || (active.version == 0 && !got.stored && got.params == default);
            let new_ok = got.id.version == active.version + 1
                && got.id.crc == link::frame::CRC32.checksum(&bytes)
                && got.params == new;
            if !(old_ok || new_ok) {
                corrupt += 1;
                eprintln!("upload {i}, cut {k}: {:?}", got.id);
            }
            // And the storage works on after the repair.
            let again = block_on(s.store_params(&bytes, got.id));
            let after = block_on(s.load_params(&default));
            if again.is_err() || after.params != new {
                unrecovered += 1;
                eprintln!("upload {i}, cut {k}: no recovery: {again:?}");
            }
            k += 1;
        }
        per_upload.push(k);
    }
    eprintln!(
        "parameter upload power-fail: {cuts} cut points over {} uploads (ops per upload {per_upload:?}), {corrupt} corrupt sets, {unrecovered} unrecovered",
        per_upload.len()
    );
    assert!(cuts > 1000, "{cuts}");
    assert_eq!(corrupt, 0);
    assert_eq!(unrecovered, 0);
}

fn event(n: u32) -> EventRecord {
    let kind = match n % 4 {
        0 => EventKind::AlarmRaised {
            leak: link::Leak::Internal,
            internal_lpm: n as f32 * 0.01,
            external_lpm: 0.0,
        },
        1 => EventKind::AlarmCleared {
            internal_lpm: 0.01,
            external_lpm: 0.0,
        },
        2 => EventKind::SensorFault { channels: 0b10 },
        _ => EventKind::Reset {
            cause: ResetCause::Watchdog,
        },
    };
    EventRecord {
        boot: n / 10,
        uptime_ms: n * 1000,
        kind,
    }
}

fn read_all<E: embedded_storage_async::nor_flash::NorFlash>(
    s: &mut Storage<PFlash, E>,
) -> Vec<EventRecord> {
    let mut out = Vec::new();
    loop {
        let mut v = heapless::Vec::<EventRecord, 8>::new();
        let total = block_on(s.read_events(out.len() as u32, &mut v)).expect("read events");
        let empty = v.is_empty();
        out.extend(v);
        if out.len() >= total as usize || empty {
            return out;
        }
    }
}

#[test]
fn event_append_survives_a_cut_after_every_word() {
    let (pf, mut ef) = (PFlash::new(P_PAGES), EFlash::new(E_PAGES));
    let (mut cuts, mut lost, mut garbage) = (0u64, 0u64, 0u64);
    let mut min_kept = usize::MAX;
    const N: u32 = 400;
    for n in 0..N {
        let ev = event(n);
        let mut k = 0u64;
        loop {
            let mut e = ef.clone();
            e.cut_after = Some(k);
            let mut s = storage(pf.clone(), e);
            let r = block_on(s.append_event(&ev, Erase::Allowed));
            let (_, mut e) = s.into_flash();
            if !e.is_dead() {
                r.expect("append without a cut");
                ef = e;
                break;
            }
            cuts += 1;
            e.power_on();
            let mut s = storage(pf.clone(), e);
            let got = read_all(&mut s);
            // Acknowledged: 0..n. What is read must be a run of them
            // ending at n - 1, then possibly event n; the run must hold
            // the last 64 acknowledged (or all of them).
            let (acked, tail) = match got.last() {
                Some(l) if *l == ev => (&got[..got.len() - 1], 1),
                _ => (&got[..], 0),
            };
            let _ = tail;
            let first = n as usize - acked.len();
            let in_order = acked
                .iter()
                .enumerate()
                .all(|(j, r)| *r == event((first + j) as u32));
            if !in_order {
                garbage += 1;
                eprintln!("append {n}, cut {k}: events out of order or damaged");
            }
            let want = (n as usize).min(64);
            if acked.len() < want {
                lost += (want - acked.len()) as u64;
                eprintln!(
                    "append {n}, cut {k}: {} of the last {want} acknowledged events",
                    acked.len()
                );
            }
            // Appending again works.
            block_on(s.append_event(&ev, Erase::Allowed)).expect("append after the cut");
            let again = read_all(&mut s);
            assert_eq!(again.last(), Some(&ev));
            k += 1;
        }
        if n >= 64 {
            let mut s = storage(pf.clone(), ef.clone());
            min_kept = min_kept.min(read_all(&mut s).len());
        }
    }
    eprintln!(
        "event append power-fail: {cuts} cut points over {N} appends, {lost} lost acknowledged events, {garbage} damaged reads; at least {min_kept} events kept once full"
    );
    assert!(cuts > 2000, "{cuts}");
    assert_eq!(lost, 0);
    assert_eq!(garbage, 0);
    assert!(min_kept >= 64, "{min_kept}");
}

/// Boot's reset record, padded onto a fresh page when the queue is low
/// (`Storage::append_event_making_room`), cut after every word write and
/// erase: afterwards every acknowledged event that the queue keeps is
/// there, undamaged and in order, the reset record too if it was
/// acknowledged, and the queue takes events again. 4 KiB pages, so the
/// 1 KiB reserve is less than a page and the padding happens.
#[test]
fn boot_making_room_survives_a_cut_after_every_word() {
    type BigPages = RamFlash<4096>;
    let boot_storage = |e: BigPages| {
        Storage::new(
            PFlash::new(P_PAGES),
            0..(P_PAGES * 4096) as u32,
            e,
            0..3 * 4096,
        )
    };
    let mut ef = BigPages::new(3);
    let (mut cuts, mut lost, mut garbage, mut padded_boots) = (0u64, 0u64, 0u64, 0u32);
    let mut acked: Vec<EventRecord> = Vec::new();
    let mut n = 0u32;
    // Boots between bursts of in-service events, until the queue went
    // round twice.
    while ef.erases < 6 {
        for _ in 0..37 {
            let ev = event(n);
            n += 1;
            let mut s = boot_storage(ef);
            block_on(s.append_event(&ev, Erase::Allowed)).expect("append");
            ef = s.into_flash().1;
            acked.push(ev);
        }
        let reset = EventRecord {
            boot: n,
            uptime_ms: 0,
            kind: EventKind::Reset {
                cause: ResetCause::PowerOn,
            },
        };
        let erases_before = ef.erases;
        let mut k = 0u64;
        loop {
            let mut e = ef.clone();
            e.cut_after = Some(k);
            let mut s = boot_storage(e);
            let r = block_on(s.append_event_making_room(&reset));
            let (_, mut e) = s.into_flash();
            if !e.is_dead() {
                r.expect("boot record without a cut");
                if e.erases > erases_before {
                    padded_boots += 1;
                }
                e.power_on(); // disarm the cut that did not come
                ef = e;
                acked.push(reset);
                break;
            }
            cuts += 1;
            e.power_on();
            let mut s = boot_storage(e);
            let got = read_all(&mut s);
            let got = match got.last() {
                Some(l) if *l == reset => &got[..got.len() - 1],
                _ => &got[..],
            };
            // A run of the acknowledged events ending at the last one.
            if !acked.ends_with(got) {
                garbage += 1;
                eprintln!("boot after event {n}, cut {k}: events out of order or damaged");
            }
            let want = acked.len().min(64);
            if got.len() < want {
                lost += (want - got.len()) as u64;
            }
            block_on(s.append_event(&reset, Erase::Allowed)).expect("append after the cut");
            k += 1;
        }
    }
    eprintln!(
        "boot making room, power-fail: {cuts} cut points over {padded_boots} boots that moved to a fresh page, {lost} lost acknowledged events, {garbage} damaged reads"
    );
    assert!(padded_boots >= 3, "{padded_boots}");
    assert!(cuts > 500, "{cuts}");
    assert_eq!(lost, 0);
    assert_eq!(garbage, 0);
}
