#![no_main]
//! `cargo +nightly fuzz run recording`: see [`leak_monitor_fuzz::recording`].

libfuzzer_sys::fuzz_target!(|data: &[u8]| leak_monitor_fuzz::recording::run(data));
