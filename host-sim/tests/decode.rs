//! `host-sim decode` on candump logs written from the monitor's own
//! encoder: decoded values, flagged CRC errors and counter jumps, strict
//! exit status, malformed lines.

use monitor::device::alarm::AlarmState;
use monitor::protocol::{AlarmFrame, CanFrame, Encoder, Message, SensitivityFrame, StatusFrame};
use monitor::LeakSet;
use monitor::Verdict;
use std::path::Path;
use std::process::{Command, Output};

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("host-sim runs")
}

fn line(t_us: u64, f: &CanFrame) -> String {
    let hex: String = f.data().iter().map(|b| format!("{b:02X}")).collect();
    format!(
        "({}.{:06}) can0 {:03X}#{hex}\n",
        t_us / 1_000_000,
        t_us % 1_000_000,
        f.id()
    )
}

fn status(internal_ml_min: i16) -> Message {
    Message::Status(StatusFrame {
        verdict: Verdict::Internal,
        leak_internal_ml_min: Some(internal_ml_min),
        leak_external_ml_min: None,
        health: 0x0040,
    })
}

fn write_log(dir: &Path) -> std::path::PathBuf {
    let mut enc = Encoder::new();
    let mut log = String::from("# a candump log\n");
    let alarm = Message::Alarm(AlarmFrame {
        state: AlarmState::Leak,
        latched: LeakSet::INTERNAL,
        relay_energised: false,
        faulted_channels: 0,
        device_fault: 0,
        changed_at_ms: 12_345,
    });
    log += &line(1_000_000, &enc.encode(&alarm));
    log += &line(1_100_000, &enc.encode(&status(385)));
    log += &line(1_200_000, &enc.encode(&status(386)));
    // Corrupt one frame, lose two others.
    let f = enc.encode(&status(387));
    let mut bad: Vec<u8> = f.data().to_vec();
    bad[2] ^= 0x01;
    log += &line(1_300_000, &CanFrame::new(f.id(), &bad).unwrap());
    enc.encode(&status(388));
    log += &line(1_600_000, &enc.encode(&status(389)));
    // Someone else's traffic.
    log += "(1.700000) can0 123#DEADBEEF\n";
    let p = dir.join("bus.log");
    std::fs::write(&p, log).unwrap();
    p
}

#[test]
fn decodes_and_flags_crc_errors_and_counter_jumps() {
    let dir = tempfile::tempdir().unwrap();
    let log = write_log(dir.path());
    let out = host_sim(&["decode", log.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 6, "{text}");
    assert!(lines[0].contains("LM_Alarm") && lines[0].contains("AlarmState=leak"));
    assert!(lines[0].contains("LatchedLeak=internal") && lines[0].contains("ChangedAt=12345 ms"));
    assert!(
        lines[1].contains("(1.100000) can0 301 LM_Status"),
        "{}",
        lines[1]
    );
    assert!(lines[1].contains(
        "Verdict=internal LeakInternal=0.385 l/min LeakExternal=n/a Health=ALARM_LATCHED"
    ));
    assert!(lines[3].contains("BAD CRC"), "{}", lines[3]);
    assert!(lines[4].contains("COUNTER JUMP (2 lost)"), "{}", lines[4]);
    assert!(lines[4].contains("LeakInternal=0.389 l/min"));
    assert!(lines[5].contains("not a leak-monitor frame"));
    let summary = String::from_utf8_lossy(&out.stderr);
    assert!(
        summary.contains("6 frames: 4 decoded, 1 bad CRC"),
        "{summary}"
    );
    assert!(
        summary.contains("1 counter jumps (2 frames lost)"),
        "{summary}"
    );
}

#[test]
fn json_output_and_strict_exit_status() {
    let dir = tempfile::tempdir().unwrap();
    let log = write_log(dir.path());
    let out = host_sim(&["decode", "--json", "--strict", log.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "strict: errors were seen");
    let records: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let outcomes: Vec<&str> = records
        .iter()
        .map(|r| r["outcome"].as_str().unwrap())
        .collect();
    assert_eq!(
        outcomes,
        ["ok", "ok", "ok", "bad_crc", "counter_jump", "foreign"]
    );
    assert_eq!(records[1]["signals"]["LeakInternal"], 0.385);
    assert!(records[1]["signals"]["LeakExternal"].is_null());
    assert_eq!(records[4]["lost"], 2);
    assert_eq!(records[1]["counter"], 0);
    assert_eq!(records[4]["counter"], 4);

    // A clean log passes --strict.
    let mut enc = Encoder::new();
    let clean = dir.path().join("clean.log");
    let text: String = (0..20)
        .map(|i| line(i * 100_000, &enc.encode(&status(i as i16))))
        .collect();
    std::fs::write(&clean, text).unwrap();
    let out = host_sim(&["decode", "--strict", clean.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_malformed_line_is_an_error_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.log");
    std::fs::write(
        &p,
        "(1.000000) can0 301#0011223344556677\n(1.1) can0 301#00112\n",
    )
    .unwrap();
    let out = host_sim(&["decode", p.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.log:2:") && err.contains("bad data"),
        "{err}"
    );
    let out = host_sim(&["decode", dir.path().join("missing.log").to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.log: cannot open"));
}

#[test]
fn several_monitors_on_one_bus_are_decoded_by_node() {
    use monitor::protocol::Node;
    let dir = tempfile::tempdir().unwrap();
    let mut a = Encoder::new();
    let mut b = Encoder::for_node(Node::new(3).unwrap());
    let mut log = String::new();
    for k in 0..4 {
        log += &line(1_000_000 + 100_000 * k, &a.encode(&status(100 + k as i16)));
        log += &line(1_050_000 + 100_000 * k, &b.encode(&status(300 + k as i16)));
    }
    let path = dir.path().join("two.log");
    std::fs::write(&path, &log).unwrap();
    let path = path.to_str().unwrap();

    // Every node, each node's counters on their own: no counter jumps.
    let out = host_sim(&["decode", "--json", "--strict", path]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 8);
    for (i, r) in rows.iter().enumerate() {
        let (node, id) = if i % 2 == 0 { (0, 0x301) } else { (3, 0x361) };
        assert_eq!(r["node"], node, "{r}");
        assert_eq!(r["id"], id, "{r}");
        assert_eq!(r["outcome"], "ok", "{r}");
        assert_eq!(r["message"], "LM_Status", "{r}");
    }
    let text = String::from_utf8(host_sim(&["decode", path]).stdout).unwrap();
    assert!(text.contains("LM_Status@3"), "{text}");

    // The identity frame's CRC in hex, as `params show` prints it.
    let id = monitor::protocol::IdentityFrame {
        node: Node::new(3).unwrap(),
        params_crc: 0x54ea_dda8,
        params_version: 3,
    };
    let f = b.encode(&Message::Identity(id));
    let one = dir.path().join("identity.log");
    std::fs::write(&one, line(2_000_000, &f)).unwrap();
    let text = String::from_utf8(host_sim(&["decode", one.to_str().unwrap()]).stdout).unwrap();
    assert!(
        text.contains("LM_Identity@3")
            && text.contains("Node=3 ParamsCrc=54eadda8 ParamsVersion=3"),
        "{text}"
    );

    // One node: the other's frames are foreign.
    let out = host_sim(&["decode", "--json", "--node", "3", path]);
    let text = String::from_utf8(out.stdout).unwrap();
    let ok = text
        .lines()
        .filter(|l| l.contains("\"outcome\":\"ok\""))
        .count();
    assert_eq!(ok, 4, "{text}");
    assert!(text
        .lines()
        .all(|l| l.contains("\"node\":3") || !l.contains("\"node\"")));

    // Not a node.
    let out = host_sim(&["decode", "--node", "8", path]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a node number"));
}

#[test]
fn the_sensitivity_frame_shows_the_alarm_levels_in_use() {
    let dir = tempfile::tempdir().unwrap();
    let mut enc = Encoder::new();
    let frame = |internal: Option<u16>, weight: Option<u8>| {
        Message::Sensitivity(SensitivityFrame {
            alarm_level_internal_ml_min: internal,
            alarm_level_external_ml_min: Some(1700),
            evidence_weight_pct: weight,
        })
    };
    let log = line(1_650_000, &enc.encode(&frame(Some(80), Some(63))))
        + &line(2_650_000, &enc.encode(&frame(None, None)));
    let path = dir.path().join("sensitivity.log");
    std::fs::write(&path, log).unwrap();
    let path = path.to_str().unwrap();

    let out = host_sim(&["decode", "--strict", path]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].contains("can0 307 LM_Sensitivity #0"), "{text}");
    assert!(
        lines[0].contains(
            "AlarmLevelInternal=0.080 l/min AlarmLevelExternal=1.700 l/min EvidenceWeight=63 %"
        ),
        "{text}"
    );
    assert!(
        lines[1].contains("AlarmLevelInternal=n/a") && lines[1].contains("EvidenceWeight=n/a"),
        "{text}"
    );

    let out = host_sim(&["decode", "--json", path]);
    let rows: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows[0]["message"], "LM_Sensitivity");
    assert_eq!(rows[0]["id"], 0x307);
    assert_eq!(rows[0]["signals"]["AlarmLevelInternal"], 0.08);
    assert_eq!(rows[0]["signals"]["AlarmLevelExternal"], 1.7);
    assert_eq!(rows[0]["signals"]["EvidenceWeight"], 63.0);
    assert!(rows[1]["signals"]["AlarmLevelInternal"].is_null());
    assert!(rows[1]["signals"]["EvidenceWeight"].is_null());
    assert_eq!(rows[1]["counter"], 1);
}
