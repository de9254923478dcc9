#![no_main]
//! `cargo +nightly fuzz run candump`: see [`leak_monitor_fuzz::candump`].

libfuzzer_sys::fuzz_target!(|data: &[u8]| leak_monitor_fuzz::candump::run(data));
