//! How the command line behaves for a user (issue 11): bad files do not
//! stop a multi-file run, a closed pipe is quiet, `-` is standard input,
//! `decode` streams and names flags, diagnostics go to stderr, developer
//! commands are hidden, completions and a man page exist.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

fn host_sim(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("host-sim runs")
}

/// Run with `input` on standard input.
fn host_sim_stdin(args: &[&str], input: &[u8]) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-sim runs");
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    let feeder = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let out = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    out
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

const HEADER: &str = "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n";

/// A short recording at rest (3 s at 1 kHz).
fn rest_body(seconds: usize) -> String {
    let mut body = String::from(HEADER);
    for k in 0..seconds * 1000 {
        body += &format!("{:.3},50.0,26.2,24.9,0.6,0.0400,0.0\n", k as f64 * 0.001);
    }
    body
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn replay_keeps_going_after_a_bad_file_and_fails_at_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "a.csv", &rest_body(1));
    let b = write(dir.path(), "b.csv", &rest_body(1));
    let missing = dir.path().join("missing.csv");
    let out = host_sim(&["replay", s(&a), s(&missing), s(&b), "--json"]);
    assert!(!out.status.success(), "a bad file must fail the run");
    let stdout = text(&out.stdout);
    let names: Vec<String> = stdout
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["recording"].to_string())
        .collect();
    assert_eq!(names.len(), 2, "{stdout}");
    assert!(
        names[0].contains("a.csv") && names[1].contains("b.csv"),
        "{names:?}"
    );
    let err = text(&out.stderr);
    assert!(err.contains("missing.csv"), "{err}");
    assert!(!err.contains("a.csv") && !err.contains("b.csv"), "{err}");
}

/// Spawn with stdout's reading end already closed: the first write gets
/// a broken pipe.
fn with_closed_stdout(args: &[&str]) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn a_closed_pipe_ends_quietly_with_status_0() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "a.csv", &rest_body(1));
    let log = write(
        dir.path(),
        "bus.log",
        &"(1.000000) can0 123#DEADBEEF\n".repeat(2000),
    );
    for args in [
        vec!["replay", s(&a), s(&a)],
        vec!["replay", "--json", s(&a)],
        vec!["decode", s(&log)],
        vec!["decode", "--json", s(&log)],
        vec!["completions", "bash"],
        vec!["man"],
        vec!["golden", "--help"],
    ] {
        let out = with_closed_stdout(&args);
        let err = text(&out.stderr);
        assert!(!err.contains("Broken pipe"), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
    }
}

#[test]
fn dash_is_standard_input_for_replay_calibrate_and_plot() {
    let body = rest_body(2);
    let out = host_sim_stdin(&["replay", "-", "--json"], body.as_bytes());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["samples"], 2000);

    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("p.svg");
    let out = host_sim_stdin(&["plot", "-", "-o", s(&svg)], body.as_bytes());
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(svg.exists());

    // A short recording at rest cannot be calibrated: read, then refused
    // (not "cannot read").
    let toml = dir.path().join("p.toml");
    let out = host_sim_stdin(&["calibrate", "-", "-o", s(&toml)], body.as_bytes());
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("calibration") && !err.contains("cannot read"),
        "{err}"
    );
}

#[test]
fn dash_is_standard_input_for_params_too() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "rest.csv", &rest_body(2));
    // A field the monitor uses: a warm-up longer than the recording keeps
    // the verdict inconclusive, so the file from stdin was really read.
    let params = "[filter]\nwarm_up_s = 5.0\n";
    let out = host_sim_stdin(
        &["replay", "--params", "-", s(&rec), "--json"],
        params.as_bytes(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["verdict"], "inconclusive", "{v}");

    // Validated like a file, and named as standard input.
    let out = host_sim_stdin(
        &["replay", "--params", "-", s(&rec)],
        b"[filter]\nwarm_up_s = -1.0\n",
    );
    let err = text(&out.stderr);
    assert!(
        !out.status.success() && err.contains("standard input") && err.contains("warm_up_s"),
        "{err}"
    );

    // Bounded.
    let huge = vec![b'#'; 2 << 20];
    let out = host_sim_stdin(&["replay", "--params", "-", s(&rec)], &huge);
    let err = text(&out.stderr);
    assert!(
        !out.status.success() && err.contains("not a parameter file"),
        "{err}"
    );

    // Standard input cannot be both.
    for args in [
        &["replay", "--params", "-", "-"][..],
        &["calibrate", "--params", "-", "-", "-o", "x.toml"][..],
        &["plot", "--params", "-", "-"][..],
    ] {
        let out = host_sim_stdin(args, params.as_bytes());
        let err = text(&out.stderr);
        assert!(
            !out.status.success() && err.contains("cannot hold both"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn decode_prints_each_frame_as_it_arrives() {
    let mut child = Command::new(BIN)
        .args(["decode", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"(1.000000) can0 123#DEADBEEF\n").unwrap();
    stdin.flush().unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    // The input stays open, as from `candump`: the line must come anyway.
    let line = rx.recv_timeout(Duration::from_secs(20));
    drop(stdin);
    let _ = child.wait();
    let line = line.expect("no output while the input is still open");
    assert!(line.contains("123"), "{line}");
}

#[test]
fn decode_names_the_bits_of_flag_fields() {
    use monitor::protocol::{Encoder, Message, StatusFrame};
    let mut enc = Encoder::new();
    let f = enc.encode(&Message::Status(StatusFrame {
        verdict: monitor::Verdict::Inconclusive,
        leak_internal_ml_min: None,
        leak_external_ml_min: None,
        health: 0x0011,
    }));
    let hex: String = f.data().iter().map(|b| format!("{b:02X}")).collect();
    let log = format!("(1.000000) can0 {:03X}#{hex}\n", f.id());
    let out = host_sim_stdin(&["decode", "-"], log.as_bytes());
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("Health=WARMING_UP|SENSOR_FAULT"),
        "{stdout}"
    );
    // JSON keeps the number and adds the names.
    let out = host_sim_stdin(&["decode", "--json", "-"], log.as_bytes());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["signals"]["Health"], 17.0);
    assert_eq!(
        v["flags"]["Health"],
        serde_json::json!(["WARMING_UP", "SENSOR_FAULT"])
    );
}

#[test]
fn a_missing_file_cause_is_printed_once() {
    for cmd in ["replay", "plot"] {
        let out = host_sim(&[cmd, "/nonexistent/run.csv"]);
        let err = text(&out.stderr);
        assert!(!out.status.success());
        assert!(err.contains("/nonexistent/run.csv"), "{err}");
        assert_eq!(err.matches("No such file").count(), 1, "{cmd}: {err}");
    }
}

#[test]
fn calibrate_diagnostics_go_to_stderr_not_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "still.csv", &rest_body(30));
    let out = host_sim(&["calibrate", s(&rec), "-o", s(&dir.path().join("p.toml"))]);
    assert!(!out.status.success());
    assert!(
        out.stdout.is_empty(),
        "diagnostics on stdout: {}",
        text(&out.stdout)
    );
    let err = text(&out.stderr);
    assert!(
        err.contains("Sensor noise") && err.contains("moves"),
        "{err}"
    );
}

#[test]
fn golden_is_hidden_from_help_but_works() {
    let help = text(&host_sim(&["--help"]).stdout);
    assert!(
        help.contains("replay") && !help.contains("golden"),
        "{help}"
    );
    let out = host_sim(&["golden", "--help"]);
    assert!(out.status.success());
    assert!(text(&out.stdout).contains("check"));
}

#[test]
fn eval_options_are_typed_with_their_values_listed() {
    let out = host_sim(&["eval", "--set", "nonsense"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(err.contains("dev") && err.contains("holdout"), "{err}");
    let help = text(&host_sim(&["simulate", "--help"]).stdout);
    assert!(help.contains("laminar") && help.contains("orifice") && help.contains("thesis"));
}

#[test]
fn completions_and_man_page() {
    for shell in ["bash", "zsh", "fish"] {
        let out = host_sim(&["completions", shell]);
        assert!(out.status.success(), "{shell}: {}", text(&out.stderr));
        let script = text(&out.stdout);
        assert!(
            script.contains("replay") && script.contains("decode"),
            "{shell}"
        );
    }
    let out = host_sim(&["man"]);
    assert!(out.status.success());
    let roff = text(&out.stdout);
    assert!(roff.contains(".TH") && roff.contains("replay"), "{roff}");
}
