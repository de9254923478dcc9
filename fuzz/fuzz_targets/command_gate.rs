#![no_main]
//! `cargo +nightly fuzz run command_gate`: see [`leak_monitor_fuzz::command_gate`].

libfuzzer_sys::fuzz_target!(|data: &[u8]| leak_monitor_fuzz::command_gate::run(data));
