//! Protocol tests: every frame round-trips, corrupted frames are caught,
//! counters are checked, the monitor's floats are quantised as documented.

use super::*;
use crate::device::alarm::AlarmState;
use crate::hypothesis::Hypothesis;
use crate::leak::LeakSet;
use crate::status::{health, Verdict};
use crate::testutil;

/// One message of every kind, with values away from zero in every field.
pub(crate) fn one_of_each() -> [Message; MessageKind::COUNT] {
    [
        Message::Alarm(AlarmFrame {
            state: AlarmState::Leak,
            latched: LeakSet::BOTH,
            relay_energised: false,
            faulted_channels: 0b0100_0101,
            device_fault: 7,
            changed_at_ms: 4_000_000_123,
        }),
        Message::Status(StatusFrame {
            verdict: Verdict::External,
            leak_internal_ml_min: Some(-12),
            leak_external_ml_min: Some(385),
            health: health::ALARM_LATCHED | health::MODEL_MISMATCH | health::TIME_NOT_INCREASING,
        }),
        Message::Detail(DetailFrame {
            leading: Hypothesis::Both,
            leak_internal_sd_ml_min: Some(17),
            leak_external_sd_ml_min: None,
            valve_gain_extend_permille: Some(-53),
            valve_gain_retract_permille: Some(1234),
        }),
        Message::Heartbeat(HeartbeatFrame {
            reset_cause: ResetCause::Watchdog,
            uptime_s: 54_321,
            estimator_load_pct: 37,
            peak_load_pct: 142,
            missed_samples: 3,
            adc_overruns: 1,
            can_tx_dropped: 15,
        }),
        Message::Challenge(ChallengeFrame {
            key: auth::KeyKind::Development,
            challenge: 0x8765_4321,
            last_ack: Some(crate::decision::acknowledge::AckResult::Accepted),
            ack_attempts: 77,
        }),
        Message::Identity(IdentityFrame {
            node: Node::new(6).unwrap(),
            params_crc: 0xFEDC_BA98,
            params_version: 4321,
        }),
        Message::Version(VersionFrame {
            firmware: [3, 14, 15],
            link_protocol: 2,
        }),
        Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: Some(80),
            alarm_level_external_ml_min: Some(1700),
            evidence_weight_pct: Some(63),
        }),
        Message::Command(CommandFrame {
            command: Command::AcknowledgeAlarm,
            mac: [0xA0, 0xB1, 0xC2, 0xD3, 0xE4, 0xF5],
        }),
    ]
}

#[test]
fn every_frame_type_round_trips() {
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    for msg in one_of_each() {
        let frame = enc.encode(&msg);
        assert_eq!(frame.id(), msg.kind().id());
        assert_eq!(frame.data().len(), FRAME_LEN);
        let r = dec.decode(&frame).unwrap();
        assert_eq!(r.message, msg);
        assert_eq!(r.counter, 0);
        assert_eq!(r.sequence, Sequence::First);
    }
}

#[test]
fn not_available_and_extreme_values_round_trip() {
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    let msgs = [
        Message::Status(StatusFrame {
            verdict: Verdict::SensorFault,
            leak_internal_ml_min: None,
            leak_external_ml_min: Some(-i16::MAX),
            health: u16::MAX,
        }),
        Message::Detail(DetailFrame {
            leading: Hypothesis::Healthy,
            leak_internal_sd_ml_min: Some(detail::SD_MAX_ML_MIN),
            leak_external_sd_ml_min: Some(0),
            valve_gain_extend_permille: None,
            valve_gain_retract_permille: Some(i16::MAX),
        }),
        Message::Alarm(AlarmFrame {
            state: AlarmState::EstimatorStalled,
            latched: LeakSet::NONE,
            relay_energised: true,
            faulted_channels: 0xFF,
            device_fault: 8,
            changed_at_ms: u32::MAX,
        }),
        Message::Heartbeat(HeartbeatFrame {
            reset_cause: ResetCause::Unknown,
            uptime_s: u16::MAX,
            estimator_load_pct: 255,
            peak_load_pct: 255,
            missed_samples: 255,
            adc_overruns: 0,
            can_tx_dropped: 0,
        }),
        Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: None,
            alarm_level_external_ml_min: Some(sensitivity::LEVEL_MAX_ML_MIN),
            evidence_weight_pct: None,
        }),
        Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: Some(0),
            alarm_level_external_ml_min: None,
            evidence_weight_pct: Some(sensitivity::WEIGHT_MAX_PCT),
        }),
    ];
    for msg in msgs {
        assert_eq!(dec.decode(&enc.encode(&msg)).unwrap().message, msg);
    }
}

#[test]
fn every_enumerated_value_round_trips() {
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    for state in AlarmState::ALL {
        for latched in LeakSet::ALL {
            let msg = Message::Alarm(AlarmFrame {
                state,
                latched,
                relay_energised: state.relay_energised(),
                faulted_channels: 0,
                device_fault: (state == AlarmState::DeviceFault) as u8 * 3,
                changed_at_ms: 1,
            });
            assert_eq!(dec.decode(&enc.encode(&msg)).unwrap().message, msg);
        }
    }
    for verdict in [
        Verdict::Healthy,
        Verdict::Internal,
        Verdict::External,
        Verdict::Both,
        Verdict::SensorFault,
    ] {
        let msg = Message::Status(StatusFrame {
            verdict,
            leak_internal_ml_min: Some(1),
            leak_external_ml_min: Some(2),
            health: 0,
        });
        assert_eq!(dec.decode(&enc.encode(&msg)).unwrap().message, msg);
    }
    for leading in Hypothesis::ALL {
        let msg = Message::Detail(DetailFrame {
            leading,
            leak_internal_sd_ml_min: None,
            leak_external_sd_ml_min: None,
            valve_gain_extend_permille: None,
            valve_gain_retract_permille: None,
        });
        assert_eq!(dec.decode(&enc.encode(&msg)).unwrap().message, msg);
    }
    for reset_cause in ResetCause::ALL {
        let msg = Message::Heartbeat(HeartbeatFrame {
            reset_cause,
            uptime_s: 0,
            estimator_load_pct: 0,
            peak_load_pct: 0,
            missed_samples: 0,
            adc_overruns: 0,
            can_tx_dropped: 0,
        });
        assert_eq!(dec.decode(&enc.encode(&msg)).unwrap().message, msg);
    }
}

#[test]
fn crc_errors_are_detected_in_every_frame_type() {
    let mut enc = Encoder::new();
    for msg in one_of_each() {
        let frame = enc.encode(&msg);
        for byte in 0..FRAME_LEN {
            for bit in 0..8 {
                let mut data = [0u8; FRAME_LEN];
                data.copy_from_slice(frame.data());
                data[byte] ^= 1 << bit;
                let bad = CanFrame::new(frame.id(), &data).unwrap();
                let err = Decoder::new().decode(&bad).unwrap_err();
                assert!(
                    matches!(err, DecodeError::E2e { kind, .. } if kind == msg.kind()),
                    "{:?} byte {byte} bit {bit}: {err:?}",
                    msg.kind()
                );
            }
        }
    }
}

#[test]
fn a_frame_under_the_wrong_identifier_fails_its_crc() {
    // The Data ID (= identifier) is in the CRC: a status payload sent as
    // a detail frame is rejected, not misread.
    let mut enc = Encoder::new();
    let status = enc.encode(&one_of_each()[1]);
    let moved = CanFrame::new(MessageKind::Detail.id(), status.data()).unwrap();
    assert!(matches!(
        Decoder::new().decode(&moved),
        Err(DecodeError::E2e {
            kind: MessageKind::Detail,
            error: E2eError::Crc { .. }
        })
    ));
}

#[test]
fn counter_jumps_and_repeats_are_reported() {
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    let msg = one_of_each()[1];
    let frames: heapless::Vec<CanFrame, 40> = (0..40).map(|_| enc.encode(&msg)).collect();
    // In order across the wrap 14 → 0.
    for (i, f) in frames[..20].iter().enumerate() {
        let r = dec.decode(f).unwrap();
        assert_eq!(r.counter as usize, i % 15);
        let want = if i == 0 {
            Sequence::First
        } else {
            Sequence::InOrder
        };
        assert_eq!(r.sequence, want, "frame {i}");
    }
    // Frame 19 again: repeated. Then 23 after 19: three lost.
    assert_eq!(
        dec.decode(&frames[19]).unwrap().sequence,
        Sequence::Repeated
    );
    assert_eq!(dec.decode(&frames[23]).unwrap().sequence, Sequence::Lost(3));
    // Counters are per frame kind: another kind starts fresh.
    let alarm = enc.encode(&one_of_each()[0]);
    assert_eq!(dec.decode(&alarm).unwrap().sequence, Sequence::First);
}

#[test]
fn a_frame_with_an_undefined_field_does_not_advance_the_counter_check() {
    // A frame is accepted only as a whole: a right CRC with an undefined
    // field leaves the counter check where it was.
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    let msg = one_of_each()[1];
    dec.decode(&enc.encode(&msg)).unwrap();
    let mut bad = [0u8, 0x60, 0, 0, 0, 0, 0, 0];
    e2e::protect(0x301, &mut bad, 1);
    assert!(matches!(
        dec.decode(&CanFrame::new(0x301, &bad).unwrap()),
        Err(DecodeError::Field { .. })
    ));
    // Counter 1 again: in order (it was not taken by the bad frame).
    let _skipped = enc.encode(&msg);
    let mut good = [0u8; FRAME_LEN];
    msg.write(&mut good);
    e2e::protect(0x301, &mut good, 1);
    let r = dec.decode(&CanFrame::new(0x301, &good).unwrap()).unwrap();
    assert_eq!(r.sequence, Sequence::InOrder);
}

#[test]
fn a_corrupted_frame_does_not_advance_the_counter_check() {
    let mut enc = Encoder::new();
    let mut dec = Decoder::new();
    let msg = one_of_each()[1];
    let a = enc.encode(&msg);
    let b = enc.encode(&msg);
    let mut data = [0u8; FRAME_LEN];
    data.copy_from_slice(b.data());
    data[3] ^= 0x10;
    dec.decode(&a).unwrap();
    assert!(dec.decode(&CanFrame::new(b.id(), &data).unwrap()).is_err());
    assert_eq!(dec.decode(&b).unwrap().sequence, Sequence::InOrder);
}

#[test]
fn foreign_and_malformed_frames_are_rejected() {
    let mut dec = Decoder::new();
    let unknown = CanFrame::new(0x123, &[0; 8]).unwrap();
    assert_eq!(dec.decode(&unknown), Err(DecodeError::UnknownId(0x123)));
    let mut enc = Encoder::new();
    let f = enc.encode(&one_of_each()[1]);
    let short = CanFrame::new(f.id(), &f.data()[..7]).unwrap();
    assert_eq!(
        dec.decode(&short),
        Err(DecodeError::Length {
            kind: MessageKind::Status,
            len: 7
        })
    );
    // Undefined codes with a valid CRC: field errors, not panics.
    let field = |id: u16, mut data: [u8; 8]| {
        e2e::protect(id, &mut data, 0);
        Decoder::new().decode(&CanFrame::new(id, &data).unwrap())
    };
    assert!(matches!(
        field(0x301, [0, 0x60, 0, 0, 0, 0, 0, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "Verdict",
                raw: 6
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x300, [0, 0x60, 9 << 3, 0, 0, 0, 0, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "DeviceFault",
                raw: 9
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x300, [0, 0x70, 0, 0, 0, 0, 0, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "AlarmState",
                raw: 7
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x303, [0, 0x80, 0, 0, 0, 0, 0, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "ResetCause",
                raw: 8
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x310, [0, 0x20, 0, 0, 0, 0, 0, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "Command",
                raw: 2
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x304, [0, 0x00, 0, 0, 0, 0, 12, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "AckResult",
                raw: 12
            },
            ..
        })
    ));
    assert!(matches!(
        field(0x307, [0, 0x00, 0, 0, 0, 0, 101, 0]),
        Err(DecodeError::Field {
            error: FieldError {
                field: "EvidenceWeight",
                raw: 101
            },
            ..
        })
    ));
    // Any tag decodes (the decoder does not check it).
    assert!(field(0x310, [0, 0x10, 0, 0, 0, 0, 0, 1]).is_ok());
}

#[test]
fn embedded_can_frames_decode_the_same() {
    use embedded_can::{Frame, StandardId};
    let mut enc = Encoder::new();
    let f = enc.encode(&one_of_each()[0]);
    let g = <CanFrame as Frame>::new(StandardId::new(f.id()).unwrap(), f.data()).unwrap();
    assert_eq!(Decoder::new().decode(&g).unwrap().message, one_of_each()[0]);
    assert!(
        <CanFrame as Frame>::new(embedded_can::ExtendedId::new(0x300).unwrap(), &[0; 8]).is_none()
    );
    assert!(CanFrame::new(0x800, &[]).is_none() && CanFrame::new(0x300, &[0; 9]).is_none());
}

#[test]
fn status_values_are_rounded_and_saturated() {
    let mut s = testutil::status();
    s.verdict = Verdict::Both;
    s.leak_internal_lpm = Some(0.3856);
    s.leak_external_lpm = Some(-0.0004);
    s.health = health::ALARM_LATCHED;
    let f = StatusFrame::from_status(&s);
    assert_eq!(f.leak_internal_ml_min, Some(386));
    assert_eq!(f.leak_external_ml_min, Some(0));
    assert_eq!(f.verdict, Verdict::Both);
    assert_eq!(f.health, health::ALARM_LATCHED);
    s.leak_internal_lpm = Some(1e6);
    s.leak_external_lpm = Some(f32::NEG_INFINITY);
    let f = StatusFrame::from_status(&s);
    assert_eq!(f.leak_internal_ml_min, Some(i16::MAX));
    assert_eq!(f.leak_external_ml_min, Some(-i16::MAX));
    s.leak_internal_lpm = None;
    s.leak_external_lpm = Some(f32::NAN);
    let f = StatusFrame::from_status(&s);
    assert_eq!(
        (f.leak_internal_ml_min, f.leak_external_ml_min),
        (None, None)
    );
}

#[test]
fn detail_values_are_rounded_and_saturated() {
    let mut s = testutil::status();
    s.leading = Hypothesis::Internal;
    s.leak_internal_sd_lpm = Some(0.0124);
    s.leak_external_sd_lpm = Some(3.0);
    s.valve_gain_deviation = [0.0526, -0.0004];
    let f = DetailFrame::from_status(&s);
    assert_eq!(f.leading, Hypothesis::Internal);
    assert_eq!(f.leak_internal_sd_ml_min, Some(12));
    assert_eq!(f.leak_external_sd_ml_min, Some(detail::SD_MAX_ML_MIN));
    assert_eq!(f.valve_gain_extend_permille, Some(53));
    assert_eq!(f.valve_gain_retract_permille, Some(0));
    s.leak_internal_sd_lpm = None;
    s.valve_gain_deviation = [f32::NAN, 100.0];
    let f = DetailFrame::from_status(&s);
    assert_eq!(f.leak_internal_sd_ml_min, None);
    assert_eq!(f.valve_gain_extend_permille, None);
    assert_eq!(f.valve_gain_retract_permille, Some(i16::MAX));
}

#[test]
fn sensitivity_values_are_rounded_and_saturated() {
    let mut s = testutil::status();
    s.leak_internal_lpm = Some(0.0);
    s.leak_external_lpm = Some(0.0);
    s.alarm_level_lpm = [0.0804, 1.6996];
    s.evidence_weight = 0.634;
    let f = SensitivityFrame::from_status(&s);
    assert_eq!(f.alarm_level_internal_ml_min, Some(80));
    assert_eq!(f.alarm_level_external_ml_min, Some(1700));
    assert_eq!(f.evidence_weight_pct, Some(63));
    s.alarm_level_lpm = [1e6, -1.0];
    s.evidence_weight = 1.2;
    let f = SensitivityFrame::from_status(&s);
    assert_eq!(
        f.alarm_level_internal_ml_min,
        Some(sensitivity::LEVEL_MAX_ML_MIN)
    );
    assert_eq!(f.alarm_level_external_ml_min, Some(0));
    assert_eq!(f.evidence_weight_pct, Some(sensitivity::WEIGHT_MAX_PCT));
    // Without a leak estimate (warming up, a sensor fault) no level is
    // published; a NaN is not available either.
    s.leak_internal_lpm = None;
    s.alarm_level_lpm[1] = f32::NAN;
    s.evidence_weight = f32::NAN;
    let f = SensitivityFrame::from_status(&s);
    assert_eq!(
        (
            f.alarm_level_internal_ml_min,
            f.alarm_level_external_ml_min,
            f.evidence_weight_pct
        ),
        (None, None, None)
    );
}

#[test]
fn heartbeat_nibbles_saturate() {
    let msg = Message::Heartbeat(HeartbeatFrame {
        reset_cause: ResetCause::PowerOn,
        uptime_s: 1,
        estimator_load_pct: 1,
        peak_load_pct: 1,
        missed_samples: 1,
        adc_overruns: 200,
        can_tx_dropped: 16,
    });
    let r = Decoder::new().decode(&Encoder::new().encode(&msg)).unwrap();
    let Message::Heartbeat(h) = r.message else {
        panic!("not a heartbeat: {r:?}");
    };
    assert_eq!((h.adc_overruns, h.can_tx_dropped), (15, 15));
}

#[test]
fn signals_name_every_field_with_its_physical_value() {
    let [alarm, status, detail, heartbeat, challenge, identity, version, sensitivity, command] =
        one_of_each();
    let names = |m: &Message| -> heapless::Vec<&'static str, 12> {
        m.signals().iter().map(|s| s.name).collect()
    };
    assert_eq!(
        names(&alarm).as_slice(),
        [
            "AlarmState",
            "LatchedLeak",
            "RelayEnergised",
            "DeviceFault",
            "FaultedChannels",
            "ChangedAt"
        ]
    );
    assert_eq!(
        names(&status).as_slice(),
        ["Verdict", "LeakInternal", "LeakExternal", "Health"]
    );
    assert_eq!(
        names(&detail).as_slice(),
        [
            "Leading",
            "LeakInternalSd",
            "LeakExternalSd",
            "ValveGainDevExtend",
            "ValveGainDevRetract"
        ]
    );
    assert_eq!(
        names(&heartbeat).as_slice(),
        [
            "ResetCause",
            "Uptime",
            "EstimatorLoad",
            "PeakLoad",
            "MissedSamples",
            "AdcOverruns",
            "CanTxDropped"
        ]
    );
    assert_eq!(
        names(&challenge).as_slice(),
        ["AckKey", "Challenge", "AckResult", "AckAttempts"]
    );
    assert_eq!(
        names(&identity).as_slice(),
        ["Node", "ParamsCrc", "ParamsVersion"]
    );
    assert_eq!(
        names(&version).as_slice(),
        [
            "FirmwareMajor",
            "FirmwareMinor",
            "FirmwarePatch",
            "LinkProtocol"
        ]
    );
    assert_eq!(
        identity.signals()[1].value.physical(),
        Some(f64::from(0xFEDC_BA98_u32))
    );
    assert_eq!(
        names(&sensitivity).as_slice(),
        ["AlarmLevelInternal", "AlarmLevelExternal", "EvidenceWeight"]
    );
    let v = sensitivity.signals();
    assert_eq!(v[0].value.physical(), Some(0.08));
    assert_eq!(v[1].value.physical(), Some(1.7));
    assert_eq!(v[2].value.physical(), Some(63.0));
    assert_eq!(names(&command).as_slice(), ["Command", "Mac"]);
    assert_eq!(
        command.signals()[1].value.physical(),
        Some(0xF5E4_D3C2_B1A0_u64 as f64)
    );
    let s = status.signals();
    assert_eq!(s[2].value.physical(), Some(0.385));
    assert_eq!(s[1].value.physical(), Some(-0.012));
    let d = detail.signals();
    assert_eq!(d[2].value, SignalValue::NotAvailable);
    assert!((d[4].value.physical().unwrap() - 123.4).abs() < 1e-9);
    extern crate std;
    use std::string::ToString;
    assert_eq!(s[2].to_string(), "LeakExternal=0.385 l/min");
    assert_eq!(s[0].to_string(), "Verdict=external");
    assert_eq!(d[2].to_string(), "LeakExternalSd=n/a");
    assert_eq!(v[1].to_string(), "AlarmLevelExternal=1.700 l/min");
    assert_eq!(v[2].to_string(), "EvidenceWeight=63 %");
}

#[test]
fn outbox_sends_the_alarm_before_the_status() {
    let [alarm, status, ..] = one_of_each();
    let mut o = outbox::Outbox::new();
    o.post(status);
    o.post(alarm);
    assert_eq!(o.take_next(), Some(alarm));
    assert_eq!(o.take_next(), Some(status));
    assert_eq!(o.take_next(), None);
}

#[test]
fn a_node_number_moves_the_whole_block() {
    let n3 = Node::new(3).unwrap();
    assert_eq!(Node::new(8), None);
    assert_eq!(MessageKind::Alarm.id_at(n3), 0x360);
    assert_eq!(MessageKind::Challenge.id_at(n3), 0x364);
    assert_eq!(MessageKind::Command.id_at(n3), 0x370);
    for node in Node::ALL {
        for kind in MessageKind::ALL {
            assert_eq!(MessageKind::locate(kind.id_at(node)), Some((kind, node)));
        }
    }
    assert_eq!(MessageKind::Command.id_at(Node::new(7).unwrap()), 0x3F0);
    assert_eq!(MessageKind::Sensitivity.id_at(n3), 0x367);
    for id in [0x000, 0x2FF, 0x308, 0x30F, 0x311, 0x31F, 0x400, 0x7FF] {
        assert_eq!(MessageKind::locate(id), None, "{id:#x}");
    }
}

#[test]
fn a_decoder_takes_only_its_nodes_frames() {
    let n5 = Node::new(5).unwrap();
    let mut enc = Encoder::for_node(n5);
    for msg in one_of_each() {
        let f = enc.encode(&msg);
        assert_eq!(f.id(), msg.kind().id_at(n5));
        assert_eq!(Decoder::for_node(n5).decode(&f).unwrap().message, msg);
        assert_eq!(
            Decoder::new().decode(&f),
            Err(DecodeError::UnknownId(f.id()))
        );
        // Node 0's frame under node 5's identifier fails the CRC (the
        // Data ID is the identifier).
        let f0 = Encoder::new().encode(&msg);
        let moved = CanFrame::new(f.id(), f0.data()).unwrap();
        assert!(matches!(
            Decoder::for_node(n5).decode(&moved),
            Err(DecodeError::E2e { .. })
        ));
    }
}
