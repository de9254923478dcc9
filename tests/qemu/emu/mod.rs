//! The firmware's application tasks (`firmware::app`) on an emulated
//! board in QEMU: the same estimator, CAN and supervisor code as on the
//! STM32F405, only the board trait (`board`) and the time driver
//! (`time_driver`) are emulated.
//!
//! As on the STM32 board, the estimator runs in an interrupt executor
//! above everything else the application does. The other tasks run in a
//! second interrupt executor at the lowest priority instead of the
//! thread-mode executor: QEMU implements `wfe`, on which embassy's
//! thread-mode executor idles, as a busy loop, while `wfi` lets its
//! virtual clock jump to the next timer (`-icount …,sleep=off`).
//!
//! A run: the board replays a golden case at 1 kHz; the CAN receiver
//! plays the command script ([`commands`]); after the last sample the
//! checker waits for the supervisor to notice that samples stopped,
//! then checks everything recorded (`check`) and exits QEMU with the
//! verdict.

mod board;
pub mod case;
mod check;
mod flash;
mod linked;
mod logger;
mod record;
mod time_driver;
mod uart;

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::exception;
use embassy_executor::{InterruptExecutor, SendSpawner};
use embassy_time::{Duration, Instant, Timer};
use firmware::app;
use firmware::app::shared::Shared;
use firmware::app::supervisor::{CHECK_PERIOD, REFERENCE_EVERY};
use firmware::board::BootInfo;
use firmware::board_map::{FRONTEND, SCANS_PER_SAMPLE};
use golden::params::golden_params;
use heapless::Vec;
use monitor::device::Estimator;
use monitor::protocol::auth::{acknowledge_frame_for, Challenger};
use monitor::protocol::{CanFrame, IdentityFrame, Node, ResetCause};
use qemu_tests::counter::{self, Counter};
use qemu_tests::{exit, println};

use board::{
    InstructionCounter, RecordingCanTx, RecordingLed, RecordingRelay, RecordingWatchdog, ReplayAdc,
    ScriptedCanRx, ScriptedSelfTest,
};
use case::EmuCase;
use check::Expect;
use firmware::board_map::{u_valve_open_pin_volts, LOOP_SUPPLY_V};
use monitor::device::diagnostics::reference::ReferenceConfig;
use monitor::device::diagnostics::DeviceFault;
use monitor::signal::ne43::DebounceConfig;
use monitor::Channel;

static SHARED: Shared = Shared::new();
static RELAY: RecordingRelay = RecordingRelay::new();
static EXECUTOR_HIGH: InterruptExecutor = InterruptExecutor::new();
static EXECUTOR_LOW: InterruptExecutor = InterruptExecutor::new();

/// The seed of the acknowledge challenges. The STM32 board takes it from
/// its true RNG (mixed with the chip's unique ID); the emulated board has
/// neither (QEMU's netduinoplus2 does not model the RNG, and this board
/// does not use the HAL), so a fixed board value: "EMUBOARD".
pub const CHALLENGE_SEED: u64 = u64::from_le_bytes(*b"EMUBOARD");

/// The reset cause the emulated board reports.
const RESET_CAUSE: ResetCause = ResetCause::PowerOn;
/// Priorities (upper 4 bits, as on the STM32F405): the time driver's
/// tick above the estimator (as the STM32 board's DMA and timer
/// interrupts), the estimator at the STM32 board's priority 6, the
/// other tasks at the lowest.
const TICK_PRIORITY: u8 = 0 << 4;
const ESTIMATOR_PRIORITY: u8 = 6 << 4;
const TASKS_PRIORITY: u8 = 15 << 4;
/// How long after the last sample the checker waits: the supervisor
/// declares the estimator stalled within two of its check periods.
const SETTLE: Duration = Duration::from_millis(50);

/// Spare interrupt vectors of the STM32F405 running the executors (UART4
/// as on the STM32 board, UART5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
enum Irq {
    Estimator = 52,
    Tasks = 53,
}

// SAFETY: both are valid interrupt numbers of the STM32F405 (82 vectors).
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

/// Without a device crate every interrupt arrives here.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    // SAFETY: each executor's own interrupt, started before it is unmasked.
    unsafe {
        match irqn {
            n if n == Irq::Estimator as i16 => EXECUTOR_HIGH.on_interrupt(),
            n if n == Irq::Tasks as i16 => EXECUTOR_LOW.on_interrupt(),
            n if n == uart::USART1.irq().number() as i16 => uart::USART1.on_interrupt(),
            n => panic!("unexpected interrupt {n}"),
        }
    }
}

firmware::app_tasks! {
    shared: SHARED,
    sample_source: ReplayAdc,
    relay: RecordingRelay,
    cycle_counter: InstructionCounter,
    watchdog: RecordingWatchdog,
    led: RecordingLed,
    self_test: ScriptedSelfTest,
    can_tx: RecordingCanTx,
    can_rx: ScriptedCanRx,
}

/// What a test injects into the emulated board.
#[derive(Clone, Copy, Debug)]
pub enum Injection {
    /// The board's self-test finds this device fault.
    SelfTest(DeviceFault),
    /// VREFINT converts to this code (the supervisor's reference check
    /// must find the ADC reference out of range).
    Vrefint(u16),
    /// The valve-command wire breaks: its input converts to the code the
    /// board map's wire-break bias gives an open input
    /// ([`open_command_wire_code`]), and the front end must fault the
    /// channel.
    OpenCommandWire,
}

impl Injection {
    /// The device fault the firmware must report, if a device fault.
    fn device_fault(self) -> Option<DeviceFault> {
        match self {
            Self::SelfTest(f) => Some(f),
            Self::Vrefint(_) => Some(DeviceFault::AdcReference),
            Self::OpenCommandWire => None,
        }
    }

    /// Earliest and latest accepted time from the injection to the relay
    /// off and the alarm frame. A self-test fault: at the next supervisor
    /// check (three checks plus a block at most). A bad VREFINT: after the
    /// reference check's debounce of 10 readings, one every
    /// `REFERENCE_EVERY` checks (the first at most one reading period
    /// after the injection): at least 9 and at most 10 reading periods,
    /// plus the same margin.
    fn reaction(self) -> (Duration, Duration) {
        const MARGIN: Duration = Duration::from_millis(35);
        match self {
            Self::SelfTest(_) => (Duration::from_ticks(0), MARGIN),
            // The front end's debounce of consecutive bad blocks.
            Self::OpenCommandWire => {
                let blocks = u64::from(DebounceConfig::DEFAULT.fault_samples);
                let period = Duration::from_micros(u64::from(app::SAMPLE_PERIOD_US));
                (Duration::from_ticks(0), period * blocks as u32 + MARGIN)
            }
            Self::Vrefint(_) => {
                let readings = u32::from(ReferenceConfig::DEFAULT.debounce);
                let every = CHECK_PERIOD * REFERENCE_EVERY;
                (every * (readings - 1), every * readings + MARGIN)
            }
        }
    }
}

/// Wait for the end of the replay, check the run with an injected device
/// fault, and end it.
#[embassy_executor::task]
async fn fault_checker(case: &'static EmuCase, t0: Instant, injection: Injection, at: Instant) {
    let period = Duration::from_micros(u64::from(case.sample_period_us));
    Timer::at(t0 + period * (case.samples - 1) + SETTLE).await;
    let reaction = injection.reaction();
    let passed = record::with(|log| match injection.device_fault() {
        Some(fault) => check::device_fault::run(log, fault, at, reaction),
        None => check::sensor_fault::run(log, Channel::UValve, at, reaction),
    });
    if passed {
        println!(
            "firmware on the emulated board, case {} with {:?}: all checks passed",
            case.name, injection
        );
    }
    exit(passed)
}

/// Wait for the end of the replay, check, and end the run.
#[embassy_executor::task]
async fn checker(case: &'static EmuCase, t0: Instant, expect: Expect) {
    let period = Duration::from_micros(u64::from(case.sample_period_us));
    Timer::at(t0 + period * (case.samples - 1) + SETTLE).await;
    exit(check_frames(case, &expect))
}

/// Check everything the firmware did during the replay of `case`.
fn check_frames(case: &EmuCase, expect: &Expect) -> bool {
    println!(
        "emulated board: {} samples of {} replayed; the firmware logged {} defmt records",
        case.samples,
        case.source,
        logger::records()
    );
    let (passed, caught) = record::with(|log| {
        let passed = check::run(case, log, &SHARED, expect, false).passed();
        (passed, check::selftest::run(case, log, &SHARED, expect))
    });
    if passed && caught {
        println!(
            "firmware on the emulated board, case {}: all checks passed",
            case.name
        );
    }
    passed && caught
}

/// The command frames the CAN receiver plays, around the sample `ack`
/// at which the estimator must apply the acknowledge: a corrupted copy
/// 100 samples before, the acknowledge itself half a sample before (the
/// receiver task signals it while the estimator waits for the next
/// block), and a replay of it 50 samples after. Only the second may act.
/// The acknowledge answers the challenge current at that time, as a
/// controller holding the firmware's key computes it: the boot's first,
/// renewed once per alarm raised before (`EmuCase::ack_rotations`). It
/// arrives 200 ms after the last alarm change, inside the acknowledge
/// hold-off: the policy refuses it, the replay is stale.
fn commands(case: &EmuCase, t0: Instant, node: Node) -> (Vec<(Instant, CanFrame), 3>, u32) {
    let mut script = Vec::new();
    let Some(ack) = case.ack_sample else {
        return (script, 0);
    };
    let period = Duration::from_micros(u64::from(case.sample_period_us));
    let at = |k: u32| t0 + period * k + period / 2;
    let key = firmware::ack_key::ACK_KEY;
    let mut challenger = Challenger::new(&key, CHALLENGE_SEED, 0);
    for _ in 0..case.ack_rotations {
        challenger.rotate(0);
    }
    let frame = acknowledge_frame_for(node, &key, challenger.current(), 0);
    let mut data = [0u8; 8];
    data.copy_from_slice(frame.data());
    data[2] ^= 0x01;
    let corrupted = CanFrame::new(frame.id(), &data).expect("8 bytes");
    let _ = script.push((at(ack - 100), corrupted));
    let _ = script.push((at(ack - 1), frame));
    let _ = script.push((at(ack + 50), frame));
    (script, 2)
}

/// Check the emulated time base against QEMU's virtual clock (TIM2,
/// 1 ns per tick): 5 ms of embassy time must be 5 ms of virtual time.
fn check_time_base() -> bool {
    const SPAN_US: u64 = 5000;
    let start = Instant::now();
    let c0 = counter::now();
    while Instant::now() < start + Duration::from_micros(SPAN_US) {}
    let ns = counter::now().wrapping_sub(c0) as u64;
    let ok = ns.abs_diff(SPAN_US * 1000) <= SPAN_US * 10;
    println!(
        "time base: {SPAN_US} µs of embassy time = {ns} ns of QEMU virtual time{}",
        if ok {
            ""
        } else {
            " (FAILED: off by more than 1 %)"
        }
    );
    ok
}

#[allow(unused_imports)] // used by the link tests only
pub use linked::{run as linked_run, Link};

/// Replay `case` through the firmware's tasks and check what they do.
#[allow(dead_code)] // each test binary calls one of these
pub fn run(case: &'static EmuCase) -> ! {
    run_with(case, None, Node::DEFAULT)
}

/// [`run`] with the installation's CAN node number `node`: every frame
/// and the command on the moved identifiers.
#[allow(dead_code)]
pub fn run_on_node(case: &'static EmuCase, node: Node) -> ! {
    run_with(case, None, node)
}

/// Replay `case` with the board's self-test finding `fault` 100 ms after
/// the relay was first energised, and check the firmware's reaction.
#[allow(dead_code)]
pub fn run_with_fault(case: &'static EmuCase, fault: DeviceFault) -> ! {
    run_with(case, Some(Injection::SelfTest(fault)), Node::DEFAULT)
}

/// Replay `case` with VREFINT converting to `code` from 100 ms after the
/// relay was first energised, and check the firmware's reaction.
#[allow(dead_code)]
pub fn run_with_vrefint(case: &'static EmuCase, code: u16) -> ! {
    run_with(case, Some(Injection::Vrefint(code)), Node::DEFAULT)
}

/// Replay `case` with the valve-command wire breaking 100 ms after the
/// relay was first energised, and check that the front end faults it.
#[allow(dead_code)]
pub fn run_with_open_command_wire(case: &'static EmuCase) -> ! {
    run_with(case, Some(Injection::OpenCommandWire), Node::DEFAULT)
}

/// The code an open valve-command input converts to on this board: the
/// wire-break bias's pin voltage, held at VREF by the input clamp.
pub fn open_command_wire_code() -> u16 {
    let adc = FRONTEND.adc;
    let pin = u_valve_open_pin_volts(LOOP_SUPPLY_V).min(adc.vref_v);
    // Nearest code (no `f32::round` without std; the code is positive).
    (adc.counts(pin) + 0.5) as u16
}

/// The sample 100 ms after `case` first energises the relay (the golden's
/// healthy claim): where a test injects its fault.
fn injection_sample(case: &EmuCase) -> u32 {
    let energised = case
        .alarm_changes()
        .find(|(_, a)| a.relay_energised)
        .map(|(k, _)| k)
        .expect("the case energises the relay");
    energised + 100
}

fn run_with(case: &'static EmuCase, injection: Option<Injection>, node: Node) -> ! {
    let mut nvic = power_on(case);
    let mut params = golden_params(case.sample_period_s, case.warm_up_s);
    params.can.node = node.number().into();
    let boot = BootInfo {
        reset_cause: RESET_CAUSE,
        identity: identity(&params),
        version: firmware::version::FRAME,
    };
    let pipeline = pipeline(&params);
    let (high, low) = start_executors(&mut nvic);
    let source = match injection {
        Some(Injection::OpenCommandWire) => ReplayAdc::start_broken(
            case,
            injection_sample(case),
            Channel::UValve as usize,
            open_command_wire_code(),
        ),
        _ => ReplayAdc::start(case),
    };
    start_tasks(
        case,
        injection,
        node,
        boot,
        pipeline,
        source,
        high,
        low,
        Checker::Frames,
    );
    idle()
}

/// Bring the emulated board up: the instruction counter, the time driver
/// (checked against QEMU's clock). Returns the interrupt controller.
fn power_on(case: &EmuCase) -> NVIC {
    assert!(
        case.sample_period_us == app::SAMPLE_PERIOD_US && case.scans as usize == SCANS_PER_SAMPLE,
        "{}: codes generated for another sample period or scan count",
        case.name
    );
    let mut core = cortex_m::Peripherals::take().expect("core peripherals");
    // TIM2 counts virtual nanoseconds (the estimator's cycle counter).
    let _ = Counter::start();
    time_driver::start(core.SYST, &mut core.SCB, TICK_PRIORITY);
    if !check_time_base() {
        exit(false);
    }
    core.NVIC
}

/// The estimator's pipeline for `params`, in a static.
#[inline(never)] // the pipeline passes through this frame, gone before the tasks run
fn pipeline(params: &monitor::Params) -> &'static mut Estimator<f32> {
    match app::estimator::pipeline::<InstructionCounter>(params, FRONTEND) {
        Ok(e) => cortex_m::singleton!(: Estimator<f32> = e).expect("one estimator"),
        Err(e) => panic!("invalid golden parameters: {}", e.field),
    }
}

/// Start both executors (the estimator's above the other tasks').
fn start_executors(nvic: &mut NVIC) -> (SendSpawner, SendSpawner) {
    // SAFETY: set before the executors start, as they require.
    unsafe {
        nvic.set_priority(Irq::Estimator, ESTIMATOR_PRIORITY);
        nvic.set_priority(Irq::Tasks, TASKS_PRIORITY);
    }
    (
        EXECUTOR_HIGH.start(Irq::Estimator),
        EXECUTOR_LOW.start(Irq::Tasks),
    )
}

/// Sleep between interrupts for ever.
fn idle() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Which checker ends the run.
#[derive(Clone, Copy, Debug)]
#[allow(dead_code)] // each test binary uses one
enum Checker {
    /// Every frame against the host's reference ([`checker`] or, with an
    /// injection, [`fault_checker`]).
    Frames,
    /// As `Frames`, then the commissioning link's stream
    /// ([`linked::stream_checker`]).
    Stream,
    /// The identity on CAN after an upload ([`linked::upload_checker`]).
    Upload,
}

/// The ADC is running (`source` replays `case` from its t0): spawn the
/// application's tasks and the checker.
#[allow(clippy::too_many_arguments)]
fn start_tasks(
    case: &'static EmuCase,
    injection: Option<Injection>,
    node: Node,
    boot: BootInfo,
    pipeline: &'static mut Estimator<f32>,
    source: ReplayAdc,
    high: SendSpawner,
    low: SendSpawner,
    checker_kind: Checker,
) {
    let t0 = record::with(|l| l.t0).expect("t0 set by the ADC");
    let (script, rejected_commands) = match checker_kind {
        Checker::Upload => (Vec::new(), 0),
        Checker::Frames | Checker::Stream => commands(case, t0, node),
    };
    let script: &'static Vec<(Instant, CanFrame), 3> =
        cortex_m::singleton!(: Vec<(Instant, CanFrame), 3> = script).expect("one script");
    let expect = Expect {
        reset_cause: RESET_CAUSE,
        rejected_commands,
        identity: boot.identity,
        version: boot.version,
    };
    high.spawn(
        estimator(source, &RELAY, InstructionCounter, pipeline, boot).expect("estimator task"),
    );
    // The injection: 100 ms after the host's reference first energises
    // the relay (the golden's healthy claim).
    let inject = injection.map(|i| {
        let k = injection_sample(case);
        let (_, latest) = i.reaction();
        assert!(
            u64::from(k + 50) + latest.as_millis() < u64::from(case.samples),
            "too late in the case to inject"
        );
        let period = Duration::from_micros(u64::from(case.sample_period_us));
        (t0 + period * k, i)
    });
    let self_test = ScriptedSelfTest {
        fault: inject.and_then(|(at, i)| match i {
            Injection::SelfTest(f) => Some((at, f)),
            _ => None,
        }),
        vrefint: inject.and_then(|(at, i)| match i {
            Injection::Vrefint(code) => Some((at, code)),
            _ => None,
        }),
    };
    let supervisor = supervisor(RecordingWatchdog, &RELAY, RecordingLed::new(), self_test);
    low.spawn(supervisor.expect("supervisor task"));
    low.spawn(can_tx(RecordingCanTx, node).expect("CAN transmit task"));
    let can_rx = can_rx(ScriptedCanRx::new(script.as_slice()), node, CHALLENGE_SEED);
    low.spawn(can_rx.expect("CAN receive task"));
    match (checker_kind, inject) {
        (Checker::Frames, None) => low.spawn(checker(case, t0, expect).expect("checker task")),
        (Checker::Frames, Some((at, i))) => {
            low.spawn(fault_checker(case, t0, i, at).expect("checker task"))
        }
        (Checker::Stream, _) => {
            low.spawn(linked::stream_checker(case, t0, expect).expect("checker task"))
        }
        (Checker::Upload, _) => {
            low.spawn(linked::upload_checker(expect.identity).expect("checker task"))
        }
    }
}

/// The identity of `params` as the commissioning link computes it
/// (version 0: compiled in), as the firmware's build script does.
fn identity(params: &monitor::Params) -> IdentityFrame {
    let id = link::storage::params_identity(params, 0).expect("the golden parameters encode");
    IdentityFrame {
        node: params.node(),
        params_crc: id.crc,
        params_version: 0,
    }
}
