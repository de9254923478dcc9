//! Property tests of the framing and the block accounting: bytes are
//! corrupted, dropped, duplicated, truncated and garbage is inserted; the
//! decoder never panics, never accepts a damaged frame, is back in step at
//! the next delimiter, and the host counts lost blocks exactly.

use link::frame::{encode, Decoder, MAX_WIRE};
use link::message::{Message, SampleBlock, WireSample, SAMPLES_PER_BLOCK};
use link::{BlockTracker, EventKind, EventRecord, Identity, Leak, ParamsId, Refusal, ResetCause};
use proptest::prelude::*;

fn block(seq: u32, seed: u32) -> SampleBlock {
    let mut samples = [WireSample::default(); SAMPLES_PER_BLOCK];
    for (i, s) in samples.iter_mut().enumerate() {
        let x = seed.wrapping_mul(2654435761).wrapping_add(i as u32);
        s.valid = (x & 0x7F) as u8;
        for (c, v) in s.values.iter_mut().enumerate() {
            *v = f32::from_bits(x.rotate_left(c as u32 * 3) & 0x7F7F_FFFF); // finite
        }
    }
    SampleBlock {
        seq,
        first_tick: seq.wrapping_mul(SAMPLES_PER_BLOCK as u32),
        dropped: 0,
        samples,
    }
}

fn frame_of(seq: u32, seed: u32) -> Vec<u8> {
    let mut out = [0u8; MAX_WIRE];
    let n = encode(seq as u16, &Message::Block(block(seq, seed)), &mut out).unwrap();
    out[..n].to_vec()
}

/// What happens to one frame on the way.
#[derive(Clone, Debug)]
enum Fate {
    Keep,
    Drop,
    /// XOR byte `pos % len` with a non-zero value.
    Corrupt(usize, u8),
    Duplicate,
    /// Only the first `len % frame_len` bytes arrive (never the delimiter).
    Truncate(usize),
    /// Garbage bytes arrive before the frame.
    GarbageBefore(Vec<u8>),
}

fn fate() -> impl Strategy<Value = Fate> {
    prop_oneof![
        6 => Just(Fate::Keep),
        1 => Just(Fate::Drop),
        1 => (any::<usize>(), 1u8..=255).prop_map(|(p, x)| Fate::Corrupt(p, x)),
        1 => Just(Fate::Duplicate),
        1 => any::<usize>().prop_map(Fate::Truncate),
        1 => proptest::collection::vec(any::<u8>(), 1..40).prop_map(Fate::GarbageBefore),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Random bytes: no panic, and nothing accepted that is not a frame.
    #[test]
    fn decoder_survives_any_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..4000)) {
        let mut d = Decoder::new();
        for b in bytes {
            let _ = d.push(b);
        }
        // A valid frame after the noise (and one delimiter) is decoded.
        let _ = d.push(0);
        let f = frame_of(7, 7);
        let mut got = 0;
        for &b in &f {
            if let Some(r) = d.push(b) {
                prop_assert_eq!(r.map(|fr| fr.msg), Ok(Message::Block(block(7, 7))));
                got += 1;
            }
        }
        prop_assert_eq!(got, 1);
    }

    /// A stream of blocks through a damaging channel.
    #[test]
    fn lost_blocks_are_counted_exactly(
        fates in proptest::collection::vec(fate(), 1..60),
        seed in any::<u32>(),
    ) {
        let k = fates.len() as u32;
        let mut wire: Vec<u8> = Vec::new();
        // Blocks the model says must arrive, in order (duplicates too).
        let mut expected: Vec<u32> = Vec::new();
        for (i, f) in fates.iter().enumerate() {
            let seq = i as u32;
            let frame = frame_of(seq, seed ^ seq);
            let clean_start = wire.last().is_none_or(|&b| b == 0);
            match f {
                Fate::Keep => {
                    if clean_start { expected.push(seq); }
                    wire.extend_from_slice(&frame);
                }
                Fate::Drop => {}
                Fate::Corrupt(p, x) => {
                    let mut fr = frame.clone();
                    let p = p % fr.len();
                    fr[p] ^= x;
                    wire.extend_from_slice(&fr);
                }
                Fate::Duplicate => {
                    // The second copy starts after the first's delimiter.
                    if clean_start { expected.push(seq); }
                    expected.push(seq);
                    wire.extend_from_slice(&frame);
                    wire.extend_from_slice(&frame);
                }
                Fate::Truncate(l) => {
                    let l = l % (frame.len() - 1);
                    wire.extend_from_slice(&frame[..l]);
                }
                Fate::GarbageBefore(g) => {
                    wire.extend_from_slice(g);
                    if g.last() == Some(&0) {
                        expected.push(seq);
                    }
                    wire.extend_from_slice(&frame);
                }
            }
        }
        let mut d = Decoder::new();
        let mut tracker = BlockTracker::default();
        let mut accepted = Vec::new();
        for &b in &wire {
            if let Some(Ok(fr)) = d.push(b) {
                match fr.msg {
                    Message::Block(bl) => {
                        // Never a damaged block.
                        prop_assert_eq!(bl, block(bl.seq, seed ^ bl.seq));
                        prop_assert_eq!(fr.seq, bl.seq as u16);
                        accepted.push(bl.seq);
                        tracker.accept(bl.seq);
                    }
                    other => prop_assert!(false, "unexpected {:?}", other),
                }
            }
        }
        tracker.finish(k - 1);
        prop_assert_eq!(&accepted, &expected);
        let mut distinct = expected.clone();
        distinct.dedup();
        prop_assert_eq!(tracker.received, distinct.len() as u64);
        prop_assert_eq!(tracker.lost, u64::from(k) - distinct.len() as u64);
        prop_assert_eq!(tracker.duplicates, (expected.len() - distinct.len()) as u64);
    }

    /// Every command and reply survives encode → decode.
    #[test]
    fn messages_round_trip(
        seq in any::<u16>(),
        a in any::<u32>(),
        b in any::<u32>(),
        data in proptest::collection::vec(any::<u8>(), 0..=128),
        text in "[a-z0-9.]{0,20}",
    ) {
        let events: heapless::Vec<EventRecord, 8> = [
            EventKind::AlarmRaised { leak: Leak::Both, internal_lpm: 1.5, external_lpm: 0.25 },
            EventKind::Reset { cause: ResetCause::Watchdog },
            EventKind::ParamsChanged { params: ParamsId { version: a, crc: b } },
            EventKind::SensorFault { channels: 0x42 },
            EventKind::Acknowledged,
        ]
        .into_iter()
        .map(|kind| EventRecord { boot: a, uptime_ms: b, kind })
        .collect();
        let msgs = [
            Message::GetIdentity,
            Message::StartStream,
            Message::StopStream,
            Message::ParamsBegin { len: a, crc: b },
            Message::ParamsChunk { offset: a, data: &data },
            Message::ParamsCommit,
            Message::ParamsRead { offset: b },
            Message::EventsRead { skip: a },
            Message::Identity(Identity {
                protocol: 1,
                firmware: &text,
                serial: &text,
                params: ParamsId { version: a, crc: b },
                boot: a,
                period_us: 1000,
            }),
            Message::Ack,
            Message::Refused { reason: Refusal::Invalid, field: &text },
            Message::Block(block(a, b)),
            Message::StreamEnd { last_seq: a, dropped: b },
            Message::ParamsData { total: a, offset: b, data: &data },
            Message::Events { total: a, skip: b, events },
        ];
        for m in msgs {
            let mut out = [0u8; MAX_WIRE];
            let n = encode(seq, &m, &mut out).unwrap();
            prop_assert_eq!(out[n - 1], 0);
            prop_assert!(!out[..n - 1].contains(&0));
            let mut d = Decoder::new();
            let mut got = 0;
            for &x in &out[..n] {
                if let Some(r) = d.push(x) {
                    let fr = r.unwrap();
                    prop_assert_eq!(fr.seq, seq);
                    prop_assert_eq!(&fr.msg, &m);
                    got += 1;
                }
            }
            prop_assert_eq!(got, 1);
        }
    }
}

#[test]
fn a_block_frame_fits_with_room() {
    let f = frame_of(u32::MAX, 1);
    assert!(f.len() < MAX_WIRE, "{}", f.len());
    eprintln!(
        "block frame on the wire: {} bytes for {SAMPLES_PER_BLOCK} samples",
        f.len()
    );
}

mod device_commands {
    //! Any sequence of commands, however wrong: the device never panics,
    //! answers every command with exactly one frame carrying its sequence
    //! number, and the active set is always a valid one.
    use link::frame::{encode, Decoder, MAX_WIRE};
    use link::message::{Message, CHUNK};
    use link::ram_flash::RamFlash;
    use link::storage::{encode_params, PARAMS_MAX};
    use link::{Device, DeviceInfo, ResetCause, Storage};
    use monitor::Params;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Cmd {
        Begin { len: u32, good_crc: bool },
        Chunk { offset: u32, len: usize, flip: bool },
        Commit,
        Read(u32),
        Events(u32),
        Identity,
        Start,
        Stop,
        Samples(u8),
    }

    fn cmd() -> impl Strategy<Value = Cmd> {
        prop_oneof![
            (
                prop_oneof![Just(0u32), Just(825), 0u32..2000, Just(u32::MAX)],
                any::<bool>()
            )
                .prop_map(|(len, good_crc)| Cmd::Begin { len, good_crc }),
            (
                prop_oneof![
                    (0u32..8).prop_map(|k| k * CHUNK as u32),
                    any::<u32>(),
                    Just(u32::MAX - 3)
                ],
                0usize..=CHUNK,
                prop::bool::weighted(0.1),
            )
                .prop_map(|(offset, len, flip)| Cmd::Chunk { offset, len, flip }),
            Just(Cmd::Commit),
            any::<u32>().prop_map(Cmd::Read),
            (0u32..20).prop_map(Cmd::Events),
            Just(Cmd::Identity),
            Just(Cmd::Start),
            Just(Cmd::Stop),
            any::<u8>().prop_map(Cmd::Samples),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        #[test]
        fn any_command_sequence(cmds in proptest::collection::vec(cmd(), 1..60)) {
            type F = RamFlash<4096>;
            let storage = Storage::new(F::new(2), 0..8192, F::new(2), 0..8192);
            let info = DeviceInfo { firmware: "t", serial: "s".try_into().unwrap(), period_us: 1000 };
            let mut dev = embassy_futures::block_on(Device::start(
                storage, info, &Params::nominal(), ResetCause::Software));
            let mut p = Params::nominal();
            p.valve.null_offset = 0.001;
            let mut enc = [0u8; PARAMS_MAX];
            let enc = encode_params(&p, &mut enc).unwrap().to_vec();
            let crc = link::frame::CRC32.checksum(&enc);
            let mut tick = 0u32;
            for (i, c) in cmds.iter().enumerate() {
                let seq = i as u16;
                let data: Vec<u8>;
                let msg = match c {
                    Cmd::Begin { len, good_crc } => Message::ParamsBegin {
                        len: *len,
                        crc: if *good_crc { crc } else { crc ^ 0x100 },
                    },
                    Cmd::Chunk { offset, len, flip } => {
                        let o = (*offset as usize).min(enc.len());
                        let mut d = enc[o..(o + len).min(enc.len())].to_vec();
                        if *flip && !d.is_empty() { d[0] ^= 1; }
                        data = d;
                        Message::ParamsChunk { offset: *offset, data: &data }
                    }
                    Cmd::Commit => Message::ParamsCommit,
                    Cmd::Read(o) => Message::ParamsRead { offset: *o },
                    Cmd::Events(s) => Message::EventsRead { skip: *s },
                    Cmd::Identity => Message::GetIdentity,
                    Cmd::Start => Message::StartStream,
                    Cmd::Stop => Message::StopStream,
                    Cmd::Samples(n) => {
                        for _ in 0..*n {
                            let _ = dev.sample(tick, &monitor::Sample::default());
                            tick += 1;
                        }
                        continue;
                    }
                };
                let mut wire = [0u8; MAX_WIRE];
                let n = encode(seq, &msg, &mut wire).unwrap();
                let mut d = Decoder::new();
                let mut reply = [0u8; MAX_WIRE];
                let mut r = 0;
                for &b in &wire[..n] {
                    if let Some(Ok(f)) = d.push(b) {
                        r = embassy_futures::block_on(dev.handle(&f, tick, &mut reply));
                    }
                }
                prop_assert!(r > 0);
                let mut d = Decoder::new();
                let mut replies = 0;
                for &b in &reply[..r] {
                    if let Some(f) = d.push(b) {
                        prop_assert_eq!(f.unwrap().seq, seq);
                        replies += 1;
                    }
                }
                prop_assert_eq!(replies, 1);
                let active = dev.params();
                prop_assert!(active.params.validate().is_ok());
                prop_assert!(active.params == Params::nominal() || active.params == p);
            }
            // What the device reads back is its active set.
            let mut wire = [0u8; MAX_WIRE];
            let n = encode(1, &Message::ParamsRead { offset: 0 }, &mut wire).unwrap();
            let mut d = Decoder::new();
            let mut reply = [0u8; MAX_WIRE];
            let mut r = 0;
            for &b in &wire[..n] {
                if let Some(Ok(f)) = d.push(b) {
                    r = embassy_futures::block_on(dev.handle(&f, 0, &mut reply));
                }
            }
            let mut d = Decoder::new();
            for &b in &reply[..r] {
                if let Some(Ok(f)) = d.push(b) {
                    if let Message::ParamsData { total, .. } = f.msg {
                        prop_assert_eq!(total as usize, encode_params(&dev.params().params, &mut [0u8; PARAMS_MAX]).unwrap().len());
                    }
                }
            }
        }
    }
}
