//! Leak monitor firmware for the STM32F405RG (168 MHz Cortex-M4F).
//!
//! Two executors: the estimator runs in an interrupt executor at a higher
//! priority than everything else the application does, so CAN, logging,
//! the supervisor and the commissioning link can never delay it; CAN, the
//! supervisor, the log, the commissioning link (USB CDC-ACM) and the USB
//! device run in the thread-mode executor. See `firmware/src/lib.rs` for the
//! tasks and the `boards` crate (`boards/src/h405.rs`) for the wiring.
#![no_std]
#![no_main]

mod stm32;

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Waker};

use defmt::unwrap;
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, Spawner};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{CAN1, FLASH, PB8, PB9};
use embassy_stm32::Peri;
use firmware::app;
use firmware::app::shared::Shared;
use firmware::board::BootInfo;
use firmware::board_map::FRONTEND;
use monitor::device::diagnostics::brownout;
use monitor::device::diagnostics::{DeviceFault, DeviceFaults};
use monitor::device::Estimator;
use monitor::params::{ParamError, Params};
use monitor::protocol::{IdentityFrame, Node, ResetCause};
use static_cell::StaticCell;
use stm32::adc::AdcSampler;
use stm32::can::{Receiver, Transmitter};
use stm32::diagnostics::BoardSelfTest;
use stm32::flash::StoragePartition;
use stm32::lsi::LsiMeter;
use stm32::pins::{self, Board};
use stm32::relay::Relay;
use stm32::system::{Dwt, Iwdg, Led};
use stm32::usb::UsbSerial;

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
/// The commissioning link's device end on the board's flash.
type LinkDevice = link::Device<StoragePartition, StoragePartition>;
static DEVICE: StaticCell<LinkDevice> = StaticCell::new();

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

firmware::app_link_task! {
    shared: SHARED,
    serial: UsbSerial,
    params_flash: StoragePartition,
    events_flash: StoragePartition,
}

/// Bring CAN up (waits for an idle bus) without holding anything else up.
#[embassy_executor::task]
async fn can_start(
    spawner: Spawner,
    can: Peri<'static, CAN1>,
    rx: Peri<'static, PB8>,
    tx: Peri<'static, PB9>,
    node: Node,
    seed: u64,
) {
    let (tx, rx) = stm32::can::start(can, rx, tx, node).await;
    defmt::info!(
        "CAN: on the bus at {} bit/s as node {}",
        monitor::protocol::BITRATE_BPS,
        node.number()
    );
    spawner.spawn(unwrap!(can_tx(tx, node)));
    spawner.spawn(unwrap!(can_rx(rx, node, seed)));
}

/// The reset cause as the event memory records it (it has no
/// low-power-reset kind; both watchdogs are one kind there).
fn link_reset_cause(cause: ResetCause) -> link::ResetCause {
    match cause {
        ResetCause::PowerOn => link::ResetCause::PowerOn,
        ResetCause::Pin => link::ResetCause::Pin,
        ResetCause::Watchdog | ResetCause::WindowWatchdog => link::ResetCause::Watchdog,
        ResetCause::Software => link::ResetCause::Software,
        ResetCause::BrownOut => link::ResetCause::BrownOut,
        ResetCause::LowPower | ResetCause::Unknown => link::ResetCause::Unknown,
    }
}

/// The commissioning link's device end, started (see `start`), in its
/// static. Not inlined: the start's future and the device are kilobytes,
/// and this frame is gone before the tasks run.
#[inline(never)]
fn start_link(
    flash: Peri<'static, FLASH>,
    serial: &str,
    reset_cause: ResetCause,
) -> &'static mut LinkDevice {
    let (params_flash, events_flash) = stm32::flash::partitions(flash);
    let mut info_serial = heapless::String::new();
    // 24 hex digits, the String's capacity.
    let _ = info_serial.push_str(serial);
    let info = link::DeviceInfo {
        firmware: env!("CARGO_PKG_VERSION"),
        serial: info_serial,
        period_us: firmware::board_map::SAMPLE_PERIOD_US,
    };
    // Built in its static, then booted in place: the device (7.7 KiB)
    // passes through no other frame, and the boot future only borrows it.
    let device = DEVICE.init_with(|| {
        link::Device::new(
            link::Storage::new(
                params_flash,
                0..firmware::board_map::flash_layout::PARAMS_SIZE,
                events_flash,
                0..firmware::board_map::flash_layout::EVENTS_SIZE,
            ),
            info,
            &installation::INSTALLATION,
        )
    });
    // Polled here to its end: it never waits for anything but the
    // blocking flash, so no waker is needed.
    {
        let mut boot = pin!(device.boot_up(link_reset_cause(reset_cause)));
        let mut cx = Context::from_waker(Waker::noop());
        while boot.as_mut().poll(&mut cx).is_pending() {}
    }
    device
}

/// The estimator's pipeline on `params`, in its static (once).
#[inline(never)]
fn init_pipeline(params: &Params) -> Result<&'static mut Estimator<f32>, ParamError> {
    app::estimator::pipeline::<Dwt>(params, FRONTEND).map(|e| &mut *ESTIMATOR.init(e))
}

/// The estimator's pipeline on the active set `active`, in its static,
/// and the identity it runs under. Not inlined: the pipeline is built on
/// the stack before it is moved into its static.
#[inline(never)]
fn build_pipeline(
    active: &link::Loaded,
    node: Node,
) -> (&'static mut Estimator<f32>, IdentityFrame) {
    match init_pipeline(&active.params) {
        Ok(e) => (e, app::link::identity_frame(node, active)),
        // A stored set was validated when it was uploaded and again when
        // it was read: this is a last line of defence. Run on the
        // compiled-in set rather than reset for ever; the link stays up,
        // so a good set can be uploaded.
        Err(e) if active.stored => {
            defmt::error!(
                "stored parameters refused by the estimator ({}): running on the compiled-in set",
                e.field
            );
            match init_pipeline(&installation::INSTALLATION) {
                Ok(e) => (
                    e,
                    IdentityFrame {
                        node,
                        params_crc: installation::INSTALLATION_CRC,
                        params_version: 0,
                    },
                ),
                Err(e) => defmt::panic!("invalid built-in parameters: {}", e.field),
            }
        }
        // Validated at build time (build.rs); kept as a last line of defence.
        Err(e) => defmt::panic!("invalid built-in parameters: {}", e.field),
    }
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
    let reset_cause = stm32::system::take_reset_cause();
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
        usb,
        usb_dm,
        usb_dp,
        flash,
    } = pins::split(p);
    // First of all: the relay output, de-energised.
    let relay: &'static Relay = RELAY.init(Relay::new(relay, relay_readback));
    defmt::info!(
        "leak monitor {} on STM32F405, last reset: {}",
        env!("CARGO_PKG_VERSION"),
        reset_cause
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
    // The commissioning link's device end: the active parameter set (the
    // stored one, else the compiled-in default), this boot's number and
    // its reset record in the event memory. It may erase a flash sector
    // (1–2 s, the core stalled): at boot that is out of service (relay
    // off, nothing sampled yet) and before the watchdog starts.
    let serial = embassy_stm32::uid::uid_hex();
    let device = start_link(flash, serial, reset_cause);
    let active = device.params();
    // CAN runs on the active set's node (a new node number in an upload
    // takes effect at the next reset).
    let node = active.params.node();
    if active.stored {
        defmt::info!(
            "parameters: stored set (identity {=u32:#010x}, version {=u32}), boot {=u32}",
            active.id.crc,
            active.id.version,
            device.boot()
        );
    } else {
        defmt::info!(
            "parameters: compiled in, {} (identity {=u32:#010x}, version 0), boot {=u32}",
            installation::INSTALLATION_SOURCE,
            active.id.crc,
            device.boot()
        );
    }
    let (pipeline, identity) = build_pipeline(active, node);
    let boot = BootInfo {
        reset_cause,
        identity,
        version: firmware::version::FRAME,
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
    spawner.spawn(unwrap!(can_start(spawner, can, can_rx, can_tx, node, seed)));

    let (usb_device, port) = stm32::usb::start(usb, usb_dm, usb_dp, serial);
    spawner.spawn(unwrap!(stm32::usb::device(usb_device)));
    spawner.spawn(unwrap!(link(port, device, node)));
    defmt::info!("commissioning link: USB CDC-ACM, serial number {}", serial);
}
