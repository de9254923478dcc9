//! The emulated board's flash for the commissioning link's storage
//! (`link::storage`): a NOR flash in RAM with the STM32F405's rules.
//! QEMU's netduinoplus2 models the flash as ROM without its controller,
//! so the firmware's embassy-stm32 flash driver cannot run there.
//!
//! As on the STM32F405: reads of any size, programming in 32-bit words
//! (the parallelism at 2.7–3.6 V) that can only clear bits, erasing whole
//! sectors back to 0xFF. The board's storage sectors are the 16 KiB ones
//! (sectors 1–3); `PAGE` is the erase size. Arguments out of range or off
//! the word or sector grid are errors, as the embedded-storage contract
//! asks (the STM32 driver reports them too).
//!
//! Not `MultiwriteNorFlash`: `link::storage` does not need to program a
//! word twice, and the board's flash driver does not promise it either.
// Each test binary uses a part of the emulated board.
#![allow(dead_code)]

use embedded_storage_async::nor_flash::{ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash};

/// Bytes per program operation.
pub const WORD: usize = 4;
/// The STM32F405's small sectors, bytes.
pub const SECTOR_16K: usize = 16 * 1024;

/// A NOR flash over `mem`, erased in pages of `PAGE` bytes.
pub struct RamNorFlash<const PAGE: usize = SECTOR_16K> {
    mem: &'static mut [u8],
}

impl<const PAGE: usize> RamNorFlash<PAGE> {
    const GRID: () = assert!(PAGE > 0 && PAGE.is_multiple_of(WORD));

    /// A flash holding what `mem` holds (as a flash keeps its contents
    /// over a reset).
    ///
    /// # Panics
    /// When `mem` is not a whole number of pages.
    pub fn new(mem: &'static mut [u8]) -> Self {
        let () = Self::GRID;
        assert!(
            mem.len().is_multiple_of(PAGE),
            "flash of {} bytes is not a whole number of {PAGE}-byte pages",
            mem.len()
        );
        Self { mem }
    }

    /// A flash over `mem`, erased.
    ///
    /// # Panics
    /// As [`Self::new`].
    pub fn erased(mem: &'static mut [u8]) -> Self {
        let flash = Self::new(mem);
        flash.mem.fill(0xFF);
        flash
    }

    /// Its contents.
    pub fn as_bytes(&self) -> &[u8] {
        self.mem
    }

    /// The range `offset..offset + len` of the memory, if in bounds and
    /// aligned to `align` bytes.
    fn range(
        &self,
        offset: u32,
        len: usize,
        align: usize,
    ) -> Result<core::ops::Range<usize>, NorFlashErrorKind> {
        let start = offset as usize;
        let end = start
            .checked_add(len)
            .filter(|&e| e <= self.mem.len())
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(NorFlashErrorKind::NotAligned);
        }
        Ok(start..end)
    }
}

impl<const PAGE: usize> ErrorType for RamNorFlash<PAGE> {
    type Error = NorFlashErrorKind;
}

impl<const PAGE: usize> ReadNorFlash for RamNorFlash<PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let r = self.range(offset, bytes.len(), Self::READ_SIZE)?;
        bytes.copy_from_slice(&self.mem[r]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const PAGE: usize> NorFlash for RamNorFlash<PAGE> {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let len = (to as usize)
            .checked_sub(from as usize)
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        let r = self.range(from, len, PAGE)?;
        self.mem[r].fill(0xFF);
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let r = self.range(offset, bytes.len(), WORD)?;
        // NOR: programming only clears bits.
        for (d, s) in self.mem[r].iter_mut().zip(bytes) {
            *d &= *s;
        }
        Ok(())
    }
}
