//! The check of a run with a broken sensor input: the firmware's tasks
//! must drop the relay and send an alarm frame in state `sensor_fault`
//! naming the channel, within the front end's debounce, and keep the
//! relay off to the end (the input stays broken).

use embassy_time::{Duration, Instant};
use monitor::device::alarm::AlarmState;
use monitor::protocol::{Decoder, Message};
use monitor::Channel;
use qemu_tests::println;

use super::super::record::Log;

/// Check the reaction to `channel` breaking at `at`: the relay off and the
/// frame within `(earliest, latest)` of it; true when it passed.
pub fn run(log: &Log, channel: Channel, at: Instant, reaction: (Duration, Duration)) -> bool {
    let (earliest, latest) = reaction;
    let in_time = |t: Instant| t >= at + earliest && t - at <= latest;
    let mut ok = true;
    let mut fail = |what: &str| {
        println!("sensor fault check FAILED: {what}");
        ok = false;
    };
    if log.overflow {
        fail("the board's record overflowed");
    }
    if !log.relay_at(at) {
        fail("the relay was not energised when the input broke (break it later)");
    }
    let mut decoder = Decoder::new();
    let frame = log
        .frames
        .iter()
        .find_map(|s| match decoder.decode(&s.frame) {
            Ok(r) => match r.message {
                Message::Alarm(a) if s.at >= at && a.state == AlarmState::SensorFault => {
                    Some((s.at, a))
                }
                _ => None,
            },
            Err(_) => None,
        });
    match frame {
        None => fail("no alarm frame with state sensor_fault after the break"),
        Some((sent, a)) => {
            if a.faulted_channels & channel.bit() == 0 {
                fail("the alarm frame does not name the broken channel");
            }
            if a.relay_energised {
                fail("the alarm frame shows the relay energised");
            }
            if !in_time(sent) {
                fail("the alarm frame came too early or too late");
            }
            println!(
                "{} broken at {} ms: alarm frame sensor_fault, channels 0x{:02x}, after {} µs, relay energised={}",
                channel.name(),
                (at - log.t0.unwrap_or(at)).as_millis(),
                a.faulted_channels,
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
        fail("the relay was energised again while the input stayed broken");
    }
    ok
}
