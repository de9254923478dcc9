//! The board's own start-up and background diagnostics: the hardware side
//! of `monitor::device::diagnostics` (which holds the logic, tested on the
//! host). Here: the RAM test before the statics are initialised, the
//! program image's checksum against the seal written by
//! `scripts/seal-image.py`, the background re-check of the image, and the
//! board's [`SelfTest`] for the supervisor: that re-check, VREFINT
//! (`vrefint.rs`), the LSI against the sample clock (`lsi.rs`) and the
//! clock security system's verdict (`system::clock_failed`).
//!
//! The installation parameters are compiled into the image, so the image
//! checksum covers them too.

use core::ptr;

use firmware::board::SelfTest;

use super::lsi::LsiMeter;
use super::vrefint::Vrefint;
use monitor::device::diagnostics::flash::{FlashScan, ScanStep, FLASH_CRC};
use monitor::device::diagnostics::ram::{march_c_minus, WordMemory};
use monitor::device::diagnostics::{DeviceFault, DeviceFaults};

/// Where the RAM test leaves its verdict: the first words of the 64 KiB
/// CCM RAM, which nothing else uses and the runtime does not initialise.
const RAM_RESULT: *mut u32 = 0x1000_0000 as *mut u32;
const RAM_PASSED: u32 = 0x5241_4D2B; // "RAM+"
const RAM_FAILED: u32 = 0x5241_4D2D; // "RAM-"

/// RAM as raw words, accessed volatile (no reference to the statics is
/// ever formed while they are tested).
struct RawRam {
    start: *mut u32,
    words: usize,
}

impl WordMemory for RawRam {
    fn words(&self) -> usize {
        self.words
    }
    fn read(&self, i: usize) -> u32 {
        // SAFETY: i < words, inside the tested region.
        unsafe { ptr::read_volatile(self.start.add(i)) }
    }
    fn write(&mut self, i: usize, v: u32) {
        // SAFETY: as above.
        unsafe { ptr::write_volatile(self.start.add(i), v) }
    }
}

extern "C" {
    static mut __sdata: u32;
    static mut __euninit: u32;
    static __sidata: u32;
    static __edata: u32;
}

// cortex-m-rt's reset handler calls `__pre_init` before it initialises
// RAM; a tail branch keeps the return address to the reset handler in LR.
core::arch::global_asm!(
    ".section .text.__pre_init,\"ax\"",
    ".global __pre_init",
    ".type __pre_init,%function",
    ".thumb_func",
    "__pre_init:",
    "b {test}",
    test = sym ram_test_before_init,
);

/// March C− over every static (`.data`, `.bss`, `.uninit`) before the
/// runtime initialises them. Stack-only code: it reads no static and the
/// stack lies below the statics (flip-link), outside the tested region.
unsafe extern "C" fn ram_test_before_init() {
    let start = ptr::addr_of_mut!(__sdata);
    let end = ptr::addr_of_mut!(__euninit);
    let mut ram = RawRam {
        start,
        words: (end as usize - start as usize) / 4,
    };
    match march_c_minus(&mut ram) {
        Ok(()) => {
            ptr::write_volatile(RAM_RESULT, RAM_PASSED);
            ptr::write_volatile(RAM_RESULT.add(1), 0);
        }
        Err(fault) => {
            ptr::write_volatile(RAM_RESULT, RAM_FAILED);
            ptr::write_volatile(RAM_RESULT.add(1), start.add(fault.word) as u32);
        }
    }
}

/// The RAM test's verdict: `Err(address)` of the first failing word
/// (`Err(0)` when the test did not run).
pub fn ram_test_result() -> Result<(), u32> {
    // SAFETY: CCM RAM is always mapped and clocked after reset.
    match unsafe { ptr::read_volatile(RAM_RESULT) } {
        RAM_PASSED => Ok(()),
        RAM_FAILED => Err(unsafe { ptr::read_volatile(RAM_RESULT.add(1)) }),
        _ => Err(0),
    }
}

/// The image seal: `scripts/seal-image.py` writes the CRC-32 of the whole
/// flash image (this word counted as [`UNSEALED`]) into `crc` after
/// linking. The magic lets the script find it.
#[repr(C)]
pub struct ImageSeal {
    magic: [u32; 2],
    crc: u32,
}

/// The seal's value in an image that was not sealed.
pub const UNSEALED: u32 = 0xFFFF_FFFF;

#[used]
#[no_mangle]
static IMAGE_SEAL: ImageSeal = ImageSeal {
    magic: [0x4C4D_5345, 0x414C_2121], // "ESML", "!!LA": found by the sealer
    crc: UNSEALED,
};

/// Flash origin (the vector table).
const FLASH_ORIGIN: usize = 0x0800_0000;

/// The image in flash: from the vector table to the end of `.data`'s
/// load image.
fn image_len() -> usize {
    // Linker symbols: only their addresses are used.
    let (sidata, sdata, edata) = (
        ptr::addr_of!(__sidata) as usize,
        ptr::addr_of!(__sdata) as usize,
        ptr::addr_of!(__edata) as usize,
    );
    sidata + (edata - sdata) - FLASH_ORIGIN
}

/// The seal word as stored (volatile: the compiler would fold the
/// constant it was built with).
fn seal() -> u32 {
    unsafe { ptr::read_volatile(ptr::addr_of!(IMAGE_SEAL.crc)) }
}

/// Read `buf.len()` image bytes from `offset`, with the seal word read as
/// [`UNSEALED`] (the checksum cannot cover itself).
fn read_image(offset: usize, buf: &mut [u8]) {
    let seal_at = ptr::addr_of!(IMAGE_SEAL.crc) as usize - FLASH_ORIGIN;
    for (k, b) in buf.iter_mut().enumerate() {
        let at = offset + k;
        // SAFETY: inside the flash image (callers stay below image_len()).
        *b = if (seal_at..seal_at + 4).contains(&at) {
            0xFF
        } else {
            unsafe { ptr::read_volatile((FLASH_ORIGIN + at) as *const u8) }
        };
    }
}

/// The background image check, a chunk per call.
pub struct ImageCheck {
    scan: FlashScan,
}

impl ImageCheck {
    /// Bytes checked per call: 1 KiB every 10 ms re-checks a 110 KiB image
    /// in about 1.1 s, at ~30 µs of CPU per call.
    pub const CHUNK: usize = 1024;

    /// The start-up check over the whole image; returns the background
    /// check, and whether the image is sealed at all (an unsealed
    /// development image is re-checked against its boot-time checksum).
    fn start(faults: &mut DeviceFaults) -> (Self, bool) {
        let len = image_len();
        let mut digest = FLASH_CRC.digest();
        let mut buf = [0u8; 256];
        let mut offset = 0;
        while offset < len {
            let n = buf.len().min(len - offset);
            read_image(offset, &mut buf[..n]);
            digest.update(&buf[..n]);
            offset += n;
        }
        let at_boot = digest.finalize();
        let sealed = seal() != UNSEALED;
        if sealed && at_boot != seal() {
            faults.raise(DeviceFault::FlashImage);
        }
        let expected = if sealed { seal() } else { at_boot };
        (
            Self {
                scan: FlashScan::new(expected, len),
            },
            sealed,
        )
    }
}

impl ImageCheck {
    /// One background step: the next chunk of the image.
    fn step(&mut self) -> Option<DeviceFault> {
        let (offset, n) = self.scan.next_chunk(Self::CHUNK);
        let mut buf = [0u8; Self::CHUNK];
        read_image(offset, &mut buf[..n]);
        match self.scan.feed(&buf[..n]) {
            ScanStep::Mismatch { .. } => Some(DeviceFault::FlashImage),
            ScanStep::InProgress | ScanStep::PassOk => None,
        }
    }
}

/// The board's self-test and diagnostic readings, for the supervisor.
pub struct BoardSelfTest {
    image: ImageCheck,
    vrefint: Vrefint,
    lsi: LsiMeter,
}

impl BoardSelfTest {
    /// The image's background check, ADC1's injected group (VREFINT) and
    /// TIM5 (the LSI), all set up.
    pub fn new(image: ImageCheck, vrefint: Vrefint, lsi: LsiMeter) -> Self {
        Self {
            image,
            vrefint,
            lsi,
        }
    }
}

impl SelfTest for BoardSelfTest {
    fn step(&mut self) -> Option<DeviceFault> {
        self.image.step()
    }

    fn vrefint_code(&mut self) -> u16 {
        self.vrefint.convert()
    }

    fn lsi_cycles_per_window(&mut self) -> Option<u32> {
        self.lsi.measure()
    }

    fn clock_failed(&self) -> bool {
        super::system::clock_failed()
    }
}

/// The start-up diagnostics (the RAM test's verdict, the image check);
/// returns the image's background check.
pub fn start_up(faults: &mut DeviceFaults) -> ImageCheck {
    if let Err(address) = ram_test_result() {
        defmt::error!("RAM test failed at {=u32:#010x}", address);
        faults.raise(DeviceFault::Ram);
    }
    let (check, sealed) = ImageCheck::start(faults);
    if !sealed {
        defmt::warn!(
            "image not sealed (scripts/seal-image.py): checked against its boot checksum only"
        );
    }
    if faults.contains(DeviceFault::FlashImage) {
        defmt::error!("program image checksum does not match its seal");
    }
    check
}
