//! The candump line parser.

use super::*;

fn frame(line: &str) -> LogFrame {
    match parse_line(line) {
        Ok(Some(Entry::Frame(f))) => f,
        other => panic!("{line}: {other:?}"),
    }
}

fn skipped(line: &str) -> Skip {
    match parse_line(line) {
        Ok(Some(Entry::Skipped(s))) => s,
        other => panic!("{line}: {other:?}"),
    }
}

#[test]
fn parses_candump_lines() {
    let f = frame("(1700000000.123456) can0 301#00112233AABBCCDD");
    assert_eq!(f.time, "1700000000.123456");
    assert_eq!(f.iface, "can0");
    assert_eq!(f.id, 0x301);
    assert!(!f.extended && !f.remote && !f.fd);
    assert_eq!(f.data, [0x00, 0x11, 0x22, 0x33, 0xAA, 0xBB, 0xCC, 0xDD]);
    let f = frame("(1.000001) vcan0 12345678#ab R");
    assert!(f.extended && f.id == 0x1234_5678 && f.data == [0xAB]);
    assert!(frame("(1.0) can0 123#R").remote);
    assert!(frame("(1.0) can0 123#R8").remote);
    assert_eq!(parse_line("").unwrap(), None);
    assert_eq!(parse_line("# comment").unwrap(), None);
    assert!(frame("(1.0) can0 300#").data.is_empty());
}

#[test]
fn skips_what_the_monitor_never_sends() {
    assert_eq!(
        skipped("(1.0) can0 20000080#0000000000000000"),
        Skip::ErrorFrame
    );
    assert_eq!(skipped("(1.0) can0 123##1AABB"), Skip::CanFd);
    assert_eq!(
        skipped("(1.0) can0 45123#81:00:12345678#11223344"),
        Skip::CanXl
    );
    assert_eq!(skipped("(1.0) can0 301#0011223344556677_9"), Skip::OddDlc);
    assert_eq!(skipped("(1.0) can0 301#001122334455667788"), Skip::OddDlc);
    assert_eq!(skipped("(1.0) can0 301#R_C"), Skip::OddDlc);
}

#[test]
fn rejects_malformed_lines_with_a_reason() {
    for (line, why) in [
        ("can0 301#00", "expected"),
        ("(1) can0 301#00", "timestamp"),
        ("(1.x) can0 301#00", "timestamp"),
        ("(1.0) can0 3011#00", "identifier"),
        ("(1.0) can0 801#00", "identifier"),
        ("(1.0) can0 301-00", "id#data"),
        ("(1.0) can0 301#0", "data"),
        ("(1.0) can0 301#zz", "data"),
        ("(1.0) can0 301#00_9", "DLC"),
        ("(1.0) can0 301#0011223344556677_2", "DLC"),
        ("(1.0) can0 123##1AAB", "CAN FD"),
        ("(1.0) can0 301#00 extra", "unexpected"),
    ] {
        let e = parse_line(line).unwrap_err();
        assert!(e.contains(why), "{line}: {e}");
    }
}

#[test]
fn health_and_faulted_channels_by_name() {
    let s = |name, value| Signal {
        name,
        value: SignalValue::Integer { value, unit: "" },
    };
    assert_eq!(
        describe(&s("Health", 0x41)),
        "Health=WARMING_UP|ALARM_LATCHED"
    );
    assert_eq!(describe(&s("Health", 0)), "Health=none");
    assert_eq!(
        describe(&s("Health", 3 << 11)),
        "Health=ACK_EVIDENCE|PROVISIONAL"
    );
    assert_eq!(describe(&s("Health", 1 << 13)), "Health=LOOP_OSCILLATING");
    assert_eq!(describe(&s("Health", 1 << 14)), "Health=VALVE_MISFIT");
    assert_eq!(
        describe(&s("Health", 1 << 15)),
        "Health=HOLD_COMMAND_SHIFTED"
    );
    assert_eq!(
        describe(&s("FaultedChannels", 0b110)),
        "FaultedChannels=p_piston|p_rod"
    );
    assert_eq!(describe(&s("Uptime", 3)), "Uptime=3");
}
