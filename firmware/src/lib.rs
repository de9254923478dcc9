//! The leak monitor's application, independent of the chip.
//!
//! Everything that decides anything is in the `monitor` crate (and tested
//! on the host); this crate runs it: four tasks, written against the small
//! board trait of [`board`], so the same tasks run on the STM32F405
//! (`src/main.rs`, `src/stm32/`) and on an emulated board.
//!
//! - [`app::estimator`] (high priority): one ADC block per millisecond →
//!   front end → `Monitor::step` → alarm logic → relay → frame scheduling.
//! - [`app::can_tx`], [`app::can_rx`] (low priority): frames out of the
//!   outbox with timeouts; the acknowledge command in.
//! - [`app::supervisor`] (low priority): watchdog fed only while the
//!   estimator keeps its deadline; relay off if it stalls; status LED;
//!   periodic log.
//!
//! Another board (e.g. an emulated one) depends on this crate with
//! `default-features = false`, implements the traits of [`board`],
//! provides an embassy-time driver, a `critical-section` implementation
//! and a defmt logger, defines a `static` [`app::shared::Shared`], and
//! wraps the `run` functions in its own tasks (`src/main.rs` shows how).
#![no_std]
#![deny(missing_docs)]

pub mod app;
pub mod board;
/// The selected board's map (the `boards` crate): pins, analogue front
/// end, sampling.
pub use boards::selected as board_map;

/// The firmware's version as `LM_Version` sends it, written by `build.rs`
/// from Cargo's version of this crate.
pub mod version {
    use monitor::protocol::VersionFrame;
    include!(concat!(env!("OUT_DIR"), "/version.rs"));
}

/// The acknowledge key, compiled in by `build.rs` from
/// `LEAK_MONITOR_ACK_KEY` (or the public development key, reported as
/// such on the bus).
pub mod ack_key {
    use monitor::protocol::auth::AckKey;
    include!(concat!(env!("OUT_DIR"), "/ack_key.rs"));
}
