//! Host tools bounded against hostile or broken input (issue 12): line and
//! size limits (a gzip bomb fails fast in little memory), implausible
//! sample rates, empty recordings, a capped event list, CAN frames the
//! monitor never sends, a byte-order mark, values beyond f32.

use flate2::write::GzEncoder;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

fn host_sim(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("host-sim runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn write(dir: &Path, name: &str, body: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p
}

const HEADER: &str = "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n";
const ROW0: &str = "0.000,50.0,21.4,12.9,0.8,0.0412,0.0\n";

/// `replay --json` fails without output on stdout, with every `needle`
/// in the error.
fn assert_refused(path: &Path, needles: &[&str]) {
    let out = host_sim(&["replay", "--json", s(path)]);
    let err = text(&out.stderr);
    assert!(!out.status.success(), "accepted: {}", text(&out.stdout));
    assert!(
        out.stdout.is_empty(),
        "partial output: {}",
        text(&out.stdout)
    );
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
}

/// One gzip member of `n` MiB of `byte` (about 1 KB per MiB).
fn gzip_member(byte: u8, mib: usize) -> Vec<u8> {
    let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::best());
    let chunk = vec![byte; 1 << 20];
    for _ in 0..mib {
        gz.write_all(&chunk).unwrap();
    }
    gz.finish().unwrap()
}

/// A ~3 MB gzip file holding `prefix` then one 3 GiB line without a line
/// end: 3072 copies of a 1 MiB member (a multi-member gzip stream).
fn gzip_bomb(dir: &Path, name: &str, prefix: &str) -> PathBuf {
    let p = dir.join(name);
    let mut f = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
    let mut head = GzEncoder::new(Vec::new(), flate2::Compression::best());
    head.write_all(prefix.as_bytes()).unwrap();
    f.write_all(&head.finish().unwrap()).unwrap();
    let member = gzip_member(b'a', 1);
    for _ in 0..3072 {
        f.write_all(&member).unwrap();
    }
    f.flush().unwrap();
    p
}

/// Run `host-sim` with at most 1 GiB of address space (so that a reader
/// without limits fails fast instead of taking the machine's memory) and
/// return its output and the peak RSS (KiB) over this test process's
/// children so far (all of them are small or bounded).
fn run_bounded(args: &[&str]) -> (Output, i64) {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(BIN);
    cmd.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    // SAFETY: only async-signal-safe calls between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: 1 << 30,
                rlim_max: 1 << 30,
            };
            libc::setrlimit(libc::RLIMIT_AS, &lim);
            Ok(())
        });
    }
    let out = cmd.output().unwrap();
    // SAFETY: getrusage only writes the struct it is given.
    let rss = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut u);
        u.ru_maxrss
    };
    (out, rss)
}

#[test]
fn gzip_bomb_of_one_3_gib_line_fails_fast_in_little_memory() {
    let dir = tempfile::tempdir().unwrap();
    let bomb = gzip_bomb(dir.path(), "bomb.csv.gz", "");
    assert!(std::fs::metadata(&bomb).unwrap().len() < 5_000_000);
    let start = std::time::Instant::now();
    let (out, rss_kib) = run_bounded(&["replay", "--json", s(&bomb)]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && out.stdout.is_empty(), "{err}");
    assert!(
        err.contains("bomb.csv.gz:1:") && err.contains("line longer than 65536 bytes"),
        "{err}"
    );
    assert!(start.elapsed().as_secs() < 30, "{:?}", start.elapsed());
    assert!(rss_kib < 100 * 1024, "peak RSS {rss_kib} KiB");

    // The same line after a valid header goes through the CSV reader.
    let bomb = gzip_bomb(dir.path(), "late.csv.gz", &format!("{HEADER}{ROW0}"));
    let (out, rss_kib) = run_bounded(&["replay", "--json", s(&bomb)]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && out.stdout.is_empty(), "{err}");
    assert!(
        err.contains("late.csv.gz:3:") && err.contains("line longer than"),
        "{err}"
    );
    assert!(rss_kib < 100 * 1024, "peak RSS {rss_kib} KiB");
}

#[test]
fn an_unclosed_quote_cannot_make_a_huge_record() {
    let dir = tempfile::tempdir().unwrap();
    let mut body = format!("{HEADER}{ROW0}\"");
    body += &"0.001,50,21,12,0.8,0.04,0\n".repeat(20_000);
    let p = write(dir.path(), "quote.csv", body.as_bytes());
    assert_refused(&p, &["quote.csv:", "record longer than"]);
}

#[test]
fn metadata_lines_are_limited() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!("{}{HEADER}{ROW0}", "# note=x\n".repeat(5000));
    let p = write(dir.path(), "meta.csv", body.as_bytes());
    assert_refused(&p, &["meta.csv:1025:", "more than 1024 metadata lines"]);
}

#[test]
fn decompressed_size_is_limited() {
    use host_sim::recording::{Limits, RecordingReader};
    let mut body = String::from(HEADER);
    for k in 0..1000 {
        body += &format!("{:.3},50.0,21.4,12.9,0.8,0.0412,0.0\n", k as f64 * 0.001);
    }
    let limits = Limits {
        max_total_bytes: 10_000,
        ..Limits::default()
    };
    let r = RecordingReader::with_limits(body.as_bytes(), "big.csv", limits).unwrap();
    let e = r.collect::<Result<Vec<_>, _>>().unwrap_err().to_string();
    assert!(
        e.starts_with("big.csv:") && e.contains("more than 10000 bytes"),
        "{e}"
    );
    // The default is documented and generous: 16 GiB.
    assert_eq!(Limits::default().max_total_bytes, 16 << 30);
}

#[test]
fn a_long_plain_line_is_an_error_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!("{HEADER}{ROW0}0.001,{}\n", "5".repeat(100_000));
    let p = write(dir.path(), "long.csv", body.as_bytes());
    assert_refused(&p, &["long.csv:3:", "line longer than 65536 bytes"]);
    let log = write(
        dir.path(),
        "long.log",
        format!("(1.0) can0 123#{}\n", "A".repeat(100_000)).as_bytes(),
    );
    let out = host_sim(&["decode", s(&log)]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("long.log:1:") && err.contains("longer than"),
        "{err}"
    );
}

#[test]
fn implausible_sample_rate_is_refused_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    for rate in ["1e300", "0", "-1000", "nan", "inf", "5", "200000", "fast"] {
        let body = format!("# format=leak-recording/1\n# sample_rate_hz={rate}\n{HEADER}{ROW0}");
        let p = write(dir.path(), "rate.csv", body.as_bytes());
        assert_refused(&p, &["rate.csv:2:", "sample_rate_hz", rate]);
    }
    let body = format!("# sample_rate_hz=1000\n{HEADER}{ROW0}");
    let p = write(dir.path(), "ok.csv", body.as_bytes());
    assert!(host_sim(&["replay", s(&p)]).status.success());
}

#[test]
fn a_recording_without_samples_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "empty.csv",
        format!("# format=leak-recording/1\n{HEADER}\n").as_bytes(),
    );
    assert_refused(&p, &["empty.csv:2:", "no samples"]);
    let out = host_sim(&["plot", s(&p), "-o", s(&dir.path().join("e.svg"))]);
    assert!(!out.status.success());
}

#[test]
fn the_event_list_is_capped_and_counts_what_it_dropped() {
    let dir = tempfile::tempdir().unwrap();
    // Every step is 10 nominal periods: a data gap at every sample.
    let mut body = format!("# sample_rate_hz=1000\n{HEADER}");
    for k in 0..12_000 {
        body += &format!("{:.2},50.0,26.2,24.9,0.6,0.0400,0.0\n", k as f64 * 0.01);
    }
    let p = write(dir.path(), "gaps.csv", body.as_bytes());
    let out = host_sim(&["replay", "--json", s(&p)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["events"].as_array().unwrap().len(), 10_000);
    assert_eq!(v["events_dropped"], 11_999 - 10_000);
    let out = host_sim(&["replay", s(&p)]);
    let human = text(&out.stdout);
    assert!(human.contains("1999 more events not kept"), "{human}");
}

fn status_line(t: &str, enc: &mut monitor::protocol::Encoder) -> String {
    use monitor::protocol::{Message, StatusFrame};
    let f = enc.encode(&Message::Status(StatusFrame {
        verdict: monitor::Verdict::Healthy,
        leak_internal_ml_min: Some(0),
        leak_external_ml_min: Some(0),
        health: 0,
    }));
    let hex: String = f.data().iter().map(|b| format!("{b:02X}")).collect();
    format!("({t}) can0 {:03X}#{hex}\n", f.id())
}

#[test]
fn decode_skips_and_counts_frames_the_monitor_never_sends() {
    let dir = tempfile::tempdir().unwrap();
    let mut enc = monitor::protocol::Encoder::new();
    let mut log = status_line("1.000000", &mut enc);
    log += "(1.010000) can0 20000080#0000000000000000\n";
    log += "(1.020000) can0 123##1AABBCCDD\n";
    log += "(1.030000) can0 45123#81:00:12345678#11223344\n";
    log += "(1.040000) can0 301#0011223344556677_9\n";
    log += "(1.050000) can0 123#001122334455667788\n";
    log += &status_line("1.100000", &mut enc);
    let p = write(dir.path(), "bus.log", log.as_bytes());
    let out = host_sim(&["decode", s(&p)]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(
        text(&out.stdout).lines().count(),
        2,
        "{}",
        text(&out.stdout)
    );
    assert!(
        err.contains("2 frames: 2 decoded") && err.contains("5 lines skipped"),
        "{err}"
    );
    assert!(
        err.contains("1 CAN error frames, 1 CAN FD, 1 CAN XL, 2 DLC above 8"),
        "{err}"
    );

    let out = host_sim(&["decode", "--strict", s(&p)]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for n in 2..=6 {
        assert!(err.contains(&format!("bus.log:{n}:")), "line {n}: {err}");
    }
    assert!(err.contains("CAN error frame"), "{err}");
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    for body in [
        format!("\u{feff}{HEADER}{ROW0}"),
        format!("\u{feff}# format=leak-recording/1\n{HEADER}{ROW0}"),
    ] {
        let p = write(dir.path(), "bom.csv", body.as_bytes());
        let out = host_sim(&["replay", "--json", s(&p)]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
}

#[test]
fn a_value_beyond_f32_is_an_error_naming_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!("{HEADER}{ROW0}0.001,50.0,21.4,1e39,0.8,0.0412,0.0\n");
    let p = write(dir.path(), "huge.csv", body.as_bytes());
    assert_refused(
        &p,
        &["huge.csv:3:", "column 4 `p_rod`", "1e39", "out of range"],
    );
}
