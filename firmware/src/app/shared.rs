//! State shared between the high-priority estimator and the low-priority
//! tasks. Atomics, or a critical section of a few instructions: the
//! estimator never waits for a low-priority task.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicPtr, AtomicU16, AtomicU32, AtomicU8, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use monitor::acknowledge::{AckEvent, AckResult};
use monitor::device::alarm::AlarmOutput;
use monitor::device::deadline::LoadReport;
use monitor::device::diagnostics::flow::Checkpoint;
use monitor::device::diagnostics::{DeviceFault, DeviceFaults};
use monitor::protocol::outbox::Outbox;
use monitor::protocol::{AlarmFrame, Command, IdentityFrame, Message};
use monitor::Monitor;

use super::stream::SampleStream;

/// Events on their way to the event memory: ms since boot and the event.
pub type MemoryEvent = (u32, link::EventKind);

/// Something worth a log line, from the estimator (logged by the
/// supervisor, so the estimator never waits for the log).
#[derive(Clone, Copy, Debug, defmt::Format)]
pub enum LogEvent {
    /// A monitor event (alarm, sensor fault, data gap, filter reset).
    Monitor {
        /// Sample time, ms.
        t_ms: u64,
        /// The event.
        event: monitor::Event,
    },
    /// The alarm output changed.
    Alarm {
        /// Sample time, ms.
        t_ms: u64,
        /// The new output.
        output: AlarmOutput,
    },
    /// An acknowledge attempt: accepted, or rejected with its reason
    /// (by the CAN receiver: transport and authentication; by the
    /// estimator: the acknowledge policy).
    AckAttempt(AckEvent),
    /// ADC data was lost.
    Overrun {
        /// Sample time after the overrun, ms.
        t_ms: u64,
        /// Samples lost.
        lost: u32,
    },
}

/// CAN counters since boot (wrapping).
pub struct CanStats {
    /// Frames queued for the bus.
    pub sent: AtomicU32,
    /// Frames dropped (transmit timeout, aborted).
    pub dropped: AtomicU32,
    /// Received command frames rejected (CRC, format, repeated counter).
    pub rejected: AtomicU32,
    /// Bus errors reported by the controller.
    pub bus_errors: AtomicU32,
}

/// Acknowledge bookkeeping between the CAN receiver (which owns the
/// challenge and checks the tag) and the estimator (which owns the latch).
pub struct AckShared {
    /// `AckResult::code` of the last attempt (0: none since boot).
    pub last: AtomicU8,
    /// Attempts since boot (wrapping).
    pub attempts: AtomicU8,
    /// Alarms raised since boot (wrapping): the receiver issues a new
    /// challenge when this changes.
    pub raised: AtomicU32,
    /// Signalled on every attempt and alarm raised: the receiver
    /// publishes the challenge frame at once.
    pub changed: Signal<CriticalSectionRawMutex, ()>,
}

impl AckShared {
    /// The last attempt's outcome.
    pub fn last(&self) -> Option<AckResult> {
        AckResult::from_code(self.last.load(Ordering::Relaxed))
    }
}

/// Everything shared between tasks.
pub struct Shared {
    outbox: Mutex<CriticalSectionRawMutex, RefCell<Outbox>>,
    outbox_ready: Signal<CriticalSectionRawMutex, ()>,
    /// The latest command received over CAN, for the estimator.
    pub commands: Signal<CriticalSectionRawMutex, Command>,
    log: Channel<CriticalSectionRawMutex, LogEvent, 16>,
    log_dropped: AtomicU32,
    /// Samples processed by the estimator (wrapping).
    pub processed: AtomicU32,
    /// Samples missed by the estimator (wrapping).
    pub missed: AtomicU32,
    /// The alarm state shown (`AlarmState::code`).
    pub alarm_state: AtomicU8,
    /// Set by the supervisor when the estimator stalled: relay off for good.
    pub stalled: AtomicBool,
    /// Device faults found by the diagnostics (`DeviceFaults` bits),
    /// latched until reset.
    device_faults: AtomicU16,
    /// Program-flow checkpoints passed since the supervisor last looked.
    checkpoints: AtomicU16,
    /// Boot time of the first sample, ms (`u32::MAX` until it arrives): the
    /// origin of the sample clock, which dates every alarm frame.
    pub first_sample_ms: AtomicU32,
    last_alarm: Mutex<CriticalSectionRawMutex, Cell<Option<AlarmFrame>>>,
    last_load: Mutex<CriticalSectionRawMutex, Cell<LoadReport>>,
    /// CAN counters.
    pub can: CanStats,
    /// Acknowledge attempts and alarms raised.
    pub ack: AckShared,
    /// Sample blocks for the commissioning link.
    pub stream: SampleStream,
    /// A monitor on a new parameter set, lent by the link task for the
    /// estimator to swap in (see [`Shared::lend_monitor`]); null if none.
    next_monitor: AtomicPtr<Monitor<f32>>,
    next_identity: Mutex<CriticalSectionRawMutex, Cell<Option<IdentityFrame>>>,
    memory: Channel<CriticalSectionRawMutex, MemoryEvent, 8>,
    memory_dropped: AtomicU32,
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

impl Shared {
    /// `now_ms` (ms since boot) on the sample clock: ms since the first
    /// sample (0 before it), so frames from any task share one time base.
    pub fn sample_clock_ms(&self, now_ms: u64) -> u32 {
        match self.first_sample_ms.load(Ordering::Acquire) {
            u32::MAX => 0,
            first => (now_ms as u32).wrapping_sub(first),
        }
    }

    /// Record a device fault (latched until reset); true if it is new.
    pub fn raise_device_fault(&self, f: DeviceFault) -> bool {
        let bit = DeviceFaults::bit(f);
        self.device_faults.fetch_or(bit, Ordering::AcqRel) & bit == 0
    }

    /// The device faults recorded so far.
    pub fn device_faults(&self) -> DeviceFaults {
        DeviceFaults::from_bits(self.device_faults.load(Ordering::Acquire))
    }

    /// A task passed its program-flow checkpoint.
    pub fn pass(&self, c: Checkpoint) {
        self.checkpoints.fetch_or(1 << c.bit, Ordering::Release);
    }

    /// The checkpoints passed since the previous call (for the supervisor).
    pub fn take_checkpoints(&self) -> u16 {
        self.checkpoints.swap(0, Ordering::AcqRel)
    }

    /// Nothing posted, nothing counted.
    pub const fn new() -> Self {
        Self {
            outbox: Mutex::new(RefCell::new(Outbox::new())),
            outbox_ready: Signal::new(),
            commands: Signal::new(),
            log: Channel::new(),
            log_dropped: AtomicU32::new(0),
            processed: AtomicU32::new(0),
            missed: AtomicU32::new(0),
            alarm_state: AtomicU8::new(0),
            stalled: AtomicBool::new(false),
            device_faults: AtomicU16::new(0),
            checkpoints: AtomicU16::new(0),
            first_sample_ms: AtomicU32::new(u32::MAX),
            last_alarm: Mutex::new(Cell::new(None)),
            last_load: Mutex::new(Cell::new(LoadReport {
                processed: 0,
                missed: 0,
                overruns: 0,
                load_pct: 0,
                peak_pct: 0,
            })),
            can: CanStats {
                sent: AtomicU32::new(0),
                dropped: AtomicU32::new(0),
                rejected: AtomicU32::new(0),
                bus_errors: AtomicU32::new(0),
            },
            ack: AckShared {
                last: AtomicU8::new(0),
                attempts: AtomicU8::new(0),
                raised: AtomicU32::new(0),
                changed: Signal::new(),
            },
            stream: SampleStream::new(),
            next_monitor: AtomicPtr::new(core::ptr::null_mut()),
            next_identity: Mutex::new(Cell::new(None)),
            memory: Channel::new(),
            memory_dropped: AtomicU32::new(0),
        }
    }

    /// Record an acknowledge attempt (for the challenge frame and the log).
    pub fn ack_attempt(&self, e: AckEvent) {
        self.ack.last.store(e.outcome.code(), Ordering::Relaxed);
        self.ack.attempts.fetch_add(1, Ordering::Relaxed);
        self.ack.changed.signal(());
        self.log(LogEvent::AckAttempt(e));
    }

    /// An alarm was raised: the receiver renews the challenge.
    pub fn alarm_raised(&self) {
        self.ack.raised.fetch_add(1, Ordering::Release);
        self.ack.changed.signal(());
    }

    /// Queue a message for the CAN transmitter (never waits; replaces a
    /// pending message of the same kind).
    pub fn post(&self, msg: Message) {
        self.outbox.lock(|o| o.borrow_mut().post(msg));
        self.outbox_ready.signal(());
    }

    /// The most urgent queued message.
    pub fn take_next(&self) -> Option<Message> {
        self.outbox.lock(|o| o.borrow_mut().take_next())
    }

    /// Messages replaced in the outbox before they were sent (wrapping).
    pub fn replaced(&self) -> u32 {
        self.outbox.lock(|o| o.borrow().replaced())
    }

    /// Wait until something was posted.
    pub async fn wait_for_messages(&self) {
        self.outbox_ready.wait().await
    }

    /// Queue a log event (dropped and counted if the log is full).
    pub fn log(&self, e: LogEvent) {
        if self.log.try_send(e).is_err() {
            self.log_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The next queued log event.
    pub fn next_log(&self) -> Option<LogEvent> {
        self.log.try_receive().ok()
    }

    /// Log events dropped because the log was full (wrapping).
    pub fn log_dropped(&self) -> u32 {
        self.log_dropped.load(Ordering::Relaxed)
    }

    /// Link task: the estimator must restart on `monitor` (a new
    /// parameter set with the identity `identity`). Lends it to the
    /// estimator and waits, without yielding, until the estimator swapped
    /// it with the running one (at its next block) or `give_up()` says so;
    /// `monitor` then holds the old monitor, or the new one if it was not
    /// taken (returns false).
    ///
    /// Built by the caller and lent, not moved into a static: a static
    /// slot would cost a monitor's worth of RAM (4 KiB) for ever, and
    /// building it in the estimator would put `Monitor::new`'s 13 KiB of
    /// stack on the estimator's interrupt.
    pub fn lend_monitor(
        &self,
        monitor: &mut Monitor<f32>,
        identity: IdentityFrame,
        mut give_up: impl FnMut() -> bool,
    ) -> bool {
        self.next_identity.lock(|c| c.set(Some(identity)));
        let lent: *mut Monitor<f32> = monitor;
        self.next_monitor.store(lent, Ordering::Release);
        loop {
            if self.next_monitor.load(Ordering::Acquire).is_null() {
                return true;
            }
            if give_up() {
                // Withdrawn, unless the estimator took it meanwhile.
                return self
                    .next_monitor
                    .compare_exchange(
                        lent,
                        core::ptr::null_mut(),
                        Ordering::AcqRel,
                        Ordering::Acquire,
                    )
                    .is_err();
            }
        }
    }

    /// Estimator: swap in the monitor lent, if one is (`swap` exchanges it
    /// with the running one); its identity.
    pub fn take_monitor(&self, swap: impl FnOnce(&mut Monitor<f32>)) -> Option<IdentityFrame> {
        let lent = self.next_monitor.load(Ordering::Acquire);
        if lent.is_null() {
            return None;
        }
        // SAFETY: the pointer is to the lender's `&mut Monitor`, which it
        // does not touch until the pointer is null again. The estimator
        // runs above the lender's priority on a single core: the lender
        // cannot resume (and withdraw or drop it) before this returns,
        // and it clears the pointer only after the swap.
        swap(unsafe { &mut *lent });
        let identity = self.next_identity.lock(Cell::take);
        self.next_monitor
            .store(core::ptr::null_mut(), Ordering::Release);
        identity
    }

    /// Estimator: an event for the event memory (dropped and counted if
    /// the queue is full; never waits).
    pub fn remember(&self, e: MemoryEvent) {
        if self.memory.try_send(e).is_err() {
            self.memory_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Link task: the next event for the event memory.
    pub async fn next_memory(&self) -> MemoryEvent {
        self.memory.receive().await
    }

    /// Events dropped on their way to the event memory (wrapping).
    pub fn memory_dropped(&self) -> u32 {
        self.memory_dropped.load(Ordering::Relaxed)
    }

    /// Remember the alarm frame last built by the estimator.
    pub fn set_last_alarm(&self, f: AlarmFrame) {
        self.last_alarm.lock(|c| c.set(Some(f)));
    }

    /// The alarm frame last built by the estimator.
    pub fn last_alarm(&self) -> Option<AlarmFrame> {
        self.last_alarm.lock(Cell::get)
    }

    /// Remember the last second's load report.
    pub fn set_load(&self, r: LoadReport) {
        self.last_load.lock(|c| c.set(r));
    }

    /// The last second's load report.
    pub fn load(&self) -> LoadReport {
        self.last_load.lock(Cell::get)
    }
}
