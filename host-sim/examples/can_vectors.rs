//! Frames produced by the monitor's CAN encoder, with the physical value of
//! every signal, one JSON object per line:
//! `{"id": 769, "message": "LM_Status", "data": "hex", "signals": {...}}`
//! (`null`: not available). `scripts/check_dbc.py` decodes the frames with
//! `cantools` against `can/leak-monitor.dbc` and compares every signal.
//! Acknowledge frames also carry `"ack": {"key": hex, "challenge": n}`:
//! the check recomputes their tag with Python's own HMAC-SHA256.
//!
//! `cargo run -p host-sim --example can_vectors`

use monitor::acknowledge::AckResult;
use monitor::device::alarm::AlarmState;
use monitor::protocol::auth::{
    acknowledge_frame, acknowledge_frame_for, AckKey, KeyKind, DEVELOPMENT_KEY,
};
use monitor::protocol::sensitivity;
use monitor::protocol::{
    AlarmFrame, CanFrame, ChallengeFrame, Decoder, DetailFrame, Encoder, HeartbeatFrame,
    IdentityFrame, Message, Node, ResetCause, SensitivityFrame, StatusFrame, VersionFrame,
};
use monitor::LeakSet;
use monitor::{Hypothesis, Verdict};
use std::collections::BTreeMap;
use std::io::Write;

const VERDICTS: [Verdict; 6] = [
    Verdict::Healthy,
    Verdict::Internal,
    Verdict::External,
    Verdict::Both,
    Verdict::SensorFault,
    Verdict::Inconclusive,
];

fn messages() -> Vec<Message> {
    let mut v = Vec::new();
    // 20 of a kind: the counter wraps 14 → 0 inside the set.
    for i in 0..20i32 {
        let flow = |k: i32| -> Option<i16> {
            match (i + k) % 7 {
                0 => None,
                1 => Some(i16::MAX),
                2 => Some(-i16::MAX),
                n => Some((n * 1237 - 4000 + i * 13) as i16),
            }
        };
        v.push(Message::Status(StatusFrame {
            verdict: VERDICTS[i as usize % 6],
            leak_internal_ml_min: flow(0),
            leak_external_ml_min: flow(3),
            health: (0x1357u32.wrapping_mul(i as u32 + 1) & 0xFFFF) as u16,
        }));
        v.push(Message::Alarm(AlarmFrame {
            state: AlarmState::ALL[i as usize % AlarmState::ALL.len()],
            latched: LeakSet::ALL[i as usize % 4],
            relay_energised: i % 3 == 0,
            faulted_channels: (i as u8).wrapping_mul(37),
            device_fault: (i % 9) as u8,
            changed_at_ms: (i as u32).wrapping_mul(0x2468_ACE1),
        }));
        v.push(Message::Detail(DetailFrame {
            leading: Hypothesis::ALL[i as usize % 4],
            leak_internal_sd_ml_min: if i % 5 == 0 {
                None
            } else {
                Some((i * 13 % 255) as u8)
            },
            leak_external_sd_ml_min: if i % 6 == 1 {
                None
            } else {
                Some(254 - i as u8)
            },
            valve_gain_extend_permille: if i % 4 == 2 {
                None
            } else {
                Some((i * 311 - 3000) as i16)
            },
            valve_gain_retract_permille: Some(if i % 2 == 0 {
                i16::MAX
            } else {
                -(i as i16) * 7
            }),
        }));
        v.push(Message::Heartbeat(HeartbeatFrame {
            reset_cause: ResetCause::ALL[i as usize % 8],
            uptime_s: (i as u16).wrapping_mul(4099),
            estimator_load_pct: (i * 11 % 256) as u8,
            peak_load_pct: (255 - i * 3) as u8,
            missed_samples: (i * 17 % 256) as u8,
            adc_overruns: (i % 16) as u8,
            can_tx_dropped: (15 - i % 16) as u8,
        }));
        // Range ends and not available among them.
        let level = |k: i32| -> Option<u16> {
            match (i + k) % 5 {
                0 => None,
                1 => Some(sensitivity::LEVEL_MAX_ML_MIN),
                2 => Some(0),
                n => Some((n * 4099 + i * 577) as u16),
            }
        };
        v.push(Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: level(0),
            alarm_level_external_ml_min: level(2),
            evidence_weight_pct: match i % 6 {
                0 => None,
                1 => Some(sensitivity::WEIGHT_MAX_PCT),
                n => Some((n * 23 - 46) as u8),
            },
        }));
    }
    // 20 of a kind here too; every outcome code, and none.
    for i in 0..20u32 {
        v.push(Message::Challenge(ChallengeFrame {
            key: KeyKind::ALL[i as usize % 2],
            challenge: i.wrapping_mul(0x9E37_79B9) ^ (0xFFFF_0000 * (i % 2)),
            last_ack: AckResult::ALL
                .get(i as usize % (AckResult::ALL.len() + 1))
                .copied(),
            ack_attempts: (i * 13) as u8,
        }));
    }
    // Every node number, range ends of the identity.
    for i in 0..16u32 {
        v.push(Message::Identity(IdentityFrame {
            node: Node::ALL[i as usize % Node::ALL.len()],
            params_crc: [0, u32::MAX, i.wrapping_mul(0x9E37_79B9)][i as usize % 3],
            params_version: [0, u16::MAX, i as u16 * 977][i as usize % 3],
        }));
        v.push(Message::Version(VersionFrame {
            firmware: [i as u8, 255 - i as u8, (i * 17) as u8],
            link_protocol: [0, 1, 255][i as usize % 3],
        }));
    }
    v
}

/// Acknowledge frames as a controller builds them: (key, challenge,
/// frame), counters 0, 1, …, 14, 0, … like any other frame.
fn acknowledges() -> Vec<([u8; 16], u32, CanFrame)> {
    let installation = [
        0x01, 0x23, 0x45, 0x67, 0x89, 0xab, 0xcd, 0xef, 0xfe, 0xdc, 0xba, 0x98, 0x76, 0x54, 0x32,
        0x10,
    ];
    (0..20u32)
        .map(|i| {
            let bytes = if i % 2 == 0 {
                DEVELOPMENT_KEY
            } else {
                installation
            };
            let challenge = i.wrapping_mul(0x2545_F491) ^ 0xDEAD_BEEF;
            let frame = acknowledge_frame(&AckKey::installation(bytes), challenge, (i % 15) as u8);
            (bytes, challenge, frame)
        })
        .collect()
}

fn line(frame: &CanFrame, msg: &Message) -> serde_json::Value {
    let signals: BTreeMap<&str, Option<f64>> = msg
        .signals()
        .iter()
        .map(|s| (s.name, s.value.physical()))
        .collect();
    let data: String = frame.data().iter().map(|b| format!("{b:02X}")).collect();
    serde_json::json!({
        "id": frame.id(),
        "message": msg.kind().name(),
        "data": data,
        "signals": signals,
    })
}

fn main() -> std::io::Result<()> {
    let mut enc = Encoder::new();
    let mut out = std::io::stdout().lock();
    for msg in messages() {
        let frame = enc.encode(&msg);
        writeln!(out, "{}", line(&frame, &msg))?;
    }
    // Another node's block: the same frames, moved.
    let node = Node::new(3).expect("a node number");
    let mut enc = Encoder::for_node(node);
    for msg in messages() {
        let frame = enc.encode(&msg);
        let mut l = line(&frame, &msg);
        l["node"] = node.number().into();
        writeln!(out, "{l}")?;
    }
    let (key, challenge, _) = acknowledges()[1];
    let frame = acknowledge_frame_for(node, &AckKey::installation(key), challenge, 0);
    let msg = Decoder::for_node(node)
        .decode(&frame)
        .expect("node 3's acknowledge decodes")
        .message;
    let mut l = line(&frame, &msg);
    let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
    l["ack"] = serde_json::json!({"key": hex, "challenge": challenge});
    l["node"] = node.number().into();
    writeln!(out, "{l}")?;
    for (key, challenge, frame) in acknowledges() {
        let msg = Decoder::new()
            .decode(&frame)
            .expect("an acknowledge frame decodes")
            .message;
        let mut l = line(&frame, &msg);
        let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
        l["ack"] = serde_json::json!({"key": hex, "challenge": challenge});
        writeln!(out, "{l}")?;
    }
    Ok(())
}
