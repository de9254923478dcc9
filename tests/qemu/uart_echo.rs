//! The emulated board's USART driver (`emu/uart.rs`) against a host:
//! every byte received on USART1 is sent back, through
//! `firmware::board::SerialPort` as the firmware's link task uses it.
//!
//! Not run by `cargo qemu-test` (it needs a peer on QEMU's serial port):
//! `scripts/qemu-serial-smoke.sh` builds it, starts it with USART1 on a
//! TCP socket, and checks the echo.
//!
//! The protocol with the script: the board sends [`READY`] once its
//! receiver is on (QEMU drops bytes that arrive before), then echoes
//! everything. Every [`BUSY_EVERY`] reads it stays busy for
//! [`BUSY_CYCLES`], so a host sending more than the receive ring holds
//! makes the driver hold bytes back (its interrupt masked); those must
//! still come back in order. [`QUIT`] (not echoed) ends the run: the board reports over
//! semihosting and QEMU exits with status 0.
#![no_std]
#![no_main]

// The firmware's crates log with defmt: the emulated board's logger.
#[path = "emu/logger.rs"]
mod logger;
#[path = "emu/uart.rs"]
mod uart;

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::exception;
use embassy_executor::InterruptExecutor;
use firmware::board::SerialPort;
use qemu_tests::{exit, println};
use uart::{UartPort, USART1};

/// Sent once the receiver is on.
const READY: &[u8] = b"uart_echo ready\n";
/// Ends the run (ASCII EOT); the host leaves it out of its data.
const QUIT: u8 = 0x04;
/// Busy time, cycles (= ns of QEMU's virtual time at `-icount
/// shift=0`): QEMU hands the guest about one byte per pass of its main
/// loop, and this is long enough for the host's bytes to fill the ring
/// (tried: 0.2 ms never does). About 0.3 s on the host.
const BUSY_CYCLES: u32 = 50_000_000;
/// Reads (of up to 64 bytes) between busy times.
const BUSY_EVERY: u32 = 32;

static EXECUTOR: InterruptExecutor = InterruptExecutor::new();

/// The executor's vector: UART5's, as the emulated board's tasks
/// (QEMU connects no serial port to UART5 here).
#[derive(Clone, Copy)]
struct Tasks;

// SAFETY: UART5's interrupt, 53, is a valid STM32F405 interrupt.
unsafe impl InterruptNumber for Tasks {
    fn number(self) -> u16 {
        53
    }
}

/// Without a device crate every interrupt arrives here.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    match irqn {
        n if n == USART1.irq().number() as i16 => USART1.on_interrupt(),
        // SAFETY: the executor's own interrupt, started before unmasked.
        53 => unsafe { EXECUTOR.on_interrupt() },
        n => panic!("unexpected interrupt {n}"),
    }
}

#[embassy_executor::task]
async fn echo(mut port: UartPort) {
    port.wait_connected().await;
    if port.write_all(READY).await.is_err() {
        println!("FAILED: uart_echo: cannot send");
        exit(false);
    }
    let mut buf = [0u8; 64];
    let (mut echoed, mut held_back, mut reads) = (0u32, 0u32, 0u32);
    loop {
        let n = match port.read(&mut buf).await {
            Ok(n) => n,
            Err(_) => {
                println!("FAILED: uart_echo: the port went away");
                exit(false);
            }
        };
        let (data, quit) = match buf[..n].iter().position(|&b| b == QUIT) {
            Some(i) => (&buf[..i], true),
            None => (&buf[..n], false),
        };
        if port.write_all(data).await.is_err() {
            println!("FAILED: uart_echo: cannot send");
            exit(false);
        }
        echoed += data.len() as u32;
        if quit {
            println!(
                "uart_echo: {echoed} bytes echoed, receiver held back {held_back} times, {} defmt records",
                logger::records()
            );
            exit(true);
        }
        if reads % BUSY_EVERY == 0 {
            cortex_m::asm::delay(BUSY_CYCLES);
            // The ring filled while busy: the handler masked its interrupt.
            if !NVIC::is_enabled(USART1.irq()) {
                held_back += 1;
            }
        }
        reads += 1;
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut core = cortex_m::Peripherals::take().expect("core peripherals");
    // The USART above the tasks, as a receive interrupt must be.
    let port = USART1.take(&mut core.NVIC, 1 << 4);
    // SAFETY: set before the executor starts, as it requires.
    unsafe { core.NVIC.set_priority(Tasks, 15 << 4) };
    let spawner = EXECUTOR.start(Tasks);
    spawner.spawn(echo(port).expect("echo task"));
    loop {
        cortex_m::asm::wfi();
    }
}
