//! The sample stream of the commissioning link, built where the samples
//! are: the estimator packs each sample it stepped into blocks
//! ([`StreamTap`], a few dozen instructions per sample, only while a host
//! streams) and hands complete blocks to the link task through
//! [`SampleStream`] without ever waiting — when the host is slow, a block
//! is dropped and counted, and the host sees the gap in the sequence
//! numbers.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use link::{BlockBuilder, SampleBlock};
use monitor::Sample;

/// Blocks waiting for the link task (each 10 ms of samples).
const QUEUED_BLOCKS: usize = 4;

/// Between the estimator (producer) and the link task (consumer).
pub struct SampleStream {
    on: AtomicBool,
    /// Bumped by the link task at every start: the estimator begins a new
    /// stream (sequence numbers from 0).
    generation: AtomicU32,
    blocks: Channel<CriticalSectionRawMutex, SampleBlock, QUEUED_BLOCKS>,
    completed: AtomicU32,
    /// Blocks the estimator dropped (queue full, or samples lost).
    dropped: AtomicU32,
    /// Blocks the link task took but could not send.
    unsent: AtomicU32,
}

impl Default for SampleStream {
    fn default() -> Self {
        Self::new()
    }
}

impl SampleStream {
    /// No stream.
    pub const fn new() -> Self {
        Self {
            on: AtomicBool::new(false),
            generation: AtomicU32::new(0),
            blocks: Channel::new(),
            completed: AtomicU32::new(0),
            dropped: AtomicU32::new(0),
            unsent: AtomicU32::new(0),
        }
    }

    /// Link task: a host started (`true`) or stopped the stream.
    pub fn set_streaming(&self, on: bool) {
        // Off first: the estimator (which may preempt this at any point)
        // leaves the stream alone while it is reset.
        self.on.store(false, Ordering::Release);
        if on {
            self.blocks.clear();
            self.completed.store(0, Ordering::Relaxed);
            self.dropped.store(0, Ordering::Relaxed);
            self.unsent.store(0, Ordering::Relaxed);
            self.generation.fetch_add(1, Ordering::AcqRel);
            self.on.store(true, Ordering::Release);
        }
    }

    /// Is a host streaming?
    pub fn is_streaming(&self) -> bool {
        self.on.load(Ordering::Acquire)
    }

    /// Link task: a block taken from the queue could not be sent.
    pub fn lost(&self) {
        self.unsent.fetch_add(1, Ordering::AcqRel);
    }

    /// Link task: the next complete block.
    pub async fn next_block(&self) -> SampleBlock {
        self.blocks.receive().await
    }

    /// Blocks completed (sent or dropped) and dropped in this stream.
    pub fn progress(&self) -> (u32, u32) {
        let dropped = self.dropped.load(Ordering::Acquire);
        (
            self.completed.load(Ordering::Acquire),
            dropped.wrapping_add(self.unsent.load(Ordering::Acquire)),
        )
    }
}

/// The estimator's end: builds blocks from the samples it stepped.
pub struct StreamTap {
    builder: BlockBuilder,
    generation: u32,
}

impl Default for StreamTap {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamTap {
    /// Not streaming yet.
    pub const fn new() -> Self {
        Self {
            builder: BlockBuilder::new(),
            generation: 0,
        }
    }

    /// The sample of step `tick`; never waits.
    pub fn push(&mut self, stream: &SampleStream, tick: u32, sample: &Sample) {
        if !stream.on.load(Ordering::Acquire) {
            return;
        }
        let generation = stream.generation.load(Ordering::Acquire);
        if generation != self.generation {
            self.generation = generation;
            self.builder = BlockBuilder::new();
        }
        // (A gap in the ticks — samples lost after an ADC overrun —
        // makes the builder drop its partial block.)
        if let Some(block) = self.builder.push(tick, sample) {
            if stream.blocks.try_send(block).is_err() {
                self.builder.dropped();
            }
        }
        stream
            .completed
            .store(self.builder.completed(), Ordering::Release);
        stream
            .dropped
            .store(self.builder.dropped_count(), Ordering::Release);
    }
}
