//! Replays every committed corpus entry (`corpus/<target>/*`) through its
//! target's body on any toolchain: `cargo test --no-default-features`
//! (what `scripts/fuzz.sh` runs where nightly is missing). Extra
//! directories to replay (e.g. a crash to check) can be given in
//! `FUZZ_REPLAY_DIRS` as `target=dir` pairs separated by `:`.

use std::path::{Path, PathBuf};

fn entries(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    v.sort();
    v
}

#[test]
fn every_corpus_entry_passes_its_target() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut dirs: Vec<(String, PathBuf)> = leak_monitor_fuzz::TARGETS
        .iter()
        .map(|(name, _)| (name.to_string(), root.join("corpus").join(name)))
        .collect();
    if let Ok(extra) = std::env::var("FUZZ_REPLAY_DIRS") {
        for pair in extra.split(':').filter(|s| !s.is_empty()) {
            let (name, dir) = pair.split_once('=').expect("target=dir");
            dirs.push((name.to_string(), PathBuf::from(dir)));
        }
    }
    for (name, dir) in dirs {
        let run = leak_monitor_fuzz::TARGETS
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("no target {name}"))
            .1;
        let files = entries(&dir);
        assert!(!files.is_empty(), "{}: empty corpus", dir.display());
        for f in &files {
            let data = std::fs::read(f).expect("corpus entry");
            run(&data);
        }
        println!("{name}: {} inputs replayed", files.len());
    }
}

#[test]
fn the_command_gate_seed_reaches_acceptance_and_rejection() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let data = std::fs::read(root.join("corpus/command_gate/session")).expect("seed");
    let s = leak_monitor_fuzz::command_gate::run_counting(&data);
    println!("{s:?}");
    assert!(s.accepted >= 2 && s.rejected >= 4, "{s:?}");
}
