//! The golden cases the QEMU tests check the Cortex-M4F against
//! (`golden/data`) must be what the current code computes on the
//! host: regenerate them with `scripts/golden.sh` after changing the
//! monitor's numbers.

use host_sim::golden;
use std::path::Path;

#[test]
fn committed_goldens_are_up_to_date() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = root.join("golden/data");
    let stale = golden::check(&dir, &root).expect("golden cases readable");
    assert!(
        stale.is_empty(),
        "{}\nregenerate with scripts/golden.sh and commit the result",
        stale.join("\n")
    );
    let cases = golden::cases(&dir).unwrap();
    let specs: Vec<_> = cases.iter().map(|c| golden::spec_of(c).unwrap()).collect();
    assert!(
        specs.iter().any(|s| s.source.contains("healthy"))
            && specs.iter().any(|s| !s.source.contains("healthy")),
        "the goldens must cover a healthy and a leak recording: {specs:?}"
    );
}

#[test]
fn a_leak_case_raises_its_alarm_within_the_cut() {
    // The leak golden is only worth its bytes if it reaches the decision
    // layer's alarm path.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let both = golden::spec_of(&root.join("golden/data/both")).unwrap();
    let case = golden::generate(&root, &both).unwrap();
    assert_eq!(case.verdict, monitor::Verdict::Both);
    assert!(case.events.len() >= 2, "{:?}", case.events);
}

#[test]
fn a_stale_golden_is_reported() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let src = root.join("golden/data");
    let tmp = tempfile::tempdir().unwrap();
    for name in ["healthy.input.bin", "healthy.expected.bin"] {
        std::fs::copy(src.join(name), tmp.path().join(name)).unwrap();
    }
    assert!(golden::check(tmp.path(), &root).unwrap().is_empty());
    // One bit of one expected per-sample record.
    let e = tmp.path().join("healthy.expected.bin");
    let mut bytes = std::fs::read(&e).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x10;
    std::fs::write(&e, bytes).unwrap();
    let stale = golden::check(tmp.path(), &root).unwrap();
    assert_eq!(stale.len(), 1, "{stale:?}");
    assert!(stale[0].contains("healthy.expected.bin"), "{stale:?}");
}
