//! The golden cases compiled into flash (listed by `build.rs` from
//! `golden/data`; written by `scripts/golden.sh`).

/// One golden case: the input file and the host's expected outputs.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// Case name (file stem).
    pub name: &'static str,
    /// `NAME.input.bin`.
    pub input: &'static [u8],
    /// `NAME.expected.bin`.
    pub expected: &'static [u8],
}

include!(concat!(env!("OUT_DIR"), "/cases.rs"));

/// The case called `name`.
pub fn by_name(name: &str) -> Option<&'static Case> {
    CASES.iter().find(|c| c.name == name)
}
