#![no_main]
//! `cargo +nightly fuzz run protocol_decoder`: see [`leak_monitor_fuzz::protocol_decoder`].

libfuzzer_sys::fuzz_target!(|data: &[u8]| leak_monitor_fuzz::protocol_decoder::run(data));
