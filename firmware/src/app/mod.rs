//! The application tasks, generic over the board (see [`crate::board`]).
//! Embassy tasks cannot be generic: each board wraps these `run`
//! functions in `#[embassy_executor::task]` functions with its own types.

pub mod can_rx;
pub mod can_tx;
pub mod estimator;
pub mod shared;
pub mod supervisor;

/// Sample period, µs (1 kHz).
pub const SAMPLE_PERIOD_US: u32 = crate::board_map::SAMPLE_PERIOD_US;
