//! A NorFlash in RAM that can lose power: after a chosen number of word
//! writes (or erases) every further operation fails, the interrupted word
//! is left half-programmed and an interrupted erase half-done — what a
//! power cut does to a real flash. Used by the power-fail tests and the
//! simulated device.

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Bytes per program operation (the STM32F4 programs 32-bit words at
/// 2.7–3.6 V).
pub const WORD: usize = 4;

/// A flash of `pages` pages of `PAGE` bytes.
#[derive(Clone, Debug)]
pub struct RamFlash<const PAGE: usize> {
    data: Vec<u8>,
    /// Operations (word writes and page erases) left before the power
    /// fails; `None`: never.
    pub cut_after: Option<u64>,
    /// Word writes and page erases done so far.
    pub ops: u64,
    /// Page erases done so far.
    pub erases: u64,
    dead: bool,
}

/// The power is off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PowerCut;

impl NorFlashError for PowerCut {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}

impl<const PAGE: usize> RamFlash<PAGE> {
    /// An erased flash.
    pub fn new(pages: usize) -> Self {
        Self {
            data: vec![0xFF; pages * PAGE],
            cut_after: None,
            ops: 0,
            erases: 0,
            dead: false,
        }
    }

    /// A flash holding `data` (a whole number of pages).
    pub fn from_bytes(data: Vec<u8>) -> Self {
        assert!(data.len().is_multiple_of(PAGE));
        Self {
            data,
            cut_after: None,
            ops: 0,
            erases: 0,
            dead: false,
        }
    }

    /// Its contents.
    pub fn as_bytes(&self) -> &[u8] {
        &self.data
    }

    /// Its size, bytes.
    pub fn size(&self) -> u32 {
        self.data.len() as u32
    }

    /// Power back on (the contents stay as the cut left them).
    pub fn power_on(&mut self) {
        self.dead = false;
        self.cut_after = None;
    }

    /// Was the power cut?
    pub fn is_dead(&self) -> bool {
        self.dead
    }

    /// One more operation: false when the power fails now.
    fn tick(&mut self) -> bool {
        if self.dead {
            return false;
        }
        if let Some(left) = self.cut_after.as_mut() {
            if *left == 0 {
                self.dead = true;
                return false;
            }
            *left -= 1;
        }
        self.ops += 1;
        true
    }

    fn check(&self, offset: u32, len: usize) -> Result<(), PowerCut> {
        if offset as usize + len > self.data.len() {
            return Err(PowerCut);
        }
        Ok(())
    }
}

impl<const PAGE: usize> ErrorType for RamFlash<PAGE> {
    type Error = PowerCut;
}

impl<const PAGE: usize> ReadNorFlash for RamFlash<PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), PowerCut> {
        if self.dead {
            return Err(PowerCut);
        }
        self.check(offset, bytes.len())?;
        let o = offset as usize;
        bytes.copy_from_slice(&self.data[o..o + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.data.len()
    }
}

impl<const PAGE: usize> NorFlash for RamFlash<PAGE> {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), PowerCut> {
        self.check(from, (to - from) as usize)?;
        assert!((from as usize).is_multiple_of(PAGE) && (to as usize).is_multiple_of(PAGE));
        for page in (from as usize..to as usize).step_by(PAGE) {
            if !self.tick() {
                // Interrupted: the first half of the page is erased.
                self.data[page..page + PAGE / 2].fill(0xFF);
                return Err(PowerCut);
            }
            self.data[page..page + PAGE].fill(0xFF);
            self.erases += 1;
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), PowerCut> {
        self.check(offset, bytes.len())?;
        assert!((offset as usize).is_multiple_of(WORD) && bytes.len().is_multiple_of(WORD));
        for (i, w) in bytes.chunks_exact(WORD).enumerate() {
            let o = offset as usize + i * WORD;
            if !self.tick() {
                // Interrupted: only the first half of the word programmed.
                for (d, s) in self.data[o..o + WORD / 2].iter_mut().zip(w) {
                    *d &= *s;
                }
                return Err(PowerCut);
            }
            // NOR: programming only clears bits.
            for (d, s) in self.data[o..o + WORD].iter_mut().zip(w) {
                *d &= *s;
            }
        }
        Ok(())
    }
}
