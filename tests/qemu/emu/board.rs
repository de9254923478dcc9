//! The emulated board: `firmware::board`'s traits on QEMU. The ADC
//! replays a golden recording from flash at 1 kHz; the relay, the CAN
//! controller, the watchdog and the LED record what the firmware does
//! with them (`super::record`); the CAN receiver plays a script of
//! command frames.

use core::future::pending;
use core::sync::atomic::{AtomicBool, Ordering};

use embassy_time::{Duration, Instant, Timer};
use firmware::board::{
    CanReceive, CanRxError, CanTransmit, CanTxError, CycleCounter, Overrun, RelayOutput,
    SampleSource, SelfTest, StatusLed, Watchdog,
};
use firmware::board_map::{BLOCK_LEN, SCANS_PER_SAMPLE};
use monitor::device::diagnostics::DeviceFault;
use monitor::protocol::CanFrame;
use monitor::signal::frontend::CHANNELS;
use qemu_tests::counter;

use super::case::EmuCase;
use super::record::{self, RelayChange, Sent};

/// One ADC block per sample period.
const BLOCK_PERIOD: Duration = Duration::from_micros(firmware::app::SAMPLE_PERIOD_US as u64);
/// Blocks the (emulated) DMA ring buffer holds, as on the STM32 board: a
/// reader that falls this many blocks behind has lost data.
const RING_BLOCKS: u64 = 2;

/// How long the replay waits before its first block, at least: the
/// tasks (estimator, supervisor) are spawned after the ADC started, and
/// the acknowledge script's challenges are computed in between. The
/// linked runs tie virtual time to the host's clock, so that start-up
/// takes longer on a slower machine; with only the rest of the current
/// millisecond, one CI machine saw the boot relay state written at the
/// first block instead of before it, and the first watchdog feed 62 µs
/// after its period.
const START_LEAD: Duration = Duration::from_millis(10);

/// The ADC, DMA and trigger timer: block `k` of the recording is complete
/// at `t0 + k` ms, as TIM3-triggered scans fill a half of the DMA buffer
/// every millisecond. Each channel's code sum is split over the scans
/// (codes differing by at most 1), so the estimator's average is the
/// recorded quarter-code value. After the last block nothing more
/// arrives: to the firmware, the ADC stopped.
pub struct ReplayAdc {
    case: &'static EmuCase,
    t0: Instant,
    next: u32,
    block: [u16; BLOCK_LEN],
    /// Start the recording over after its last block, for ever.
    looping: bool,
    /// From this block on, this channel converts to this code on every
    /// scan (a broken input).
    broken: Option<(u32, usize, u16)>,
}

impl ReplayAdc {
    /// Start the conversions now: block 0 is complete on a millisecond
    /// boundary [`START_LEAD`] after now.
    pub fn start(case: &'static EmuCase) -> Self {
        let t0 = Instant::from_millis((Instant::now() + START_LEAD).as_millis() + 1);
        record::with(|l| l.t0 = Some(t0));
        Self {
            case,
            t0,
            next: 0,
            block: [0; BLOCK_LEN],
            looping: false,
            broken: None,
        }
    }

    /// [`Self::start`] with `channel` converting to `code` on every scan
    /// from block `from` on.
    #[allow(dead_code)] // the open-wire test's only
    pub fn start_broken(case: &'static EmuCase, from: u32, channel: usize, code: u16) -> Self {
        Self {
            broken: Some((from, channel, code)),
            ..Self::start(case)
        }
    }

    /// [`Self::start`], the recording played over and over: the ADC
    /// never stops.
    #[allow(dead_code)] // the upload test's only
    pub fn start_looping(case: &'static EmuCase) -> Self {
        Self {
            looping: true,
            ..Self::start(case)
        }
    }

    fn fill(&mut self, k: u32) {
        let sums = self.case.codes(k);
        let scans = SCANS_PER_SAMPLE as u16;
        for (scan, codes) in self.block.chunks_exact_mut(CHANNELS).enumerate() {
            for (code, &sum) in codes.iter_mut().zip(&sums) {
                *code = sum / scans + u16::from((scan as u16) < sum % scans);
            }
            if let Some((from, channel, broken)) = self.broken {
                if k >= from {
                    codes[channel] = broken;
                }
            }
        }
    }
}

impl SampleSource for ReplayAdc {
    async fn next_block(&mut self) -> Result<&[u16], Overrun> {
        if self.next >= self.case.samples && !self.looping {
            pending::<()>().await;
        }
        let due = self.t0 + BLOCK_PERIOD * self.next;
        Timer::at(due).await;
        let complete = (Instant::now() - self.t0).as_ticks() / BLOCK_PERIOD.as_ticks();
        if complete >= self.next as u64 + RING_BLOCKS {
            // Overwritten before it was read (a whole ring behind):
            // report it, then continue with the latest complete block.
            self.next = if self.looping {
                complete as u32
            } else {
                (complete as u32).min(self.case.samples)
            };
            record::with(|l| l.overruns += 1);
            return Err(Overrun);
        }
        self.fill(self.next % self.case.samples);
        self.next += 1;
        record::with(|l| l.blocks += 1);
        Ok(&self.block)
    }
}

/// VREFINT's code on a healthy board: VDDA = 3.3 V and the typical
/// VREFINT of 1.21 V, 12 bits (1.21 / 3.3 × 4095 = 1501.5).
pub const VREFINT_NOMINAL: u16 = 1502;

/// LSI cycles per second of sample time on a healthy board: the LSI's
/// typical 32 kHz.
pub const LSI_NOMINAL: u32 = 32_000;

/// The board's background self-test and diagnostic readings: finds
/// nothing and reads a healthy board's values, or, when a test injects
/// one, a device fault or a VREFINT code from a given time on. Every
/// reading the supervisor takes is recorded (`record::Log::vrefint`,
/// `record::Log::lsi`).
pub struct ScriptedSelfTest {
    /// The fault and when it appears.
    pub fault: Option<(Instant, DeviceFault)>,
    /// The VREFINT code and when it replaces [`VREFINT_NOMINAL`].
    pub vrefint: Option<(Instant, u16)>,
}

impl SelfTest for ScriptedSelfTest {
    fn step(&mut self) -> Option<DeviceFault> {
        self.fault
            .filter(|(at, _)| Instant::now() >= *at)
            .map(|(_, f)| f)
    }

    fn vrefint_code(&mut self) -> u16 {
        let now = Instant::now();
        record::with(|l| l.vrefint.take(now));
        self.vrefint
            .filter(|(at, _)| now >= *at)
            .map_or(VREFINT_NOMINAL, |(_, code)| code)
    }

    fn lsi_cycles_per_window(&mut self) -> Option<u32> {
        let now = Instant::now();
        record::with(|l| l.lsi.take(now));
        Some(LSI_NOMINAL)
    }

    fn clock_failed(&self) -> bool {
        false
    }
}

/// The fail-safe relay: records its first write and every change.
pub struct RecordingRelay {
    energised: AtomicBool,
}

impl RecordingRelay {
    /// De-energised (the driver input's pull-down), not yet written.
    pub const fn new() -> Self {
        Self {
            energised: AtomicBool::new(false),
        }
    }
}

impl RelayOutput for RecordingRelay {
    fn set_energised(&self, energised: bool) {
        let at = Instant::now();
        record::with(|l| {
            let first = l.relay_writes == 0;
            l.relay_writes += 1;
            let previous = self.energised.swap(energised, Ordering::Relaxed);
            if (first || previous != energised)
                && l.relay.push(RelayChange { at, energised }).is_err()
            {
                l.overflow = true;
            }
        });
    }

    fn read_back(&self) -> bool {
        // The emulated relay follows its driver.
        self.energised.load(Ordering::Relaxed)
    }

    fn commanded(&self) -> bool {
        self.energised.load(Ordering::Relaxed)
    }
}

/// The CAN controller's transmit side: every frame is accepted at once
/// (a bus with a receiver acknowledging everything) and recorded.
pub struct RecordingCanTx;

impl CanTransmit for RecordingCanTx {
    async fn transmit(&mut self, frame: &CanFrame) -> Result<u8, CanTxError> {
        let sent = Sent {
            at: Instant::now(),
            frame: *frame,
        };
        record::with(|l| {
            if l.frames.push(sent).is_err() {
                l.overflow = true;
            }
        });
        Ok(0)
    }

    fn abort_pending(&mut self) -> u8 {
        0
    }
}

/// The CAN controller's receive side: delivers each scripted frame at
/// its time, then nothing.
pub struct ScriptedCanRx {
    script: &'static [(Instant, CanFrame)],
    next: usize,
}

impl ScriptedCanRx {
    /// Deliver `script` (in time order).
    pub fn new(script: &'static [(Instant, CanFrame)]) -> Self {
        Self { script, next: 0 }
    }
}

impl CanReceive for ScriptedCanRx {
    async fn receive(&mut self) -> Result<CanFrame, CanRxError> {
        let Some(&(at, frame)) = self.script.get(self.next) else {
            return pending().await;
        };
        Timer::at(at).await;
        self.next += 1;
        Ok(frame)
    }
}

/// The independent watchdog: counts feeds and the longest gap between
/// them.
pub struct RecordingWatchdog;

impl Watchdog for RecordingWatchdog {
    fn feed(&mut self) {
        let now = Instant::now();
        record::with(|l| {
            l.feeds += 1;
            let first = match l.feed_span {
                Some((first, last)) => {
                    l.max_feed_gap = l.max_feed_gap.max(now - last);
                    first
                }
                None => now,
            };
            l.feed_span = Some((first, now));
        });
    }
}

/// QEMU's TIM2 as the cycle counter: under `-icount shift=0` it counts
/// one tick per instruction, 1 ns of virtual time each
/// (`qemu_tests::counter`). The emulated CPU thus runs 1 000 000
/// instructions per 1 ms sample, about 12 times what a 168 MHz
/// Cortex-M4 executes: the estimator's load figures here are not the
/// chip's (`cargo qemu-bench` measures the step's cost).
pub struct InstructionCounter;

impl CycleCounter for InstructionCounter {
    const CYCLES_PER_SAMPLE: u32 = firmware::app::SAMPLE_PERIOD_US * 1000;

    fn cycles(&self) -> u32 {
        counter::now()
    }
}

/// The status LED: counts changes.
pub struct RecordingLed {
    on: bool,
}

impl RecordingLed {
    /// Off.
    pub const fn new() -> Self {
        Self { on: false }
    }
}

impl StatusLed for RecordingLed {
    fn set(&mut self, on: bool) {
        if on != core::mem::replace(&mut self.on, on) {
            record::with(|l| l.led_changes += 1);
        }
    }
}
