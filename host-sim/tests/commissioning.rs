//! The commissioning commands end to end against the simulated device
//! (`sim:` port: the device's own link and storage code on a RAM flash):
//! record → upload → show → events, a lost-block report, refusals.

use host_sim::recording::RecordingReader;
use monitor::Params;
use std::path::Path;
use std::process::{Command, Output};

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("host-sim runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn ok(args: &[&str]) -> (String, String) {
    let o = host_sim(args);
    assert!(
        o.status.success(),
        "{args:?} failed: {}{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    (text(&o.stdout), text(&o.stderr))
}

fn simulate(dir: &Path, seconds: &str) -> String {
    let p = dir.join("in.csv");
    ok(&["simulate", "-o", p.to_str().unwrap(), "--duration", seconds]);
    p.to_str().unwrap().to_string()
}

fn samples(path: &str) -> Vec<monitor::Sample> {
    RecordingReader::open(Path::new(path))
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap()
}

/// `host-sim record PORT -o OUT --duration S`; its stderr.
fn record(port: &str, out: &std::path::Path, seconds: &str) -> String {
    let out = out.to_str().unwrap();
    ok(&["record", port, "-o", out, "--duration", seconds]).1
}

#[test]
fn record_equals_what_the_device_streamed() {
    let dir = tempfile::tempdir().unwrap();
    let input = simulate(dir.path(), "2");
    let out = dir.path().join("site.csv.gz");
    let port = format!("sim:{input}");
    let err = record(&port, &out, "2");
    assert!(err.contains("lost blocks: 0 of 200"), "{err}");
    let got = samples(out.to_str().unwrap());
    let want = samples(&input);
    assert_eq!(got.len(), 2000);
    assert_eq!(got, want, "the recording differs from the streamed samples");
    let r = RecordingReader::open(&out).unwrap();
    assert_eq!(
        r.meta("source"),
        Some(format!("firmware {} serial SIM-0001", host_sim::port::SIM_FIRMWARE).as_str())
    );
    assert_eq!(r.meta("sample_rate_hz"), Some("1000"));
    // And it replays.
    let (json, _) = ok(&["replay", out.to_str().unwrap(), "--json"]);
    assert!(json.contains("\"samples\":2000"), "{json}");
}

#[test]
fn record_reports_every_lost_block() {
    let dir = tempfile::tempdir().unwrap();
    let input = simulate(dir.path(), "3");
    let out = dir.path().join("lossy.csv");
    // Every 7th block dropped at the device (slow host), every 11th
    // corrupted on the wire: of 300 blocks, 42 + (27 − 3) = 66 lost.
    let port = format!("sim:{input}?drop=7&corrupt=11");
    let err = record(&port, &out, "3");
    assert!(
        err.contains(
            "lost blocks: 66 of 300 (42 dropped by the device, 24 damaged frames on the link)"
        ),
        "{err}"
    );
    let got = samples(out.to_str().unwrap());
    let want = samples(&input);
    assert_eq!(got.len(), 3000 - 66 * 10);
    // What is there is exact, at its own time.
    for s in &got {
        let i = (s.t_s * 1000.0).round() as usize;
        assert_eq!(*s, want[i]);
    }
}

#[test]
fn upload_show_events_through_reboots() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("flash.bin");
    let port = format!("sim:?state={}", state.display());
    let good = dir.path().join("site.toml");
    std::fs::write(
        &good,
        "[valve]\nnull_offset = 0.002\n[sensors]\npressure_offsets_bar = [0.1, 0.0, -0.05, 0.0]\n",
    )
    .unwrap();

    let (show0, _) = ok(&["params", "show", &port]);
    assert!(show0.starts_with("# parameter set version 0 "), "{show0}");
    assert!(show0.contains("compiled-in default"));

    let (up, _) = ok(&["params", "upload", &port, good.to_str().unwrap()]);
    assert!(
        up.starts_with("active: parameter set version 1 crc "),
        "{up}"
    );

    // A new connection is a reboot of the simulated device.
    let (show, _) = ok(&["params", "show", &port]);
    assert!(show.starts_with("# parameter set version 1 "), "{show}");
    let shown: Params = toml::from_str(&show).unwrap();
    assert_eq!(shown, host_sim::load_params(&good).unwrap());
    let crc_up = up.split("crc ").nth(1).unwrap().split(' ').next().unwrap();
    assert!(show.contains(&format!("crc {crc_up}")));

    // Refused on the host, naming the field; nothing changes.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[cylinder]\nrod_side_area_m2 = 0.004\n").unwrap();
    let o = host_sim(&["params", "upload", &port, bad.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("cylinder.rod_side_area_m2"),
        "{}",
        text(&o.stderr)
    );

    let (json, _) = ok(&["events", &port, "--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let kinds: Vec<&str> = v["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["kind"].as_str().unwrap())
        .collect();
    // Boots: show0, upload, show (the refused upload never connected).
    assert_eq!(
        kinds,
        ["reset", "reset", "params_changed", "reset", "reset"]
    );
    assert_eq!(v["params_version"], 1);
    assert_eq!(v["events"][2]["params_crc"].as_str().unwrap(), crc_up);
    assert_eq!(v["boot"], 4);
    let (table, _) = ok(&["events", &port]);
    assert!(table.contains("parameters changed: version 1"), "{table}");
}

#[test]
fn help_exists_for_every_commissioning_command() {
    for args in [
        &["record", "--help"][..],
        &["params", "upload", "--help"],
        &["params", "show", "--help"],
        &["events", "--help"],
    ] {
        let (out, _) = ok(args);
        assert!(
            out.contains("PORT") || out.contains("<PORT>"),
            "{args:?}: {out}"
        );
    }
}

#[test]
fn a_port_that_does_not_exist_is_a_clear_error() {
    let o = host_sim(&["params", "show", "/dev/nonexistent-leak-monitor"]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("/dev/nonexistent-leak-monitor"),
        "{}",
        text(&o.stderr)
    );
}

/// The real serial-port path (`serialport`, termios, read timeouts): the
/// simulated device behind a pseudo-terminal, `host-sim` on its other end
/// as on `/dev/ttyACM0`.
#[cfg(unix)]
#[test]
fn record_and_upload_over_a_serial_port() {
    use serialport::{SerialPort, TTYPort};
    use std::io::{Read, Write};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    let dir = tempfile::tempdir().unwrap();
    let input = simulate(dir.path(), "1");
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal");
    let path = slave.name().expect("pty name");
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut master_rx = master.try_clone_native().unwrap();
    let mut dev = sim_device(&input, "PTY-7");
    let stop = Arc::new(AtomicBool::new(false));
    // One thread moves bytes both ways between the pty and the device.
    let s2 = stop.clone();
    let bridge = std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while !s2.load(Ordering::SeqCst) {
            match master_rx.read(&mut buf) {
                Ok(n) if n > 0 => dev.write_all(&buf[..n]).unwrap(),
                _ => {}
            }
            loop {
                match dev.read(&mut buf) {
                    Ok(n) if n > 0 => master.write_all(&buf[..n]).unwrap(),
                    _ => break,
                }
            }
        }
    });
    let out = dir.path().join("pty.csv");
    let err = record(&path, &out, "1");
    assert!(err.contains("lost blocks: 0 of 100"), "{err}");
    assert!(err.contains("firmware 9.9.9 serial PTY-7"), "{err}");
    assert_eq!(samples(out.to_str().unwrap()), samples(&input));
    let good = dir.path().join("site.toml");
    std::fs::write(&good, "[valve]\nnull_offset = 0.003\n").unwrap();
    let (up, _) = ok(&["params", "upload", &path, good.to_str().unwrap()]);
    assert!(up.starts_with("active: parameter set version 1 "), "{up}");
    stop.store(true, Ordering::SeqCst);
    bridge.join().unwrap();
    drop(slave);
}

/// The `tcp:HOST:PORT` path (how host-sim reaches the emulated board's
/// UART in QEMU, `-chardev socket,…,server=on`): the simulated device
/// behind a TCP listener on this host, one connection per `host-sim` run
/// as QEMU serves them.
#[test]
fn record_and_upload_over_tcp() {
    use std::io::{ErrorKind, Read, Write};
    use std::net::TcpListener;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    let dir = tempfile::tempdir().unwrap();
    let input = simulate(dir.path(), "1");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    listener.set_nonblocking(true).unwrap();
    let port = format!("tcp:{}", listener.local_addr().unwrap());
    let mut dev = sim_device(&input, "TCP-7");
    let stop = Arc::new(AtomicBool::new(false));
    // One thread accepts each connection in turn and moves bytes both
    // ways between it and the device until the host closes it.
    let s2 = stop.clone();
    let bridge = std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while !s2.load(Ordering::SeqCst) {
            let mut conn = match listener.accept() {
                Ok((c, _)) => c,
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
                Err(e) => panic!("accept: {e}"),
            };
            conn.set_nonblocking(false).unwrap();
            conn.set_read_timeout(Some(Duration::from_millis(5)))
                .unwrap();
            loop {
                match conn.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => dev.write_all(&buf[..n]).unwrap(),
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                    Err(_) => break,
                }
                while let Ok(n @ 1..) = dev.read(&mut buf) {
                    if conn.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
            }
        }
    });
    let out = dir.path().join("tcp.csv");
    let err = record(&port, &out, "1");
    assert!(err.contains("lost blocks: 0 of 100"), "{err}");
    assert!(err.contains("firmware 9.9.9 serial TCP-7"), "{err}");
    assert_eq!(samples(out.to_str().unwrap()), samples(&input));
    let good = dir.path().join("site.toml");
    std::fs::write(&good, "[valve]\nnull_offset = 0.003\n").unwrap();
    let (up, _) = ok(&["params", "upload", &port, good.to_str().unwrap()]);
    assert!(up.starts_with("active: parameter set version 1 "), "{up}");
    let (show, _) = ok(&["params", "show", &port]);
    assert!(show.starts_with("# parameter set version 1 "), "{show}");
    let shown: Params = toml::from_str(&show).unwrap();
    assert_eq!(shown, host_sim::load_params(&good).unwrap());
    stop.store(true, Ordering::SeqCst);
    bridge.join().unwrap();
}

#[test]
fn a_tcp_port_nobody_listens_on_is_a_clear_error() {
    let free = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = format!("tcp:{}", free.local_addr().unwrap());
    drop(free);
    let o = host_sim(&["params", "show", &port]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(err.contains(&format!("{port}: cannot connect")), "{err}");
}

/// The simulated device (firmware "9.9.9", board serial `serial`)
/// streaming the recording `input`, with a short read timeout for a
/// bridge thread.
fn sim_device(input: &str, serial: &str) -> link::sim::SimPort {
    let want = samples(input);
    let cfg = link::sim::SimConfig {
        firmware: "9.9.9",
        serial: serial.into(),
        period_us: 1000,
        source: Box::new(move |tick| want.get(tick as usize).copied()),
        state: None,
        drop_every: None,
        corrupt_every: None,
        default: Params::nominal(),
    };
    let mut dev = link::sim::spawn(cfg).unwrap();
    dev.timeout = std::time::Duration::from_millis(5);
    dev
}
