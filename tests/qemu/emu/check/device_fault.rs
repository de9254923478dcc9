//! The check of a run with an injected device fault: the firmware's tasks
//! must drop the relay and send an alarm frame naming the fault, within
//! the time its check takes to decide (a few supervisor periods for a
//! self-test fault, the debounce for a reading out of range), and keep
//! the relay off to the end.

use embassy_time::{Duration, Instant};
use monitor::device::alarm::AlarmState;
use monitor::device::diagnostics::DeviceFault;
use qemu_tests::println;

use super::super::record::Log;

/// Check the reaction to `fault` injected at `at`: the relay off and the
/// frame within `reaction` of it; true when it passed.
pub fn run(log: &Log, fault: DeviceFault, at: Instant, reaction: (Duration, Duration)) -> bool {
    super::reaction::run(
        log,
        "device fault",
        AlarmState::DeviceFault,
        at,
        reaction,
        |a| {
            (a.device_fault != fault.code()).then_some("the alarm frame names another device fault")
        },
        |after, a| {
            println!(
                "device fault {} injected at {} ms: alarm frame device_fault={} after {} µs, relay energised={}",
                fault.name(),
                (at - log.t0.unwrap_or(at)).as_millis(),
                a.device_fault,
                after.as_micros(),
                a.relay_energised
            )
        },
    )
}
