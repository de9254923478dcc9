//! The emulated board's commissioning link: a USART of QEMU's
//! netduinoplus2 as `firmware::board::SerialPort` (the STM32 board uses
//! USB CDC-ACM instead). QEMU connects its first `-serial` to USART1.
//!
//! QEMU's STM32F2xx USART model (`hw/char/stm32f2xx_usart.c`, the one
//! the STM32F405 machine uses) implements SR, DR, BRR, CR1–CR3 and GTPR
//! as plain registers. What matters here:
//!
//! - there is no baud rate and no clock gating (the RCC is an
//!   unimplemented-device region in QEMU's STM32F405): CR1's UE, TE and RE
//!   are all it needs. Bytes arriving while UE or RE is clear are dropped;
//! - it holds one received byte in DR and accepts the next from its
//!   character device only after DR was read: the host's bytes wait in
//!   QEMU (and the socket) instead of overrunning. RXNE raises the
//!   interrupt when RXNEIE is set;
//! - transmission is synchronous (a write to DR blocks QEMU until the
//!   character device took the byte). TC is set after every write; TXE
//!   is set permanently by current models but cleared by a DR write in
//!   older ones, which never set it again. The driver waits for TXE or TC
//!   (on real hardware TC implies TXE, so this is the same wait);
//! - the interrupt line follows SR ∧ CR1 for TXE, TC and RXNE in current
//!   models, but in older ones it stays raised after RXNEIE is cleared
//!   until DR is read. So the receiver applies back-pressure by masking
//!   the interrupt in the NVIC, never by clearing RXNEIE, and TXEIE and
//!   TCIE stay clear (TC, and TXE in current models, stay set: an
//!   interrupt storm).
//!
//! Reception: the interrupt handler ([`Usart::on_interrupt`], called from
//! the vector table for [`Usart::irq`]) moves the byte into a ring buffer
//! (an embassy-sync `Pipe`), which `SerialPort::read` awaits. When the
//! ring is full the handler leaves the byte in DR and masks its interrupt;
//! the reader unmasks it after taking bytes, so nothing is ever lost.
//! Transmission polls the status register.
// Each test binary uses a part of the emulated board.
#![allow(dead_code)]

use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use firmware::board::{Disconnected, SerialPort};

/// Receive ring buffer, bytes: two whole frames of the commissioning
/// link, so a reader that was busy sending a sample block loses no
/// command (and the host's bytes wait in QEMU beyond that anyway).
pub const RX_LEN: usize = 2 * link::frame::MAX_WIRE;

/// Status register polls before a transmission counts as stuck: QEMU's
/// model sends each byte at once, so this only ends a wait on a model
/// that never reports the data register empty.
const TX_POLLS: u32 = 100_000;

/// Register offsets, bytes (RM0090 30.6).
const SR: usize = 0x00;
const DR: usize = 0x04;
const CR1: usize = 0x0C;
/// SR: transmit data register empty, transmission complete, received
/// data register not empty.
const SR_TXE: u32 = 1 << 7;
const SR_TC: u32 = 1 << 6;
const SR_RXNE: u32 = 1 << 5;
/// CR1: USART enable, RXNE interrupt enable, transmitter and receiver
/// enable.
const CR1_UE: u32 = 1 << 13;
const CR1_RXNEIE: u32 = 1 << 5;
const CR1_TE: u32 = 1 << 3;
const CR1_RE: u32 = 1 << 2;

/// A USART's interrupt number (its position in the STM32F405's vector
/// table after the 16 exceptions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Irq(u16);

// SAFETY: only constructed for the STM32F405's USART interrupts below
// (all under its 82 vectors).
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self.0
    }
}

/// One USART: its registers, its interrupt and its receive ring.
pub struct Usart {
    base: usize,
    irq: Irq,
    rx: Pipe<CriticalSectionRawMutex, RX_LEN>,
    taken: AtomicBool,
}

/// USART1, QEMU's first `-serial` (`serial_hd(0)`): registers at
/// 0x4001_1000, interrupt 37.
pub static USART1: Usart = Usart::new(0x4001_1000, 37);

impl Usart {
    const fn new(base: usize, irq: u16) -> Self {
        Self {
            base,
            irq: Irq(irq),
            rx: Pipe::new(),
            taken: AtomicBool::new(false),
        }
    }

    /// Its interrupt, for the vector table (`DefaultHandler`'s `irqn`).
    pub fn irq(&self) -> Irq {
        self.irq
    }

    fn read(&self, offset: usize) -> u32 {
        // SAFETY: a register of this USART (a valid MMIO address on the
        // STM32F405 and in QEMU's model).
        unsafe { read_volatile((self.base + offset) as *const u32) }
    }

    fn write(&self, offset: usize, value: u32) {
        // SAFETY: as in `read`.
        unsafe { write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// Enable the receiver and transmitter and the receive interrupt at
    /// `priority` (upper 4 bits, as `NVIC::set_priority` takes it), and
    /// hand out the port. The vector table must call
    /// [`Self::on_interrupt`] for [`Self::irq`] from now on.
    ///
    /// # Panics
    /// When taken a second time.
    pub fn take(&'static self, nvic: &mut NVIC, priority: u8) -> UartPort {
        assert!(
            !self.taken.swap(true, Ordering::AcqRel),
            "USART taken twice"
        );
        // 8N1 (CR2, CR3 at reset); no BRR: QEMU's model has no baud rate
        // (a real STM32 would need one here).
        self.write(CR1, CR1_UE | CR1_TE | CR1_RE | CR1_RXNEIE);
        // SAFETY: the handler only touches this USART and its ring, which
        // is ready; no critical section relies on this interrupt masked.
        unsafe {
            nvic.set_priority(self.irq, priority);
            NVIC::unmask(self.irq);
        }
        UartPort { usart: self }
    }

    /// The interrupt handler: move the received byte into the ring, or,
    /// when the ring is full, leave it in DR (QEMU then holds back the
    /// rest) and mask the interrupt until the reader made room.
    pub fn on_interrupt(&self) {
        if self.read(SR) & SR_RXNE == 0 {
            return;
        }
        // The handler is the ring's only writer: room now stays room.
        if self.rx.free_capacity() == 0 {
            NVIC::mask(self.irq);
            return;
        }
        let byte = self.read(DR) as u8;
        let _ = self.rx.try_write(&[byte]);
    }
}

/// The USART as the firmware's serial port.
pub struct UartPort {
    usart: &'static Usart,
}

impl SerialPort for UartPort {
    /// A UART has no connection state: at once.
    async fn wait_connected(&mut self) {}

    /// Cancel-safe: bytes leave the ring only when this returns them.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Disconnected> {
        if buf.is_empty() {
            return Ok(0);
        }
        let n = self.usart.rx.read(buf).await;
        // There is room now: let a byte held back in DR in.
        // SAFETY: masking is only back-pressure, no critical section.
        unsafe { NVIC::unmask(self.usart.irq) };
        Ok(n)
    }

    /// Polls the status register; QEMU sends each byte at once (blocking
    /// the emulation while the host's end is full), so this does not
    /// yield. `Err(Disconnected)` when the transmitter never gets ready.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Disconnected> {
        for &b in bytes {
            let mut polls = 0;
            while self.usart.read(SR) & (SR_TXE | SR_TC) == 0 {
                polls += 1;
                if polls == TX_POLLS {
                    return Err(Disconnected);
                }
            }
            self.usart.write(DR, u32::from(b));
        }
        Ok(())
    }
}
