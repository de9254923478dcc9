//! The board trait: what the application needs from the hardware. The
//! STM32F405 implements it in `src/stm32/`; an emulated board can replay a
//! recording instead of the ADC and report the relay and CAN frames.
//!
//! The traits use `async fn`: the tasks are spawned with concrete board
//! types, whose futures the compiler checks directly (no `Send` bounds
//! are needed on the traits).
#![allow(async_fn_in_trait)]

use monitor::protocol::{CanFrame, IdentityFrame, ResetCause, VersionFrame};

/// The ring buffer overran: at least one block of samples was lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Overrun;

/// Raw ADC data, one block per sample period (1 ms): several scans of all
/// channels in `Channel::ALL` order, interleaved.
pub trait SampleSource {
    /// Wait for the next block. `Err(Overrun)` when data was lost; the
    /// next call returns fresh data again.
    async fn next_block(&mut self) -> Result<&[u16], Overrun>;
}

/// The fail-safe relay. `&self`, so that the estimator and the supervisor
/// can both switch it (each write is atomic).
pub trait RelayOutput: Sync {
    /// Energise (healthy) or de-energise (alarm) the relay.
    fn set_energised(&self, energised: bool);

    /// Is the relay energised, as read back from the relay itself (its
    /// auxiliary contact), independently of what it was driven to?
    fn read_back(&self) -> bool;

    /// What the relay was last driven to.
    fn commanded(&self) -> bool;
}

/// The board's background self-test (e.g. the program image's checksum,
/// a chunk at a time), stepped by the supervisor every check period, and
/// the readings behind the device diagnostics that the supervisor checks
/// (`monitor::device::diagnostics::check`) at its own pace.
pub trait SelfTest {
    /// One step; the device fault it found, if any.
    fn step(&mut self) -> Option<monitor::device::diagnostics::DeviceFault>;

    /// Convert the chip's internal reference VREFINT once and return its
    /// ADC code (12 bits, right-aligned; VDDA = 3.3 V reads about 1502),
    /// or 0 when the conversion did not complete in time. Must not disturb
    /// the sampling of the inputs. Called every few check periods
    /// (`app::supervisor::REFERENCE_EVERY`).
    fn vrefint_code(&mut self) -> u16;

    /// Measure the independent low-speed oscillator (LSI) against the
    /// sample clock: LSI cycles per window of sample time
    /// (`monitor::device::diagnostics::clock::WINDOW_US`, 1 s; 17 000 to
    /// 47 000 on a healthy STM32F405). 0 when the LSI shows no edge at all;
    /// `None` when no valid measurement could be taken this time (tried
    /// again at the next window). Called once per window
    /// (`app::supervisor::CLOCK_EVERY`), the first time one window after
    /// start.
    fn lsi_cycles_per_window(&mut self) -> Option<u32>;

    /// Has the clock security system tripped since boot (the crystal
    /// failed)? Read every check period.
    fn clock_failed(&self) -> bool;
}

/// A CAN transmit error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum CanTxError {
    /// The controller refused the frame.
    Rejected,
}

/// The CAN transmitter.
pub trait CanTransmit {
    /// Queue `frame` for transmission; waits while every transmit buffer
    /// is full (callers bound the wait with a timeout). Returns how many
    /// pending frames the controller gave up to make room (bxCAN replaces
    /// a waiting lower-priority frame by a higher-priority one): those are
    /// lost and count as dropped.
    async fn transmit(&mut self, frame: &CanFrame) -> Result<u8, CanTxError>;

    /// Abort frames still waiting for the bus (after a timeout: bus off
    /// or no other node acknowledging). Returns how many were aborted.
    fn abort_pending(&mut self) -> u8;
}

/// A CAN receive error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum CanRxError {
    /// A bus error (stuff, form, ACK, bit, CRC error) was reported.
    Bus,
    /// A frame that is not a classic data frame with a standard identifier.
    Unsupported,
}

/// The CAN receiver (filtered to the command frame where the hardware
/// can filter).
pub trait CanReceive {
    /// Wait for the next frame.
    async fn receive(&mut self) -> Result<CanFrame, CanRxError>;
}

/// The independent watchdog, already running.
pub trait Watchdog {
    /// Reload it.
    fn feed(&mut self);
}

/// A free-running cycle counter (DWT CYCCNT on the Cortex-M4).
pub trait CycleCounter {
    /// CPU cycles per sample period (168 000 at 168 MHz and 1 kHz).
    const CYCLES_PER_SAMPLE: u32;

    /// The counter now (wrapping).
    fn cycles(&self) -> u32;
}

/// The status LED.
pub trait StatusLed {
    /// Light it or not.
    fn set(&mut self, on: bool);
}

/// Facts about the board read once at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct BootInfo {
    /// Why the board last reset.
    pub reset_cause: ResetCause,
    /// The node and the active parameter set (`LM_Identity`).
    pub identity: IdentityFrame,
    /// The firmware's version (`LM_Version`).
    pub version: VersionFrame,
}

/// The commissioning link's transport went away (USB unplugged or not
/// configured by a host); the bytes were not sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Disconnected;

/// The byte transport of the commissioning link (`link` crate): USB
/// CDC-ACM on the STM32F405, a UART on the emulated board.
pub trait SerialPort {
    /// Wait until a host is connected (at once on a UART).
    async fn wait_connected(&mut self);

    /// Wait for bytes from the host and copy them into `buf` (at least one
    /// byte, at most `buf.len()`). Must be cancel-safe: the link task
    /// drops this future when a block of samples is ready to send, and
    /// no received byte may be lost by that.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Disconnected>;

    /// Send all of `bytes`. Waits while the host is slow (the caller
    /// bounds the wait); `Err` when the host went away.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Disconnected>;
}
