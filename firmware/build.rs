//! Link script setup: `memory.x` (workspace root) is copied to OUT_DIR so
//! editing it relinks, and defmt's script is added. `link.x` comes from
//! `.cargo/config.toml` (see `../shared/notes/embedded-toolchain-facts.md`).
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
    std::fs::copy(root.join("memory.x"), out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
