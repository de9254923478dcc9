//! The commissioning link on the emulated board: the firmware's link task
//! (`firmware::app::link`) on USART1, which QEMU serves on a TCP socket
//! (`scripts/qemu-link-e2e.sh` drives it with `host-sim`), and the link's
//! storage on RAM flash. Two runs:
//!
//! - [`Link::Record`]: the machine starts when the host starts the
//!   stream, so that `host-sim record` captures the case from its first
//!   sample; every frame is checked as in the other runs, then the
//!   stream: every block sent, none dropped, the host stopped it; then the
//!   host has a few seconds to read the event memory.
//! - [`Link::Upload`]: the case plays in a loop while the host records a
//!   few seconds (past the warm-up) and then uploads a parameter set;
//!   `LM_Identity` must switch once, from the compiled-in set to the
//!   uploaded one, and the monitor must restart on it (the relay drops
//!   for the new warm-up).
// Each test binary uses a part of the emulated board.
#![allow(dead_code)]

use embassy_executor::SendSpawner;
use embassy_futures::block_on;
use embassy_time::{Duration, Instant, Timer};
use firmware::app::link::identity_frame;
use firmware::board::BootInfo;
use golden::params::golden_params;
use link::message::SAMPLES_PER_BLOCK;
use link::{Device, DeviceInfo, Storage};
use monitor::device::Estimator;
use monitor::protocol::{Decoder, IdentityFrame, Message, Node};
use qemu_tests::{exit, println};

use super::board::ReplayAdc;
use super::case::EmuCase;
use super::check::Expect;
use super::flash::RamNorFlash;
use super::uart::{self, UartPort};
use super::{
    check_frames, pipeline, power_on, record, start_executors, start_tasks, Checker, RESET_CAUSE,
    SETTLE, SHARED,
};

/// Erase page of the emulated flash (the STM32F405's 16 KiB sectors do not
/// fit QEMU's 128 KiB of RAM twice over; the storage works the same on
/// any page size).
const PAGE: usize = 4096;
/// Pages of each of the parameter map and the event queue.
const PAGES: usize = 2;
type Flash = RamNorFlash<PAGE>;
/// USART1's interrupt: below the estimator (as the STM32 board's USB
/// interrupt), above the other tasks.
const UART_PRIORITY: u8 = 7 << 4;
/// How long the recording run goes on after the host stopped the stream.
const EVENTS_WINDOW: Duration = Duration::from_secs(3);
/// How long a checker waits for the host, virtual time (about half as
/// long in wall time; the host's commands take a few virtual seconds).
const HOST_TIMEOUT: Duration = Duration::from_secs(60);

firmware::app_link_task! {
    shared: SHARED,
    serial: UartPort,
    params_flash: Flash,
    events_flash: Flash,
}

/// Which link run.
#[derive(Clone, Copy, Debug)]
pub enum Link {
    /// `host-sim record` captures the case.
    Record,
    /// `host-sim params upload` changes the running set.
    Upload,
}

/// Boot the emulated board with the commissioning link and run `case`.
pub fn run(case: &'static EmuCase, run: Link) -> ! {
    let mut nvic = power_on(case);
    let (device, boot) = boot_device(case);
    let node = boot.identity.node;
    let estimator = pipeline(&device.params().params);
    let port = uart::USART1.take(&mut nvic, UART_PRIORITY);
    let (high, low) = start_executors(&mut nvic);
    low.spawn(link(port, device, node).expect("link task"));
    match run {
        Link::Record => {
            low.spawn(starter(case, node, boot, estimator, high, low).expect("starter task"))
        }
        Link::Upload => start_tasks(
            case,
            None,
            node,
            boot,
            estimator,
            ReplayAdc::start_looping(case),
            high,
            low,
            Checker::Upload,
        ),
    }
    super::idle()
}

/// The link's device on a freshly erased flash: boot picks the
/// compiled-in set. Not inlined: the device and its boot future pass
/// through this frame, which is gone before the tasks run on the stack.
#[inline(never)]
fn boot_device(case: &EmuCase) -> (&'static mut Device<Flash, Flash>, BootInfo) {
    let default = golden_params(case.sample_period_s, case.warm_up_s);
    let params_mem = cortex_m::singleton!(: [u8; PAGE * PAGES] = [0xFF; PAGE * PAGES])
        .expect("one parameter flash");
    let events_mem =
        cortex_m::singleton!(: [u8; PAGE * PAGES] = [0xFF; PAGE * PAGES]).expect("one event flash");
    let range = 0..(PAGE * PAGES) as u32;
    let storage = Storage::new(
        Flash::erased(params_mem),
        range.clone(),
        Flash::erased(events_mem),
        range,
    );
    let info = DeviceInfo {
        firmware: env!("CARGO_PKG_VERSION"),
        serial: heapless::String::try_from("EMU-0001").expect("fits"),
        period_us: firmware::app::SAMPLE_PERIOD_US,
    };
    // Boot is out of service: the storage may erase.
    let device = block_on(Device::start(
        storage,
        info,
        &default,
        link::ResetCause::PowerOn,
    ));
    let loaded = device.params();
    let boot = BootInfo {
        reset_cause: RESET_CAUSE,
        identity: identity_frame(loaded.params.node(), loaded),
        version: firmware::version::FRAME,
    };
    println!(
        "emulated board: parameter set version {} crc {:08x} ({})",
        loaded.id.version,
        loaded.id.crc,
        if loaded.stored {
            "stored"
        } else {
            "compiled in"
        }
    );
    let device = cortex_m::singleton!(: Device<Flash, Flash> = device).expect("one device");
    (device, boot)
}

/// The machine starts when the host starts recording, so that the stream
/// holds the case from its first sample.
#[embassy_executor::task]
async fn starter(
    case: &'static EmuCase,
    node: Node,
    boot: BootInfo,
    estimator: &'static mut Estimator<f32>,
    high: SendSpawner,
    low: SendSpawner,
) {
    while !SHARED.stream.is_streaming() {
        Timer::after_millis(1).await;
    }
    let source = ReplayAdc::start(case);
    start_tasks(
        case,
        None,
        node,
        boot,
        estimator,
        source,
        high,
        low,
        Checker::Stream,
    );
}

/// Wait for the end of the replay, check every frame, then the stream.
#[embassy_executor::task]
pub async fn stream_checker(case: &'static EmuCase, t0: Instant, expect: Expect) {
    let period = Duration::from_micros(u64::from(case.sample_period_us));
    Timer::at(t0 + period * (case.samples - 1) + SETTLE).await;
    let frames_ok = check_frames(case, &expect);
    // `host-sim record --duration` stops the stream once it has every
    // sample.
    let deadline = Instant::now() + HOST_TIMEOUT;
    while SHARED.stream.is_streaming() && Instant::now() < deadline {
        Timer::after_millis(10).await;
    }
    let (completed, dropped) = SHARED.stream.progress();
    let blocks = case.samples / SAMPLES_PER_BLOCK as u32;
    let stopped = !SHARED.stream.is_streaming();
    let stream_ok = stopped && completed == blocks && dropped == 0;
    println!(
        "commissioning link: {} of {} blocks streamed, {} dropped; the host {} the stream{}",
        completed,
        blocks,
        dropped,
        if stopped { "stopped" } else { "never stopped" },
        if stream_ok { "" } else { " (FAILED)" }
    );
    // Time for the host to read the event memory (`host-sim events`; the
    // script runs this test with virtual time tied to the host's clock).
    Timer::after(EVENTS_WINDOW).await;
    exit(frames_ok && stream_ok)
}

/// What the identity frames sent so far show.
enum Switch {
    /// No frame with another identity yet.
    Waiting,
    /// The switch and the frames after it: the identity sent after it,
    /// the time of the last frame before it and of the first after it,
    /// and how many frames after it.
    Seen {
        new: IdentityFrame,
        last_old: Instant,
        first_new: Instant,
        after: u32,
    },
    /// Something other than one switch from `before` to one new identity.
    Wrong(&'static str),
}

fn identity_switch(log: &record::Log, before: IdentityFrame) -> Switch {
    let mut decoder = Decoder::for_node(before.node);
    let mut seen: Option<(IdentityFrame, Instant, Instant, u32)> = None;
    let mut last_old = None;
    for sent in &log.frames {
        let Ok(r) = decoder.decode(&sent.frame) else {
            return Switch::Wrong("a frame does not decode");
        };
        let Message::Identity(id) = r.message else {
            continue;
        };
        match &mut seen {
            None if id == before => last_old = Some(sent.at),
            None => {
                let Some(last_old) = last_old else {
                    return Switch::Wrong("the first identity frame is not the compiled-in set");
                };
                seen = Some((id, last_old, sent.at, 1));
            }
            Some((new, _, _, after)) if id == *new => *after += 1,
            Some(_) => return Switch::Wrong("the identity changed more than once"),
        }
    }
    match seen {
        None => Switch::Waiting,
        Some((new, last_old, first_new, after)) => Switch::Seen {
            new,
            last_old,
            first_new,
            after,
        },
    }
}

/// Wait for the uploaded set's identity on CAN and check the switch.
#[embassy_executor::task]
pub async fn upload_checker(before: IdentityFrame) {
    let deadline = Instant::now() + HOST_TIMEOUT;
    let outcome = loop {
        match record::with(|log| identity_switch(log, before)) {
            // Three frames (3 s) of the new identity and nothing else.
            Switch::Seen { after, .. } if after < 3 => {}
            Switch::Waiting => {}
            done => break done,
        }
        if Instant::now() > deadline {
            break Switch::Wrong("no new identity on CAN before the timeout");
        }
        Timer::after_millis(50).await;
    };
    let passed = match outcome {
        Switch::Seen {
            new,
            last_old,
            first_new,
            after,
        } => {
            // The monitor restarted on the set: the relay, energised on
            // the old set (the host uploads after the warm-up), drops for
            // the new warm-up at some moment between the last old and the
            // first new identity frame (the switch happens in between).
            let (was_on, relay_dropped) = record::with(|log| {
                let was_on = log.relay_at(last_old);
                let dropped = log
                    .relay
                    .iter()
                    .any(|c| !c.energised && c.at > last_old && c.at <= first_new);
                (was_on, dropped)
            });
            let ok = new.node == before.node
                && new.params_version == 1
                && new.params_crc != before.params_crc
                && was_on
                && relay_dropped;
            println!(
                "LM_Identity: before the upload version {} crc {:08x}; after it version {} crc {:08x} ({} frames); relay {} before, dropped at the restart: {}{}",
                before.params_version,
                before.params_crc,
                new.params_version,
                new.params_crc,
                after,
                if was_on { "energised" } else { "off (FAILED: upload during the warm-up)" },
                relay_dropped,
                if ok { "" } else { " (FAILED)" }
            );
            if !ok {
                // What the relay did around the switch, for the failure's cause.
                record::with(|log| {
                    for c in log.relay.iter() {
                        println!(
                            "LM_Identity: relay {} at {} ms (sample {:?}); last old identity at {} ms, first new at {} ms; overruns {}",
                            if c.energised { "on" } else { "off" },
                            c.at.as_millis(),
                            log.sample_at(c.at),
                            last_old.as_millis(),
                            first_new.as_millis(),
                            log.overruns
                        );
                    }
                });
            }
            ok
        }
        Switch::Wrong(why) => {
            println!("LM_Identity after an upload: FAILED, {}", why);
            false
        }
        Switch::Waiting => unreachable!("the loop ends only on an outcome"),
    };
    exit(passed)
}
