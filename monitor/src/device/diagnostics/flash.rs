//! Flash checksums: the program image and the stored parameter set are
//! checked with a CRC-32 at start-up (in one go) and again in the
//! background, a chunk per call, so a bit that flips while the board runs
//! is found within one pass (the image of ~110 KiB at 1 KiB per 10 ms: ~1 s).

use crc::{Crc, CRC_32_ISO_HDLC};

/// The checksum used for flash regions: CRC-32 (ISO-HDLC, as zlib).
pub const FLASH_CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32 of a whole region in one go (start-up check, sealing tools).
pub fn crc32(region: &[u8]) -> u32 {
    FLASH_CRC.checksum(region)
}

/// The outcome of one background step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScanStep {
    /// The pass goes on.
    InProgress,
    /// A pass over the whole region ended with the expected checksum; the
    /// next call starts a new pass.
    PassOk,
    /// A pass ended with another checksum: the region changed.
    Mismatch {
        /// What the pass computed.
        found: u32,
    },
}

/// A background CRC over a region, a chunk at a time.
#[derive(Clone, Debug)]
pub struct FlashScan {
    expected: u32,
    len: usize,
    offset: usize,
    digest_state: u32,
    passes: u32,
}

impl FlashScan {
    /// A scan of a region of `len` bytes expected to have CRC `expected`.
    pub const fn new(expected: u32, len: usize) -> Self {
        Self {
            expected,
            len,
            offset: 0,
            digest_state: 0,
            passes: 0,
        }
    }

    /// Completed passes with the expected checksum.
    pub const fn passes(&self) -> u32 {
        self.passes
    }

    /// Where the next chunk starts, bytes from the region's start, and how
    /// long it may be (at most `max_chunk`).
    pub fn next_chunk(&self, max_chunk: usize) -> (usize, usize) {
        (self.offset, max_chunk.min(self.len - self.offset))
    }

    /// Feed the chunk at [`Self::next_chunk`]'s offset (the caller reads
    /// it, e.g. from flash with a sealed word patched). An empty chunk
    /// before the end of the region ends the pass as a mismatch.
    pub fn feed(&mut self, chunk: &[u8]) -> ScanStep {
        // The crc crate's digest borrows its `Crc`; keep the register
        // between calls instead and resume from it.
        let mut digest = FLASH_CRC.digest_with_initial(self.digest_state_or_init());
        digest.update(chunk);
        self.offset += chunk.len().min(self.len - self.offset);
        if self.offset < self.len && !chunk.is_empty() {
            self.digest_state = resume_register(digest.finalize());
            return ScanStep::InProgress;
        }
        let found = digest.finalize();
        let complete = self.offset == self.len;
        self.offset = 0;
        self.digest_state = 0;
        if complete && found == self.expected {
            self.passes = self.passes.wrapping_add(1);
            ScanStep::PassOk
        } else {
            ScanStep::Mismatch { found }
        }
    }

    /// Feed the next chunk of `region` (the whole region in memory).
    pub fn step(&mut self, region: &[u8], max_chunk: usize) -> ScanStep {
        let (start, n) = self.next_chunk(max_chunk);
        self.feed(region.get(start..start + n).unwrap_or(&[]))
    }

    fn digest_state_or_init(&self) -> u32 {
        if self.offset == 0 {
            FLASH_CRC.algorithm.init
        } else {
            self.digest_state
        }
    }
}

/// The initial value that resumes a CRC from a finalised intermediate
/// value: undo the final XOR to get the register back, and reverse its bits
/// because `digest_with_initial` reflects the initial value of a reflected
/// algorithm such as ISO-HDLC.
fn resume_register(finalised: u32) -> u32 {
    (finalised ^ FLASH_CRC.algorithm.xorout).reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image() -> [u8; 4096] {
        let mut img = [0u8; 4096];
        for (i, b) in img.iter_mut().enumerate() {
            *b = (i as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3];
        }
        img
    }

    #[test]
    fn chunked_crc_equals_the_one_shot_crc() {
        let img = image();
        let mut s = FlashScan::new(crc32(&img), img.len());
        for chunk in [1, 7, 1000, 4096, 5000] {
            let mut steps = 0;
            loop {
                steps += 1;
                match s.step(&img, chunk) {
                    ScanStep::InProgress => continue,
                    ScanStep::PassOk => break,
                    ScanStep::Mismatch { found } => panic!("chunk {chunk}: {found:#x}"),
                }
            }
            assert_eq!(steps, img.len().div_ceil(chunk), "chunk {chunk}");
        }
        assert_eq!(s.passes(), 5);
    }

    #[test]
    fn a_flipped_bit_is_found_within_one_pass() {
        let mut img = image();
        let mut s = FlashScan::new(crc32(&img), img.len());
        // Half a pass, then a bit flips in the part already checked: the
        // running pass still ends OK, the next one finds it.
        for _ in 0..2 {
            assert_eq!(s.step(&img, 1024), ScanStep::InProgress);
        }
        img[100] ^= 0x08;
        let mut found = None;
        for _ in 0..8 {
            match s.step(&img, 1024) {
                ScanStep::Mismatch { found: f } => {
                    found = Some(f);
                    break;
                }
                ScanStep::PassOk | ScanStep::InProgress => {}
            }
        }
        assert_eq!(found, Some(crc32(&img)));
        // Every single-bit flip anywhere changes the CRC.
        let clean = image();
        for byte in (0..clean.len()).step_by(97) {
            for bit in 0..8 {
                let mut c = clean;
                c[byte] ^= 1 << bit;
                assert_ne!(crc32(&c), crc32(&clean), "byte {byte} bit {bit}");
            }
        }
    }

    #[test]
    fn a_region_shorter_than_expected_is_a_mismatch_not_a_panic() {
        let img = image();
        let mut s = FlashScan::new(crc32(&img), img.len() + 10);
        let mut last = ScanStep::InProgress;
        for _ in 0..10 {
            last = s.step(&img, 4096);
            if last != ScanStep::InProgress {
                break;
            }
        }
        assert!(matches!(last, ScanStep::Mismatch { .. }));
    }
}
