//! What the checks of an injected fault share: the relay energised when
//! the fault came, the first alarm frame in the expected state after it
//! within the reaction time and with the relay shown off, the relay
//! dropped within the reaction time and never energised again.

use embassy_time::{Duration, Instant};
use monitor::device::alarm::AlarmState;
use monitor::protocol::{AlarmFrame, Decoder, Message};
use qemu_tests::println;

use super::super::record::Log;

/// Check the reaction to a fault injected at `at` that must bring alarm
/// state `state` within `(earliest, latest)` of it. `problem` judges the
/// frame's own fields (`None`: right), `report` prints it. `what` names
/// the check in its failures. True when it passed.
pub fn run(
    log: &Log,
    what: &str,
    state: AlarmState,
    at: Instant,
    (earliest, latest): (Duration, Duration),
    problem: impl Fn(&AlarmFrame) -> Option<&'static str>,
    report: impl Fn(Duration, &AlarmFrame),
) -> bool {
    let in_time = |t: Instant| t >= at + earliest && t - at <= latest;
    let mut ok = true;
    let mut fail = |why: &str| {
        println!("{what} check FAILED: {why}");
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
                Message::Alarm(a) if s.at >= at && a.state == state => Some((s.at, a)),
                _ => None,
            },
            Err(_) => None,
        });
    match frame {
        None => fail("no alarm frame in the expected state after the injection"),
        Some((sent, a)) => {
            if let Some(why) = problem(&a) {
                fail(why);
            }
            if a.relay_energised {
                fail("the alarm frame shows the relay energised");
            }
            if !in_time(sent) {
                fail("the alarm frame came too early or too late");
            }
            report(sent - at, &a);
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
