//! Link setup (`memory.x` copied to OUT_DIR so editing it relinks; `link.x`
//! comes from `.cargo/config.toml`) and the list of golden cases: every
//! `golden/data/NAME.input.bin` with its `NAME.expected.bin`, compiled into
//! flash with `include_bytes!`.
use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let here = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    std::fs::copy(here.join("../memory.x"), out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");

    let data = here.join("golden/data");
    println!("cargo:rerun-if-changed={}", data.display());
    let mut names: Vec<String> = std::fs::read_dir(&data)
        .unwrap_or_else(|e| panic!("{}: {e}", data.display()))
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.strip_suffix(".input.bin").map(str::to_string)
        })
        .collect();
    names.sort();
    assert!(!names.is_empty(), "no golden cases in {}", data.display());
    let mut src = String::from(
        "/// The golden cases in `tests/golden/data`, by name.\npub static CASES: &[Case] = &[\n",
    );
    for n in &names {
        let input = data.join(format!("{n}.input.bin"));
        let expected = data.join(format!("{n}.expected.bin"));
        assert!(
            expected.exists(),
            "{} has no expected file",
            input.display()
        );
        writeln!(
            src,
            "    Case {{ name: {n:?}, input: include_bytes!({:?}), expected: include_bytes!({:?}) }},",
            input.display().to_string(),
            expected.display().to_string()
        )
        .unwrap();
    }
    src.push_str("];\n");
    std::fs::write(out.join("cases.rs"), src).unwrap();
}
