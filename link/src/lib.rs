//! The serial link between a leak monitor and a host computer, and what
//! the device keeps in flash. `no_std`, no allocation (the `std` feature
//! adds the host's client, a RAM flash and a simulated device).
//!
//! - [`frame`]: COBS frames with a sequence number and a CRC-32;
//! - [`message`]: commands, replies, the sample stream, event records;
//! - [`stream`]: blocks of samples, and the host's count of lost blocks;
//! - [`storage`]: the parameter set and the event queue in flash
//!   (`sequential-storage`), power-fail safe;
//! - [`device`]: the device end, transport-agnostic;
//! - [`memory`]: which monitor events the event memory keeps.
//!
//! Parameters change only over this link, never over CAN.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod device;
pub mod frame;
pub mod memory;
pub mod message;
pub mod storage;
pub mod stream;

#[cfg(feature = "std")]
pub mod client;
#[cfg(feature = "std")]
pub mod ram_flash;
#[cfg(feature = "std")]
pub mod sim;

pub use device::{Device, DeviceInfo};
pub use frame::{encode, Decoder, Frame, FrameError};
pub use message::{
    EventKind, EventRecord, Identity, Leak, Message, ParamsId, Refusal, ResetCause, SampleBlock,
    WireSample,
};
pub use storage::{Erase, Loaded, Storage, StoreError};
pub use stream::{Accept, BlockBuilder, BlockTracker, StreamClock};
