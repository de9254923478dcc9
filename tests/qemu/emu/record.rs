//! What the emulated board saw the firmware do, kept in RAM for the
//! checks at the end of the run: every CAN frame transmitted, the relay
//! output's first write and every change, watchdog feeds, ADC blocks.

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_time::{Duration, Instant};
use heapless::Vec;
use monitor::protocol::CanFrame;

/// Frames kept (an 8 s recording produces about 110).
pub const MAX_FRAMES: usize = 512;
/// Relay changes kept.
pub const MAX_RELAY: usize = 64;

/// A frame handed to the CAN controller.
#[derive(Clone, Copy, Debug)]
pub struct Sent {
    /// When, since boot.
    pub at: Instant,
    /// The frame.
    pub frame: CanFrame,
}

/// A relay write that set a new output (or the first write).
#[derive(Clone, Copy, Debug)]
pub struct RelayChange {
    /// When, since boot.
    pub at: Instant,
    /// The new output.
    pub energised: bool,
}

/// When the supervisor took one kind of diagnostic reading.
#[derive(Clone, Copy, Debug)]
pub struct Readings {
    /// Readings taken.
    pub count: u32,
    /// The first and the last.
    pub span: Option<(Instant, Instant)>,
    /// Shortest and longest time between two readings.
    pub gaps: Option<(Duration, Duration)>,
}

impl Readings {
    const fn new() -> Self {
        Self {
            count: 0,
            span: None,
            gaps: None,
        }
    }

    /// A reading taken at `now`.
    pub fn take(&mut self, now: Instant) {
        self.count += 1;
        let first = match self.span {
            Some((first, last)) => {
                let gap = now - last;
                self.gaps = Some(match self.gaps {
                    Some((lo, hi)) => (lo.min(gap), hi.max(gap)),
                    None => (gap, gap),
                });
                first
            }
            None => now,
        };
        self.span = Some((first, now));
    }
}

/// Everything recorded.
#[derive(Debug)]
pub struct Log {
    /// Frames in transmit order.
    pub frames: Vec<Sent, MAX_FRAMES>,
    /// The relay's first write, then every change.
    pub relay: Vec<RelayChange, MAX_RELAY>,
    /// Relay writes of any value.
    pub relay_writes: u32,
    /// Something did not fit: the log is incomplete.
    pub overflow: bool,
    /// When block 0 of the recording was complete (the board's t0).
    pub t0: Option<Instant>,
    /// Blocks handed to the estimator.
    pub blocks: u32,
    /// ADC overruns reported to the estimator.
    pub overruns: u32,
    /// Watchdog feeds.
    pub feeds: u32,
    /// The first and the last feed.
    pub feed_span: Option<(Instant, Instant)>,
    /// Longest time between two feeds.
    pub max_feed_gap: Duration,
    /// Status LED changes.
    pub led_changes: u32,
    /// VREFINT conversions the supervisor asked for.
    pub vrefint: Readings,
    /// LSI measurements the supervisor asked for.
    pub lsi: Readings,
}

impl Log {
    const fn new() -> Self {
        Self {
            frames: Vec::new(),
            relay: Vec::new(),
            relay_writes: 0,
            overflow: false,
            t0: None,
            blocks: 0,
            overruns: 0,
            feeds: 0,
            feed_span: None,
            max_feed_gap: Duration::from_ticks(0),
            led_changes: 0,
            vrefint: Readings::new(),
            lsi: Readings::new(),
        }
    }

    /// Sample index of time `at` (the block being processed then), or
    /// `None` before block 0.
    pub fn sample_at(&self, at: Instant) -> Option<u32> {
        let t0 = self.t0?;
        (at >= t0).then(|| ((at - t0).as_micros() / 1000) as u32)
    }

    /// The relay output at time `at` (de-energised before any write).
    pub fn relay_at(&self, at: Instant) -> bool {
        self.relay
            .iter()
            .take_while(|c| c.at <= at)
            .last()
            .is_some_and(|c| c.energised)
    }
}

static LOG: Mutex<CriticalSectionRawMutex, RefCell<Log>> = Mutex::new(RefCell::new(Log::new()));

/// Run `f` on the log (in a critical section: keep it short while the
/// firmware runs).
pub fn with<R>(f: impl FnOnce(&mut Log) -> R) -> R {
    LOG.lock(|l| f(&mut l.borrow_mut()))
}
