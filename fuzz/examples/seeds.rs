//! Writes the seed corpora that are generated from the protocol code
//! (`corpus/candump`, `corpus/protocol_decoder`, `corpus/command_gate`):
//! frames from the monitor's own encoder, as host-sim's `can_vectors`
//! example builds them, and acknowledge frames a controller builds.
//!
//! `cargo run --no-default-features --example seeds` (in `fuzz/`)

use monitor::acknowledge::AckResult;
use monitor::device::alarm::AlarmState;
use monitor::protocol::auth::{acknowledge_frame, AckKey, KeyKind};
use monitor::protocol::{
    AlarmFrame, CanFrame, ChallengeFrame, DetailFrame, Encoder, HeartbeatFrame, IdentityFrame,
    Message, Node, ResetCause, SensitivityFrame, StatusFrame, VersionFrame,
};
use monitor::{Hypothesis, LeakSet, Verdict};
use std::fmt::Write as _;
use std::path::Path;

fn messages(i: usize) -> [Message; 8] {
    [
        Message::Status(StatusFrame {
            verdict: [Verdict::Healthy, Verdict::Internal, Verdict::External][i % 3],
            leak_internal_ml_min: i.is_multiple_of(2).then_some(120 * i as i16),
            leak_external_ml_min: Some(-7),
            health: 0x0041 << (i % 3),
        }),
        Message::Alarm(AlarmFrame {
            state: AlarmState::ALL[i % AlarmState::ALL.len()],
            latched: LeakSet::ALL[i % 4],
            relay_energised: i.is_multiple_of(2),
            faulted_channels: (i as u8).wrapping_mul(37),
            device_fault: (i % 9) as u8,
            changed_at_ms: (i as u32).wrapping_mul(0x2468_ACE1),
        }),
        Message::Detail(DetailFrame {
            leading: Hypothesis::ALL[i % 4],
            leak_internal_sd_ml_min: Some(13),
            leak_external_sd_ml_min: None,
            valve_gain_extend_permille: Some(-31),
            valve_gain_retract_permille: None,
        }),
        Message::Heartbeat(HeartbeatFrame {
            reset_cause: ResetCause::ALL[i % 8],
            uptime_s: 4099u16.wrapping_mul(i as u16),
            estimator_load_pct: 37,
            peak_load_pct: 61,
            missed_samples: 0,
            adc_overruns: 1,
            can_tx_dropped: 2,
        }),
        Message::Challenge(ChallengeFrame {
            key: KeyKind::ALL[i % 2],
            challenge: (i as u32).wrapping_mul(0x9E37_79B9),
            last_ack: AckResult::ALL.get(i % 12).copied(),
            ack_attempts: i as u8,
        }),
        Message::Identity(IdentityFrame {
            node: Node::ALL[i % Node::ALL.len()],
            params_crc: (i as u32).wrapping_mul(0x2545_F491),
            params_version: i as u16,
        }),
        Message::Version(VersionFrame {
            firmware: [0, 1, i as u8],
            link_protocol: 1,
        }),
        Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: (i % 3 != 0).then_some(80 * i as u16),
            alarm_level_external_ml_min: Some(1700),
            evidence_weight_pct: Some((i * 5) as u8),
        }),
    ]
}

fn write(dir: &Path, name: &str, data: &[u8]) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join(name), data).unwrap();
}

fn candump_line(t: f64, f: &CanFrame) -> String {
    let hex: String = f.data().iter().map(|b| format!("{b:02X}")).collect();
    format!("({t:.6}) can0 {:03X}#{hex}\n", f.id())
}

/// `AnyFrame::read` layout: flags, id (u32), length, 8 bytes.
fn any_bytes(f: &CanFrame) -> Vec<u8> {
    let mut v = vec![0u8];
    v.extend_from_slice(&u32::from(f.id()).to_le_bytes());
    v.push(f.data().len() as u8);
    let mut d = [0u8; 8];
    d[..f.data().len()].copy_from_slice(f.data());
    v.extend_from_slice(&d);
    v
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus");
    let mut enc = Encoder::new();
    let key = AckKey::installation(*b"0123456789abcdef");

    // candump: a log of every kind of frame, 20 of a kind (the counter
    // wraps), with acknowledges, a foreign frame and a comment; one with
    // the lines candump writes that decode skips; one with a lost and a
    // repeated frame.
    let mut log = String::from("# host-sim encoder\n");
    let mut t = 1_700_000_000.0;
    let mut frames = Vec::new();
    for i in 0..20 {
        for m in messages(i) {
            let f = enc.encode(&m);
            log += &candump_line(t, &f);
            frames.push(f);
            t += 0.01;
        }
        let ack = acknowledge_frame(&key, 0xDEAD_BEEF ^ i as u32, (i % 15) as u8);
        log += &candump_line(t, &ack);
    }
    log += "(1700000001.000000) can0 123#DEADBEEF\n";
    write(&root.join("candump"), "encoder.log", log.as_bytes());
    let mut odd = String::new();
    writeln!(odd, "(1700000002.000000) can0 20000080#0000000000000000").unwrap();
    writeln!(odd, "(1700000002.000100) can0 301##1112233").unwrap();
    writeln!(odd, "(1700000002.000200) can0 301#R").unwrap();
    writeln!(odd, "(1700000002.000300) can0 12345678#0011").unwrap();
    writeln!(odd, "(1700000002.000400) can0 301#0011223344556677_9").unwrap();
    writeln!(odd, "(1700000002.000500) can0 12#11:22:33#4455").unwrap();
    odd += &candump_line(1_700_000_002.000_6, &frames[1]).replace('\n', " R\n");
    write(&root.join("candump"), "skipped.log", odd.as_bytes());
    let mut gaps = String::new();
    // Status frames (the first of each group of 8) with counters 0, 1, 3,
    // 3, 8: two lost, one repeated, five lost.
    for k in [0usize, 8, 24, 24, 64] {
        gaps += &candump_line(1_700_000_003.0 + k as f64 * 0.01, &frames[k]);
    }
    write(
        &root.join("candump"),
        "lost-and-repeated.log",
        gaps.as_bytes(),
    );

    // protocol_decoder: one frame of each kind, then a sequence (mode
    // byte 0: the CRC as encoded).
    let dir = root.join("protocol_decoder");
    let mut seq = Vec::new();
    for (k, f) in frames.iter().enumerate().take(8) {
        let mut one = any_bytes(f);
        one.push(0);
        write(&dir, &format!("kind-{k}"), &one);
    }
    for f in frames.iter().step_by(3).take(20) {
        seq.extend(any_bytes(f));
        seq.push(0);
    }
    write(&dir, "sequence", &seq);
    let ack = acknowledge_frame(&key, 7, 3);
    let mut one = any_bytes(&ack);
    one.push(0);
    write(&dir, "command", &one);

    // command_gate: the controller acknowledges (op 0), again too soon,
    // a replay (op 3), an alarm (op 4), a guessed tag (op 7), expiry
    // (op 5 after a jump), forged bytes (op 1) and other traffic (op 6).
    let dir = root.join("command_gate");
    let mut g: Vec<u8> = 42u64.to_le_bytes().to_vec();
    let mut op = |code: u8, dt: u16, rest: &[u8]| {
        g.push(code);
        g.extend_from_slice(&dt.to_le_bytes());
        g.extend_from_slice(&1000u32.to_le_bytes());
        g.extend_from_slice(rest);
    };
    op(0, 100, &[0]);
    op(0, 5, &[1]);
    op(0, 100, &[1]);
    op(3, 100, &[0, 0]);
    op(4, 100, &[1]);
    op(0, 100, &[2]);
    op(7, 100, &[3, 1, 2, 3, 4, 5, 6]);
    op(2, 100, &[b'x'; 18]);
    op(1, 100, &[1, 0, 0x12, 1, 2, 3, 4, 5, 6]);
    op(6, 100, &any_bytes(&frames[0]));
    op(0, 100, &[3]);
    op(0, 100, &[4]);
    op(5, 60_000, &[]);
    op(5, 60_000, &[]);
    op(5, 60_000, &[]);
    op(5, 60_000, &[]);
    op(5, 60_000, &[]);
    op(5, 60_000, &[]);
    op(0, 100, &[5]);
    write(&dir, "session", &g);
    write(
        &dir,
        "ack-once",
        &[&7u64.to_le_bytes()[..], &[0, 0, 0, 0, 0, 0, 0, 0]].concat(),
    );
}
