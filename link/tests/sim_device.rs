//! The device end and the host client over the simulated device's pipe.

use link::client::{Client, ClientError};
use link::message::SAMPLES_PER_BLOCK;
use link::sim::{spawn, SimConfig};
use link::storage::{decode_params, encode_params, PARAMS_MAX};
use link::{BlockTracker, EventKind, Refusal};
use monitor::{Params, Sample};
use std::time::Duration;

fn config(state: Option<std::path::PathBuf>, n: u32) -> SimConfig {
    SimConfig {
        firmware: "0.1.0",
        serial: "SIM-0001".into(),
        period_us: 1000,
        source: Box::new(move |tick| {
            (tick < n).then(|| Sample {
                t_s: f64::from(tick) * 1e-3,
                p_supply_bar: Some(50.0 + tick as f32 * 1e-3),
                p_piston_bar: (tick % 97 != 0).then_some(20.0),
                p_rod_bar: Some(12.0),
                p_tank_bar: Some(0.8),
                x_piston_m: Some(0.05),
                u_valve: Some(0.0),
                temp_oil_c: None,
            })
        }),
        state,
        drop_every: None,
        corrupt_every: None,
        default: Params::nominal(),
    }
}

#[test]
fn upload_read_back_events_and_reboot() {
    let dir = tempfile_dir();
    let state = dir.join("flash.bin");
    let mut enc = [0u8; PARAMS_MAX];
    let mut p = Params::nominal();
    p.valve.null_offset = 0.002;
    let enc = encode_params(&p, &mut enc).unwrap().to_vec();
    {
        let mut c = Client::new(spawn(config(Some(state.clone()), 0)).unwrap()).unwrap();
        let id = c.identity().unwrap();
        assert_eq!(id.serial, "SIM-0001");
        assert_eq!(id.params.version, 0);
        assert_eq!(id.boot, 1);
        let new = c.upload_params(&enc).unwrap();
        assert_eq!(new.params.version, 1);
        assert_eq!(new.params.crc, link::frame::CRC32.checksum(&enc));
        assert_eq!(decode_params(&c.read_params().unwrap()).unwrap(), p);
        // A set that fails validation is refused naming the field.
        let mut bad = p.clone();
        bad.fluid.bulk_modulus_bar = -1.0;
        let mut b = [0u8; PARAMS_MAX];
        let b = encode_params(&bad, &mut b).unwrap().to_vec();
        match c.upload_params(&b) {
            Err(ClientError::Refused {
                reason: Refusal::Invalid,
                field,
            }) => {
                assert_eq!(field, "fluid.bulk_modulus_bar")
            }
            r => panic!("{r:?}"),
        }
        assert_eq!(c.identity().unwrap().params, new.params);
    }
    // Reboot: the set and the events are still there.
    let mut c = Client::new(spawn(config(Some(state), 0)).unwrap()).unwrap();
    let id = c.identity().unwrap();
    assert_eq!((id.params.version, id.boot), (1, 2));
    let ev = c.read_events().unwrap();
    let kinds: Vec<_> = ev.iter().map(|e| (e.boot, e.kind)).collect();
    assert!(
        matches!(kinds[0], (1, EventKind::Reset { .. })),
        "{kinds:?}"
    );
    assert!(matches!(kinds[1], (1, EventKind::ParamsChanged { params }) if params == id.params));
    assert!(matches!(kinds[2], (2, EventKind::Reset { .. })));
    assert_eq!(kinds.len(), 3);
}

#[test]
fn stream_counts_dropped_and_corrupted_blocks() {
    let n_blocks = 200u32;
    let mut cfg = config(None, n_blocks * SAMPLES_PER_BLOCK as u32);
    cfg.drop_every = Some(7);
    cfg.corrupt_every = Some(11);
    let mut c = Client::new(spawn(cfg).unwrap()).unwrap();
    c.start_stream().unwrap();
    let mut t = BlockTracker::default();
    let mut samples = 0;
    while let Some(b) = c.next_block(Duration::from_millis(300)).unwrap() {
        t.accept(b.seq);
        assert_eq!(b.first_tick, b.seq * SAMPLES_PER_BLOCK as u32);
        samples += b.samples.len();
    }
    let (last, dropped) = c.stop_stream().unwrap();
    t.finish(last);
    let lost_drop = n_blocks / 7;
    let lost_crc = (1..=n_blocks).filter(|k| k % 11 == 0 && k % 7 != 0).count() as u64;
    assert_eq!(last, n_blocks - 1);
    assert_eq!(dropped, lost_drop);
    assert_eq!(t.lost, u64::from(lost_drop) + lost_crc);
    assert_eq!(t.received + t.lost, u64::from(n_blocks));
    assert_eq!(samples as u64, t.received * SAMPLES_PER_BLOCK as u64);
    assert_eq!(c.stats().crc + c.stats().malformed, lost_crc as u32);
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("link-sim-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn device_refuses_broken_uploads_and_keeps_the_active_set() {
    use link::frame::{encode, Decoder, MAX_WIRE};
    use link::message::Message;
    use link::ram_flash::RamFlash;
    use link::{Device, DeviceInfo, ResetCause, Storage};
    type F = RamFlash<4096>;
    let s = Storage::new(F::new(2), 0..8192, F::new(2), 0..8192);
    let info = DeviceInfo {
        firmware: "t",
        serial: "x".try_into().unwrap(),
        period_us: 1000,
    };
    let mut dev =
        embassy_futures::block_on(Device::start(s, info, &Params::nominal(), ResetCause::Pin));
    let mut ask = |m: Message<'_>| -> String {
        let mut wire = [0u8; MAX_WIRE];
        let n = encode(9, &m, &mut wire).unwrap();
        let mut d = Decoder::new();
        let mut reply = [0u8; MAX_WIRE];
        let mut r = 0;
        for &b in &wire[..n] {
            if let Some(Ok(f)) = d.push(b) {
                r = embassy_futures::block_on(dev.handle(&f, 0, &mut reply));
            }
        }
        let mut d = Decoder::new();
        let mut out = String::new();
        for &b in &reply[..r] {
            if let Some(Ok(f)) = d.push(b) {
                assert_eq!(f.seq, 9);
                out = format!("{:?}", f.msg);
            }
        }
        out
    };
    let mut enc = [0u8; PARAMS_MAX];
    let enc = encode_params(&Params::nominal(), &mut enc)
        .unwrap()
        .to_vec();
    let crc = link::frame::CRC32.checksum(&enc);
    // No begin.
    assert!(ask(Message::ParamsCommit).contains("Unexpected"));
    assert!(ask(Message::ParamsChunk {
        offset: 0,
        data: &enc[..8]
    })
    .contains("Unexpected"));
    // Too large.
    assert!(ask(Message::ParamsBegin { len: 1 << 20, crc }).contains("TooLarge"));
    // Out of order.
    assert_eq!(
        ask(Message::ParamsBegin {
            len: enc.len() as u32,
            crc
        }),
        "Ack"
    );
    assert!(ask(Message::ParamsChunk {
        offset: 8,
        data: &enc[8..16]
    })
    .contains("OutOfOrder"));
    // Incomplete, then wrong CRC.
    assert_eq!(
        ask(Message::ParamsChunk {
            offset: 0,
            data: &enc[..100]
        }),
        "Ack"
    );
    assert!(ask(Message::ParamsCommit).contains("Incomplete"));
    assert_eq!(
        ask(Message::ParamsBegin {
            len: enc.len() as u32,
            crc: crc ^ 1
        }),
        "Ack"
    );
    for (i, c) in enc.chunks(128).enumerate() {
        assert_eq!(
            ask(Message::ParamsChunk {
                offset: (i * 128) as u32,
                data: c
            }),
            "Ack"
        );
    }
    assert!(ask(Message::ParamsCommit).contains("Incomplete"));
    // Not a parameter set.
    let junk = vec![0xAAu8; 40];
    let jcrc = link::frame::CRC32.checksum(&junk);
    assert_eq!(ask(Message::ParamsBegin { len: 40, crc: jcrc }), "Ack");
    assert_eq!(
        ask(Message::ParamsChunk {
            offset: 0,
            data: &junk
        }),
        "Ack"
    );
    assert!(ask(Message::ParamsCommit).contains("Undecodable"));
    // Host-side messages are not commands.
    assert!(ask(Message::Ack).contains("Unexpected"));
    assert_eq!(dev.params().id.version, 0);
    assert!(!dev.take_changed());
}

#[test]
fn a_new_stream_discards_blocks_of_an_old_one() {
    let mut c = Client::new(spawn(config(None, 1_000_000)).unwrap()).unwrap();
    c.start_stream().unwrap();
    for _ in 0..50 {
        c.next_block(Duration::from_millis(300)).unwrap().unwrap();
    }
    // Restart without stopping: old blocks are still in the pipe.
    c.start_stream().unwrap();
    let mut t = BlockTracker::default();
    for _ in 0..200 {
        let b = c.next_block(Duration::from_millis(300)).unwrap().unwrap();
        assert_eq!(t.accept(b.seq), link::Accept::New { lost: 0 }, "{}", b.seq);
    }
    let (last, dropped) = c.stop_stream().unwrap();
    assert!(last >= 199);
    assert_eq!((t.lost, t.duplicates, dropped), (0, 0, 0));
}
