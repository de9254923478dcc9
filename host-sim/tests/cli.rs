//! The command line as scripts use it: exit codes, error messages that
//! name file, line and column, the replay JSON contract, the examples.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("host-sim runs")
}

/// `host_sim(args)`, which must succeed (the failure names the arguments
/// and shows stderr).
fn host_sim_ok(args: &[&str]) -> Output {
    let out = host_sim(args);
    assert!(
        out.status.success(),
        "host-sim {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const HEADER: &str = "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n";
const ROW0: &str = "0.000,50.0,21.4,12.9,0.8,0.0412,0.0\n";

/// `host-sim replay [--json] --params PARAMS REC`, which must succeed.
fn replay_with(params: &Path, rec: &Path, json: bool) -> Output {
    let mut args = vec!["replay"];
    if json {
        args.push("--json");
    }
    args.extend(["--params", params.to_str().unwrap(), rec.to_str().unwrap()]);
    host_sim_ok(&args)
}

/// `host-sim replay --params PARAMS REC`: the human summary.
fn replay_text(params: &Path, rec: &Path) -> String {
    String::from_utf8_lossy(&replay_with(params, rec, false).stdout).into_owned()
}

/// `host-sim replay --json --params PARAMS REC`: the summary JSON.
fn replay_json(params: &Path, rec: &Path) -> serde_json::Value {
    serde_json::from_slice(&replay_with(params, rec, true).stdout).unwrap()
}

fn assert_rejected(body: &str, must_contain: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.csv", body);
    let out = host_sim(&["replay", p.to_str().unwrap(), "--json"]);
    assert!(!out.status.success(), "malformed recording accepted");
    assert!(
        out.stdout.is_empty(),
        "partial output on stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.csv"),
        "error does not name the file: {err}"
    );
    for s in must_contain {
        assert!(err.contains(s), "error does not contain `{s}`: {err}");
    }
}

#[test]
fn missing_column_is_an_error_naming_it() {
    assert_rejected(
        "t,p_supply,p_piston,p_tank,x_piston,u_valve\n0,50,21,1,0.04,0\n",
        &[":1:", "`p_rod`"],
    );
}

#[test]
fn bad_number_is_an_error_naming_line_and_column() {
    let body = format!("{HEADER}{ROW0}0.001,50.0,21.4,12.9,0.8,0.04x2,0.0\n");
    assert_rejected(&body, &[":3:", "column 6 `x_piston`", "0.04x2"]);
}

#[test]
fn time_going_backwards_is_an_error() {
    let body = format!(
        "{HEADER}{ROW0}0.002,50.0,21.4,12.9,0.8,0.0412,0.0\n0.001,50.0,21.4,12.9,0.8,0.0412,0.0\n"
    );
    assert_rejected(&body, &[":4:", "`t`", "does not increase"]);
}

#[test]
fn nan_is_an_error() {
    let body = format!("{HEADER}{ROW0}0.001,50.0,NaN,12.9,0.8,0.0412,0.0\n");
    assert_rejected(
        &body,
        &[":3:", "column 3 `p_piston`", "not a finite number"],
    );
}

#[test]
fn unreadable_file_is_an_error() {
    let out = host_sim(&["replay", "/nonexistent/run.csv", "--json"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/run.csv"));
}

#[test]
fn bad_params_file_is_an_error_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "ok.csv", &format!("{HEADER}{ROW0}"));
    let params = write(dir.path(), "p.toml", "[valve]\ndead_zone = -1.0\n");
    let out = host_sim(&[
        "replay",
        rec.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("p.toml") && err.contains("valve.dead_zone"),
        "{err}"
    );
}

/// Field names are a contract (`host-sim-cli.md`): present, with the
/// documented types.
#[test]
fn replay_json_has_the_contract_fields() {
    let dir = tempfile::tempdir().unwrap();
    let mut body = String::from(HEADER);
    for k in 0..3000 {
        body += &format!("{:.3},50.0,26.2,24.9,0.6,0.0400,0.0\n", k as f64 * 0.001);
    }
    body += "3.000,50.0,,24.9,0.6,0.0400,0.0\n";
    let rec = write(dir.path(), "rest.csv", &body);
    let out = host_sim_ok(&["replay", rec.to_str().unwrap(), "--json"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.trim().lines().count(), 1, "exactly one JSON object");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["recording"].as_str().unwrap().ends_with("rest.csv"));
    assert_eq!(v["samples"], 3001);
    assert!((v["duration_s"].as_f64().unwrap() - 3.0).abs() < 1e-9);
    // The last sample has no piston pressure: a sensor fault, not healthy.
    assert_eq!(v["verdict"], "sensor_fault");
    assert!(v["first_alarm_s"].is_null());
    assert!(v.get("leak_internal_lpm").is_some() && v.get("leak_external_lpm").is_some());
    // Provisional (no --params): the level in use is the gross one.
    assert_eq!(v["alarm_level_internal_lpm"], 5.0);
    assert_eq!(v["alarm_level_external_lpm"], 5.0);
    let events = v["events"].as_array().unwrap();
    assert_eq!(events.len(), 1);
    assert_eq!(events[0]["kind"], "sensor_fault");
    assert_eq!(events[0]["sensor"], "p_piston");
    assert!((events[0]["t"].as_f64().unwrap() - 3.0).abs() < 1e-9);
}

/// A file that holds the laminar factor needs the oil temperature: on a
/// recording without it, replay says so and every sample is a sensor fault.
#[test]
fn replay_without_the_temperature_a_held_laminar_factor_needs_is_a_sensor_fault() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let held = format!(
        "{}\n[filter]\nq_laminar = 0.0\n",
        std::fs::read_to_string(root.join("reference-rig.toml")).unwrap()
    );
    let held = write(dir.path(), "held.toml", &held);
    let rec = root.join("healthy.csv.gz");
    let out = replay_with(&held, &rec, true);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("healthy.csv.gz") && err.contains("no temp_oil column"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["verdict"], "sensor_fault");
    assert!(v["first_alarm_s"].is_null());
    let events = v["events"].as_array().unwrap();
    assert_eq!(events[0]["kind"], "sensor_fault");
    assert_eq!(events[0]["sensor"], "temp_oil");
}

/// The alarm level in use at the end: the user's (0.08 l/min) on the
/// reference rig, raised to the installation's floor in the region the
/// recording ends in (extending), `null` without a leak estimate.
#[test]
fn replay_names_the_alarm_level_in_use() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let rec = root.join("healthy.csv.gz");
    let reference = root.join("reference-rig.toml");
    // The reference rig's set with detection floors while extending only.
    let floored = format!(
        "{}region_floor_internal_lpm = [0.0, 0.0, 0.3]\nregion_floor_external_lpm = [0.0, 0.0, 0.69]\n",
        std::fs::read_to_string(&reference).unwrap()
    );
    let floored = write(dir.path(), "floored.toml", &floored);
    let json = |params: &Path| replay_json(params, &rec);
    let v = json(&reference);
    assert_eq!(v["verdict"], "healthy");
    assert_eq!(v["alarm_level_internal_lpm"], 0.08);
    assert_eq!(v["alarm_level_external_lpm"], 0.08);
    // The recording ends extending: that region's floors.
    let last = host_sim::recording::RecordingReader::open(&rec)
        .unwrap()
        .last()
        .unwrap()
        .unwrap();
    let u_end = last.u_valve.unwrap();
    assert!(u_end > 0.05, "the recording ends extending: {last:?}");
    let v = json(&floored);
    assert_eq!(v["verdict"], "healthy");
    assert_eq!(v["alarm_level_internal_lpm"], 0.3);
    assert_eq!(v["alarm_level_external_lpm"], 0.69);
    let text = replay_text(&floored, &rec);
    assert!(
        text.contains("alarm level internal 0.300 l/min, external 0.690 l/min"),
        "{text}"
    );
    // One sample: no estimate, no level.
    let one = write(dir.path(), "one.csv", &format!("{HEADER}{ROW0}"));
    let out = host_sim_ok(&["replay", "--json", one.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in [
        "leak_internal_lpm",
        "alarm_level_internal_lpm",
        "alarm_level_external_lpm",
    ] {
        assert!(v.get(k).is_some_and(|x| x.is_null()), "{k}: {v}");
    }
}

#[test]
fn a_loop_that_hunts_is_measured_and_named_by_replay() {
    // 10 s at 100 bar of a position loop hunting at 18 Hz: the chamber
    // pressures swing ±30 bar with a ±0.04 command, the piston trembles
    // by ±0.1 mm about its place.
    let mut body = String::from(HEADER);
    for k in 0..10_000 {
        let t = k as f64 * 1e-3;
        let phase = 2.0 * std::f64::consts::PI * 18.0 * t;
        let s = phase.sin();
        body += &format!(
            "{t:.3},100.0,{:.2},{:.2},1.0,{:.5},{:.4}\n",
            50.0 + 30.0 * s,
            40.0 - 30.0 * s,
            0.09 - 1e-4 * phase.cos(),
            0.04 * s
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "hunting.csv", &body);
    let out = host_sim_ok(&["replay", "--json", rec.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let share = v["loop_oscillation_share"].as_f64().unwrap();
    let hz = v["loop_oscillation_hz"].as_f64().unwrap();
    assert!(share > 0.95 && (hz - 18.0).abs() < 1.0, "{v}");
    // The monitor says so itself, as the device would over CAN, from
    // 1.4 s in (the recent share of its 0.2 s windows reaching a half
    // after seven of them).
    let hunting = v["loop_hunting_fraction"].as_f64().unwrap();
    assert!((0.8..0.9).contains(&hunting), "{v}");
    let out = host_sim_ok(&["replay", rec.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("the position loop oscillates at ≈ 18 Hz during"),
        "{text}"
    );
    // A settled recording: measured, no oscillation, no warning.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let out = host_sim_ok(&[
        "replay",
        "--json",
        "--params",
        root.join("reference-rig.toml").to_str().unwrap(),
        root.join("healthy.csv.gz").to_str().unwrap(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["loop_oscillation_share"].as_f64().unwrap() < 0.05, "{v}");
    assert_eq!(v["loop_hunting_fraction"].as_f64(), Some(0.0), "{v}");
    // One sample: nothing to judge.
    let one = write(dir.path(), "one.csv", &format!("{HEADER}{ROW0}"));
    let out = host_sim_ok(&["replay", "--json", one.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["loop_oscillation_share"].is_null(), "{v}");
    assert!(v["loop_oscillation_hz"].is_null(), "{v}");
}

#[test]
fn replay_reports_the_share_of_samples_the_valve_model_did_not_describe() {
    // The reference rig's recording replayed with its own parameters: the
    // valve model fits. With both flow gains at half the rig's, the `both`
    // filter's gains stand ~100 % off: those samples are no evidence, and
    // the replay (like the CAN Health bit 14) says why.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let rig = root.join("reference-rig.toml");
    let rec = root.join("healthy.csv.gz");
    let misfit = |params: &Path| {
        replay_json(params, &rec)["valve_misfit_fraction"]
            .as_f64()
            .unwrap()
    };
    assert_eq!(misfit(&rig), 0.0);
    let dir = tempfile::tempdir().unwrap();
    let half = std::fs::read_to_string(&rig).unwrap()
        + "\n[valve]\nflow_gain_extend_lpm_sqrt_bar = 4.0\nflow_gain_retract_lpm_sqrt_bar = 3.7\n";
    let half = write(dir.path(), "half-valve.toml", &half);
    let share = misfit(&half);
    assert!(share > 0.5, "{share}");
    let text = replay_text(&half, &rec);
    assert!(
        text.contains("beyond what the valve model describes"),
        "{text}"
    );
}

#[test]
fn replay_reports_the_share_of_samples_held_with_a_command_away_from_the_installations() {
    // The reference rig's recording with its own parameters (no holding
    // command: not followed), then with a holding command 0.2 away from
    // the one its loop holds with: `healthy` is withheld at the holds,
    // and the replay (like the CAN Health bit 15) says so.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let rig = root.join("reference-rig.toml");
    let rec = root.join("healthy.csv.gz");
    let replay = |params: &Path, json: bool| {
        let mut args = vec!["replay", "--params", params.to_str().unwrap()];
        if json {
            args.push("--json");
        }
        args.push(rec.to_str().unwrap());
        host_sim_ok(&args).stdout
    };
    let shifted = |params: &Path| {
        let v: serde_json::Value = serde_json::from_slice(&replay(params, true)).unwrap();
        v["hold_command_shifted_fraction"].as_f64().unwrap()
    };
    assert_eq!(shifted(&rig), 0.0);
    let dir = tempfile::tempdir().unwrap();
    let away = std::fs::read_to_string(&rig).unwrap().replace(
        "[baseline]\n",
        "[baseline]\nhold_command = 0.2\nhold_command_tolerance = 0.003\n",
    );
    let away = write(dir.path(), "hold-away.toml", &away);
    assert!(shifted(&away) > 0.0);
    let text = String::from_utf8_lossy(&replay(&away, false)).into_owned();
    assert!(
        text.contains("a valve command away from the installation's"),
        "{text}"
    );
}

#[test]
fn human_summary_without_json() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "ok.csv", &format!("{HEADER}{ROW0}"));
    let out = host_sim(&["replay", rec.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    // One sample is no evidence: never `healthy`.
    assert!(
        text.contains("verdict") && text.contains("INCONCLUSIVE"),
        "{text}"
    );
}

/// The committed examples (README's first command, with their rig's set)
/// give their verdicts. Without `--params` the same recordings run the
/// provisional set: never `healthy`, and their leaks (0.1–0.5 l/min, far
/// below the gross level) raise no alarm.
#[test]
fn example_recordings_give_their_verdicts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let params = root.join("reference-rig.toml");
    for (file, want) in [
        ("healthy.csv.gz", "healthy"),
        ("internal.csv.gz", "internal"),
        ("external.csv.gz", "external"),
        ("both.csv.gz", "both"),
    ] {
        let p = root.join(file);
        let replay = |extra: &[&str]| {
            let mut args = vec!["replay", p.to_str().unwrap(), "--json"];
            args.extend_from_slice(extra);
            let out = host_sim_ok(&args);
            serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
        };
        let v = replay(&["--params", params.to_str().unwrap()]);
        assert_eq!(v["verdict"], want, "{file}");
        assert!(v["provisional_floor_lpm"].is_null(), "{file}");
        let v = replay(&[]);
        assert_eq!(v["verdict"], "inconclusive", "{file} without --params");
        assert!(v["first_alarm_s"].is_null(), "{file} without --params");
        assert_eq!(v["provisional_floor_lpm"], 5.0, "{file} without --params");
    }
}

#[test]
fn simulate_writes_a_recording_replay_reads() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sim.csv");
    host_sim_ok(&[
        "simulate",
        "-o",
        p.to_str().unwrap(),
        "--duration",
        "2",
        "--with-temp",
        "--temp",
        "40",
    ]);
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with("# format=leak-recording/1\n"));
    assert!(text.contains("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve,temp_oil,q_internal_lpm,q_external_lpm\n"));
    assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 2001);
    let out = host_sim(&["replay", p.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
}

/// `--dump-rig` writes the simulator's rig data in the format `--rig`
/// reads: the dumped rig simulates the same recording as the seeded rig it
/// came from, and dumps to the same file again. A monitor parameters file
/// is not a rig file, and a rig file the simulator cannot compute is
/// refused naming the field.
#[test]
fn a_dumped_rig_round_trips_through_rig() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let sim = |extra: &[&str], out: &str| {
        let mut args = vec![
            "simulate",
            "-o",
            out,
            "--duration",
            "2",
            "--internal",
            "0.2",
        ];
        args.extend_from_slice(extra);
        host_sim_ok(&args);
    };
    let (seeded, again) = (path("seeded.csv"), path("again.csv"));
    let (dump, dump2) = (path("rig.toml"), path("rig2.toml"));
    sim(&["--rig-seed", "21", "--dump-rig", &dump], &seeded);
    sim(&["--rig", &dump, "--dump-rig", &dump2], &again);
    let rows = |p: &str| -> Vec<String> {
        let text = std::fs::read_to_string(p).unwrap();
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .map(str::to_string)
            .collect()
    };
    let (a, b) = (rows(&seeded), rows(&again));
    assert_eq!(a.len(), 2001);
    assert!(a == b, "the dumped rig simulates another recording");
    let text = std::fs::read_to_string(&dump).unwrap();
    assert_eq!(text, std::fs::read_to_string(&dump2).unwrap());
    assert!(
        text.contains("[load.pantograph]") && text.contains("pressure_offsets_bar"),
        "{text}"
    );

    let params = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/calibrated-rig21.toml");
    let out = host_sim(&[
        "simulate",
        "-o",
        &path("x.csv"),
        "--rig",
        params.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("calibrated-rig21.toml") && err.contains("not a rig file"),
        "{err}"
    );
    let bad = write(dir.path(), "bad.toml", "[cylinder]\nstroke_m = -0.18\n");
    let out = host_sim(&[
        "simulate",
        "-o",
        &path("y.csv"),
        "--rig",
        bad.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.toml") && err.contains("cylinder.stroke_m"),
        "{err}"
    );
}

#[test]
fn calibrate_writes_params_that_replay_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("healthy.csv.gz");
    let params = dir.path().join("site.toml");
    host_sim_ok(&[
        "simulate",
        "-o",
        rec.to_str().unwrap(),
        "--duration",
        "40",
        "--rig-seed",
        "5",
        "--no-truth",
    ]);
    let out = host_sim_ok(&[
        "calibrate",
        rec.to_str().unwrap(),
        "-o",
        params.to_str().unwrap(),
    ]);
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        report.contains("valve flow gain") && report.contains("NIS"),
        "{report}"
    );
    // This rig's loop stops the piston inside the dead zone where the
    // approach left the spool: no one holding command to follow.
    let all = report.to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        all.contains("different commands at different holds"),
        "{all}"
    );
    let text = std::fs::read_to_string(&params).unwrap();
    assert!(text.starts_with("# Installation parameters fitted by host-sim calibrate"));
    let out = host_sim_ok(&[
        "replay",
        rec.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["verdict"], "healthy");
}

#[test]
fn calibrate_refuses_a_recording_without_moves() {
    let dir = tempfile::tempdir().unwrap();
    let mut body = String::from(HEADER);
    for k in 0..30_000 {
        body += &format!("{:.3},50.0,26.2,24.9,0.6,0.0400,0.0\n", k as f64 * 0.001);
    }
    let rec = write(dir.path(), "still.csv", &body);
    let out = host_sim(&[
        "calibrate",
        rec.to_str().unwrap(),
        "-o",
        dir.path().join("p.toml").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("still.csv") && err.contains("moves"), "{err}");
    // No file, and the user is told what the installation runs meanwhile.
    assert!(!dir.path().join("p.toml").exists());
    assert!(err.contains("runs provisional"), "{err}");
}

#[test]
fn plot_of_a_leak_recording_shows_the_verdict_and_the_alarm() {
    let dir = tempfile::tempdir().unwrap();
    let rec = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/internal.csv.gz");
    let params = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/reference-rig.toml");
    let svg = dir.path().join("internal.svg");
    host_sim_ok(&[
        "plot",
        "--params",
        params.to_str().unwrap(),
        rec.to_str().unwrap(),
        "-o",
        svg.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.trim_start().starts_with("<svg"), "not an SVG");
    for s in [
        "verdict internal",
        "alarm internal",
        "Leak flow estimates",
        "alarm level",
        "warm-up",
    ] {
        assert!(text.contains(s), "plot lacks `{s}`");
    }
    // Every panel draws its series: 4 pressures, position, command, 4 leak
    // curves, 5 probability/weight curves, the two levels' legend lines.
    let lines = text.matches("<polyline").count();
    assert!(lines >= 15, "only {lines} polylines");
    // Decimated: 18 000 samples do not become megabytes.
    assert!(text.len() < 2_000_000, "{} bytes", text.len());
}

#[test]
fn plot_of_a_malformed_recording_is_an_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.csv",
        &format!("{HEADER}{ROW0}0.001,50.0,nan,12.9,0.8,0.0412,0.0\n"),
    );
    let svg = dir.path().join("bad.svg");
    let out = host_sim(&["plot", p.to_str().unwrap(), "-o", svg.to_str().unwrap()]);
    assert!(!out.status.success(), "malformed recording plotted");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.csv:3:"),
        "error does not name the line: {err}"
    );
    assert!(
        !svg.exists(),
        "an SVG was written for a malformed recording"
    );
}
