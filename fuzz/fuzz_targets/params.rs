#![no_main]
//! `cargo +nightly fuzz run params`: see [`leak_monitor_fuzz::params`].

libfuzzer_sys::fuzz_target!(|data: &[u8]| leak_monitor_fuzz::params::run(data));
