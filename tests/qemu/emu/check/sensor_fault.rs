//! The check of a run with a broken sensor input: the firmware's tasks
//! must drop the relay and send an alarm frame in state `sensor_fault`
//! naming the channel, within the front end's debounce, and keep the
//! relay off to the end (the input stays broken).

use embassy_time::{Duration, Instant};
use monitor::device::alarm::AlarmState;
use monitor::Channel;
use qemu_tests::println;

use super::super::record::Log;

/// Check the reaction to `channel` breaking at `at`: the relay off and the
/// frame within `reaction` of it; true when it passed.
pub fn run(log: &Log, channel: Channel, at: Instant, reaction: (Duration, Duration)) -> bool {
    super::reaction::run(
        log,
        "sensor fault",
        AlarmState::SensorFault,
        at,
        reaction,
        |a| {
            (a.faulted_channels & channel.bit() == 0)
                .then_some("the alarm frame does not name the broken channel")
        },
        |after, a| {
            println!(
                "{} broken at {} ms: alarm frame sensor_fault, channels 0x{:02x}, after {} µs, relay energised={}",
                channel.name(),
                (at - log.t0.unwrap_or(at)).as_millis(),
                a.faulted_channels,
                after.as_micros(),
                a.relay_energised
            )
        },
    )
}
