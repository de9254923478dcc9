//! Leak monitor firmware for the STM32F405RG (168 MHz Cortex-M4F).
//!
//! Two executors: the estimator runs in an interrupt executor at a higher
//! priority than everything else the application does, so CAN, logging
//! and the supervisor can never delay it; CAN, the supervisor and the log
//! run in the thread-mode executor. See `firmware/src/lib.rs` for the
//! tasks and the `boards` crate (`boards/src/h405.rs`) for the wiring.
#![no_std]
#![no_main]

mod stm32;

use defmt::unwrap;
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, Spawner};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{CAN1, PB8, PB9};
use embassy_stm32::Peri;
use firmware::app;
use firmware::app::shared::Shared;
use firmware::board::BootInfo;
use firmware::board_map::FRONTEND;
use monitor::device::diagnostics::brownout;
use monitor::device::diagnostics::{DeviceFault, DeviceFaults};
use monitor::device::Estimator;
use monitor::protocol::IdentityFrame;
use static_cell::StaticCell;
use stm32::adc::AdcSampler;
use stm32::can::{Receiver, Transmitter};
use stm32::diagnostics::BoardSelfTest;
use stm32::lsi::LsiMeter;
use stm32::pins::{self, Board};
use stm32::relay::Relay;
use stm32::system::{Dwt, Iwdg, Led};

/// The installation's parameters, compiled in by `build.rs` from the TOML
/// file named by `LEAK_MONITOR_PARAMS` (or the reference rig's).
mod installation {
    #![allow(clippy::all)]
    use monitor::params::*;
    include!(concat!(env!("OUT_DIR"), "/installation.rs"));
}

static SHARED: Shared = Shared::new();
static RELAY: StaticCell<Relay> = StaticCell::new();
static ESTIMATOR: StaticCell<Estimator<f32>> = StaticCell::new();
static EXECUTOR_HIGH: InterruptExecutor = InterruptExecutor::new();
static EXECUTOR_LOW: StaticCell<Executor> = StaticCell::new();

/// Priority of the estimator's executor: above the thread-mode tasks,
/// below the DMA and CAN interrupt handlers (priority 0), which are short.
const ESTIMATOR_PRIORITY: Priority = Priority::P6;

/// A spare interrupt vector that runs the estimator's executor.
#[interrupt]
unsafe fn UART4() {
    unsafe { EXECUTOR_HIGH.on_interrupt() }
}

firmware::app_tasks! {
    shared: SHARED,
    sample_source: AdcSampler,
    relay: Relay,
    cycle_counter: Dwt,
    watchdog: Iwdg,
    led: Led,
    self_test: BoardSelfTest,
    can_tx: Transmitter,
    can_rx: Receiver,
}

/// Bring CAN up (waits for an idle bus) without holding anything else up.
#[embassy_executor::task]
async fn can_start(
    spawner: Spawner,
    can: Peri<'static, CAN1>,
    rx: Peri<'static, PB8>,
    tx: Peri<'static, PB9>,
    seed: u64,
) {
    let node = installation::INSTALLATION.node();
    let (tx, rx) = stm32::can::start(can, rx, tx, node).await;
    defmt::info!(
        "CAN: on the bus at {} bit/s as node {}",
        monitor::protocol::BITRATE_BPS,
        node.number()
    );
    spawner.spawn(unwrap!(can_tx(tx, node)));
    spawner.spawn(unwrap!(can_rx(rx, node, seed)));
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let low = EXECUTOR_LOW.init(Executor::new());
    // `start` runs once, inside `run`, and returns: its stack frame (the
    // set-up) is gone before the tasks run.
    low.run(start)
}

/// Bring the board up and spawn the tasks.
#[inline(never)]
fn start(spawner: Spawner) {
    let boot = BootInfo {
        reset_cause: stm32::system::take_reset_cause(),
        identity: IdentityFrame {
            node: installation::INSTALLATION.node(),
            params_crc: installation::INSTALLATION_CRC,
            params_version: 0,
        },
        version: firmware::version::FRAME,
    };
    let p = embassy_stm32::init(stm32::clocks::config());
    let Board {
        adc,
        adc_dma,
        adc_trigger,
        inputs,
        relay,
        relay_readback,
        led,
        can,
        can_rx,
        can_tx,
        iwdg,
        rng,
        lsi_timer,
    } = pins::split(p);
    // First of all: the relay output, de-energised.
    let relay: &'static Relay = RELAY.init(Relay::new(relay, relay_readback));
    defmt::info!(
        "leak monitor {} on STM32F405, last reset: {}",
        env!("CARGO_PKG_VERSION"),
        boot.reset_cause
    );
    let mut device_faults = DeviceFaults::NONE;
    stm32::system::enable_clock_security();
    let bor = stm32::system::ensure_brownout_level();
    defmt::info!("brown-out reset level: {}", bor);
    if bor < brownout::REQUIRED {
        device_faults.raise(DeviceFault::BrownOut);
    }
    let image = stm32::diagnostics::start_up(&mut device_faults);
    for f in DeviceFault::ALL {
        if device_faults.contains(f) {
            // The estimator shows it from its first block: relay off.
            SHARED.raise_device_fault(f);
        }
    }
    defmt::info!(
        "installation parameters: {} (identity {=u32:#010x}, version 0)",
        installation::INSTALLATION_SOURCE,
        installation::INSTALLATION_CRC
    );
    let pipeline = match app::estimator::pipeline::<Dwt>(&installation::INSTALLATION, FRONTEND) {
        Ok(e) => ESTIMATOR.init(e),
        // Validated at build time (build.rs); kept as a last line of defence.
        Err(e) => defmt::panic!("invalid built-in parameters: {}", e.field),
    };
    let core = unwrap!(cortex_m::Peripherals::take());
    let cycles = Dwt::new(core.DCB, core.DWT);
    let (source, vrefint) = AdcSampler::new(adc, adc_dma, adc_trigger, inputs);
    let watchdog = Iwdg::start(iwdg);
    let lsi = LsiMeter::new(lsi_timer, source.sample_period_ticks());
    let self_test = BoardSelfTest::new(image, vrefint, lsi);
    // After the watchdog: a RNG that never becomes ready resets the board
    // (relay off) instead of hanging it silently.
    let seed = stm32::system::challenge_seed(rng);

    interrupt::UART4.set_priority(ESTIMATOR_PRIORITY);
    let high = EXECUTOR_HIGH.start(interrupt::UART4);
    high.spawn(unwrap!(estimator(source, relay, cycles, pipeline, boot)));

    spawner.spawn(unwrap!(supervisor(
        watchdog,
        relay,
        Led::new(led),
        self_test
    )));
    spawner.spawn(unwrap!(can_start(spawner, can, can_rx, can_tx, seed)));
}
