//! The boards the leak monitor runs on: each board's map (pins, analogue
//! front end, sampling) in a module of its own, one of them selected by a
//! feature — the pattern of Hubris' board crates. The firmware, the
//! on-target tests' build script and the emulated board all read the
//! selected map (`boards::selected`), so there is one map, not copies.
//!
//! Adding a board: a module here with the same items as [`h405`], a
//! feature in `Cargo.toml`, a line in the selection below; then the
//! board's HAL side in the firmware (`firmware/src/stm32/` for another
//! STM32, or a new module next to it).
#![no_std]
#![deny(missing_docs)]

pub mod timer;

#[cfg(feature = "h405")]
pub mod h405;

/// The selected board's map.
#[cfg(feature = "h405")]
pub use h405 as selected;

#[cfg(not(any(feature = "h405")))]
compile_error!("no board selected: enable one board feature of the `boards` crate (e.g. `h405`)");
