//! The check of a run with an injected device fault: the firmware's tasks
//! must drop the relay and send an alarm frame naming the fault, within
//! the time its check takes to decide (a few supervisor periods for a
//! self-test fault, the debounce for a reading out of range), and keep
//! the relay off to the end.

use embassy_time::{Duration, Instant};
use monitor::device::alarm::AlarmState;
use monitor::device::diagnostics::DeviceFault;
use monitor::protocol::{Decoder, Message};
use qemu_tests::println;

use super::super::record::Log;

/// Check the reaction to `fault` injected at `at`: the relay off and the
/// frame within `(earliest, latest)` of it; true when it passed.
pub fn run(log: &Log, fault: DeviceFault, at: Instant, reaction: (Duration, Duration)) -> bool {
    let (earliest, latest) = reaction;
    let in_time = |t: Instant| t >= at + earliest && t - at <= latest;
    let mut ok = true;
    let mut fail = |what: &str| {
        println!("device fault check FAILED: {what}");
        ok = false;
    };
    if log.overflow {
        fail("the board's record overflowed");
    }
    if !log.relay_at(at) {
        fail("the relay was not energised when the fault was injected (inject later)");
    }
    let mut decoder = Decoder::new();
    let frame = log
        .frames
        .iter()
        .find_map(|s| match decoder.decode(&s.frame) {
            Ok(r) => match r.message {
                Message::Alarm(a) if s.at >= at && a.state == AlarmState::DeviceFault => {
                    Some((s.at, a))
                }
                _ => None,
            },
            Err(_) => None,
        });
    match frame {
        None => fail("no alarm frame with state device_fault after the injection"),
        Some((sent, a)) => {
            if a.device_fault != fault.code() {
                fail("the alarm frame names another device fault");
            }
            if a.relay_energised {
                fail("the alarm frame shows the relay energised");
            }
            if !in_time(sent) {
                fail("the alarm frame came too early or too late");
            }
            println!(
                "device fault {} injected at {} ms: alarm frame device_fault={} after {} µs, relay energised={}",
                fault.name(),
                (at - log.t0.unwrap_or(at)).as_millis(),
                a.device_fault,
                (sent - at).as_micros(),
                a.relay_energised
            );
        }
    }
    match log.relay.iter().find(|c| c.at >= at) {
        Some(c) if !c.energised && in_time(c.at) => {}
        _ => fail("the relay did not drop within the reaction time"),
    }
    if log.relay.iter().any(|c| c.at >= at && c.energised) {
        fail("the relay was energised again after the fault");
    }
    ok
}
