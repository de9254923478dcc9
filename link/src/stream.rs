//! The sample stream: blocks built on the device, gaps counted on the host.

use crate::message::{SampleBlock, WireSample, SAMPLES_PER_BLOCK};
use monitor::Sample;

/// Collects samples into blocks on the device. Every completed block gets
/// the next sequence number whether it is then sent or dropped
/// ([`BlockBuilder::dropped`]), so the host counts every lost block.
#[derive(Clone, Debug)]
pub struct BlockBuilder {
    next_seq: u32,
    dropped: u32,
    fill: usize,
    block: SampleBlock,
}

impl Default for BlockBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl BlockBuilder {
    /// A new stream (sequence numbers from 0).
    pub const fn new() -> Self {
        Self {
            next_seq: 0,
            dropped: 0,
            fill: 0,
            block: SampleBlock {
                seq: 0,
                first_tick: 0,
                dropped: 0,
                samples: [WireSample {
                    valid: 0,
                    values: [0.0; crate::message::CHANNELS],
                }; SAMPLES_PER_BLOCK],
            },
        }
    }

    /// Add the sample of monitor step `tick`; returns a completed block.
    /// A block holds consecutive steps only: when `tick` does not follow
    /// the previous sample (the device lost samples), the partial block
    /// is abandoned — its sequence number used and counted as dropped,
    /// so the host sees the gap — and a new one starts at `tick`.
    pub fn push(&mut self, tick: u32, sample: &Sample) -> Option<SampleBlock> {
        if self.fill > 0 && tick != self.block.first_tick.wrapping_add(self.fill as u32) {
            self.fill = 0;
            self.next_seq = self.next_seq.wrapping_add(1);
            self.dropped();
        }
        if self.fill == 0 {
            self.block.first_tick = tick;
        }
        self.block.samples[self.fill] = WireSample::from_sample(sample);
        self.fill += 1;
        if self.fill < SAMPLES_PER_BLOCK {
            return None;
        }
        self.fill = 0;
        self.block.seq = self.next_seq;
        self.block.dropped = self.dropped;
        self.next_seq = self.next_seq.wrapping_add(1);
        Some(self.block)
    }

    /// The completed block could not be sent (the host is slow): count it.
    /// Its sequence number stays used, so the host sees the gap.
    pub fn dropped(&mut self) {
        self.dropped = self.dropped.saturating_add(1);
    }

    /// Blocks dropped so far.
    pub fn dropped_count(&self) -> u32 {
        self.dropped
    }

    /// Take over the progress of a builder running elsewhere: `blocks`
    /// completed (sent or dropped) and `dropped` of them dropped.
    pub fn set_progress(&mut self, blocks: u32, dropped: u32) {
        self.next_seq = blocks;
        self.dropped = dropped;
    }

    /// Blocks completed so far (sent or dropped).
    pub fn completed(&self) -> u32 {
        self.next_seq
    }

    /// The last sequence number assigned, `u32::MAX` if none.
    pub fn last_seq(&self) -> u32 {
        self.next_seq.wrapping_sub(1)
    }
}

/// What the host makes of a received block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Accept {
    /// The next block; `lost` blocks were missing before it.
    New {
        /// Blocks missing between the previous one and this.
        lost: u32,
    },
    /// A block seen before (or older than the newest): ignored.
    Duplicate,
}

/// Host side: checks block sequence numbers of one stream (which starts
/// at 0). Every block missing between two received ones is counted once;
/// repeats are ignored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BlockTracker {
    expected: u32,
    /// Blocks received (once each).
    pub received: u64,
    /// Blocks missing (dropped by the device, lost or corrupted on the
    /// way).
    pub lost: u64,
    /// Blocks received again or out of order (ignored).
    pub duplicates: u64,
}

impl BlockTracker {
    /// Account for block `seq`.
    pub fn accept(&mut self, seq: u32) -> Accept {
        let lost = seq.wrapping_sub(self.expected);
        // Half the sequence space ahead is "new", the rest is old.
        if lost > u32::MAX / 2 {
            self.duplicates += 1;
            return Accept::Duplicate;
        }
        self.expected = seq.wrapping_add(1);
        self.received += 1;
        self.lost += u64::from(lost);
        Accept::New { lost }
    }

    /// At the end of a stream whose last block was `last_seq` (from
    /// [`crate::Message::StreamEnd`]; `u32::MAX`: none): count the blocks
    /// missing at the end.
    pub fn finish(&mut self, last_seq: u32) -> u32 {
        let missing = last_seq.wrapping_add(1).wrapping_sub(self.expected);
        if missing > u32::MAX / 2 {
            return 0;
        }
        self.lost += u64::from(missing);
        self.expected = last_seq.wrapping_add(1);
        missing
    }
}

/// Host side: the index of each block's first sample since the stream's
/// first sample, from the device's sample counter (`first_tick`, which
/// wraps after 2³² samples, 49.7 days at 1 kHz) — so time in a recording
/// keeps increasing across the wrap and across lost blocks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamClock {
    last: Option<(u64, u32)>,
}

impl StreamClock {
    /// Index of the first sample of an accepted (new) block.
    pub fn first_index(&mut self, seq: u32, first_tick: u32) -> u64 {
        let index = match self.last {
            // Streams start at block 0, on a block boundary.
            None => u64::from(seq) * SAMPLES_PER_BLOCK as u64,
            Some((index, tick)) => index + u64::from(first_tick.wrapping_sub(tick)),
        };
        self.last = Some((index, first_tick));
        index
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gap_in_the_steps_abandons_the_partial_block() {
        let s = Sample::default();
        let mut b = BlockBuilder::new();
        for tick in 0..3 {
            assert!(b.push(tick, &s).is_none());
        }
        // Steps 3..=6 lost: the partial block (0..3) is dropped.
        let mut done = None;
        for tick in 7..7 + SAMPLES_PER_BLOCK as u32 {
            done = done.or(b.push(tick, &s));
        }
        let block = done.expect("a whole block after the gap");
        assert_eq!((block.seq, block.first_tick, block.dropped), (1, 7, 1));
        assert_eq!((b.completed(), b.dropped_count()), (2, 1));
    }

    #[test]
    fn clock_survives_the_counter_wrap_and_gaps() {
        let mut c = StreamClock::default();
        let n = SAMPLES_PER_BLOCK as u32;
        let t0 = u32::MAX - 25;
        // Block 0 lost: the first received is block 1.
        assert_eq!(c.first_index(1, t0.wrapping_add(n)), u64::from(n));
        assert_eq!(c.first_index(2, t0.wrapping_add(2 * n)), 2 * u64::from(n));
        // Block 3 lost, block 4 after the wrap.
        assert_eq!(c.first_index(4, t0.wrapping_add(4 * n)), 4 * u64::from(n));
    }

    #[test]
    fn tracker_counts_gaps_duplicates_and_the_end() {
        let mut t = BlockTracker::default();
        assert_eq!(t.accept(1), Accept::New { lost: 1 });
        assert_eq!(t.accept(1), Accept::Duplicate);
        assert_eq!(t.accept(0), Accept::Duplicate);
        assert_eq!(t.accept(5), Accept::New { lost: 3 });
        assert_eq!(t.finish(7), 2);
        assert_eq!((t.received, t.lost, t.duplicates), (2, 6, 2));
    }
}
