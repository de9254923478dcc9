//! The checks must be able to fail: run them again on copies of the
//! recorded log with one realistic fault each, and require the fault to
//! be flagged by the check meant to catch it.

use embassy_time::Duration;
use firmware::app::shared::Shared;
use monitor::device::alarm::AlarmState;
use monitor::protocol::{e2e, CanFrame, Decoder, Encoder, Message, MessageKind, Node};
use monitor::LeakSet;
use qemu_tests::println;

use super::{Check, Expect};
use crate::emu::case::EmuCase;
use crate::emu::record::Log;

/// Index in `log.frames` of the `nth` frame of `kind`.
fn nth(log: &Log, kind: MessageKind, nth: usize) -> usize {
    log.frames
        .iter()
        .enumerate()
        .filter(|(_, s)| MessageKind::locate(s.frame.id()).is_some_and(|(k, _)| k == kind))
        .nth(nth)
        .map(|(i, _)| i)
        .expect("enough frames of the kind")
}

/// `frame` with its message replaced by `msg`, keeping its counter and
/// protecting it properly (a wrong message, not a corrupted frame).
fn resend(frame: &CanFrame, msg: &Message) -> CanFrame {
    let counter = frame.data()[1] & 0x0F;
    let mut data = [0u8; 8];
    data.copy_from_slice(Encoder::new().encode(msg).data());
    e2e::protect(frame.id(), &mut data, counter);
    CanFrame::new(frame.id(), &data).expect("8 bytes")
}

/// The first alarm frame latching a leak (or, without one, the last
/// alarm frame before the end), with a wrong announcement: another leak
/// kind, or a leak where there is none.
fn wrong_verdict(log: &mut Log, case: &EmuCase, node: Node) {
    let alarm = |s: &crate::emu::record::Sent| match Decoder::for_node(node).decode(&s.frame) {
        Ok(r) => match r.message {
            Message::Alarm(a) => Some(a),
            _ => None,
        },
        Err(_) => None,
    };
    let leak = log
        .frames
        .iter()
        .position(|s| alarm(s).is_some_and(|a| a.latched != LeakSet::NONE));
    let i = leak.unwrap_or_else(|| nth(log, MessageKind::Alarm, case.samples as usize / 1000));
    let mut a = alarm(&log.frames[i]).expect("an alarm frame");
    a.latched = match a.latched {
        LeakSet::INTERNAL => LeakSet::EXTERNAL,
        LeakSet::NONE => LeakSet::INTERNAL,
        _ => LeakSet::INTERNAL,
    };
    a.state = AlarmState::Leak;
    a.relay_energised = false;
    log.frames[i].frame = resend(&log.frames[i].frame, &Message::Alarm(a));
}

/// Run the checks on `log` damaged by `damage`; it must fail `want`.
fn expect_flagged(
    name: &str,
    case: &EmuCase,
    log: &mut Log,
    shared: &Shared,
    expect: &Expect,
    damage: impl FnOnce(&mut Log),
    want: &[Check],
) -> bool {
    let saved = (log.frames.clone(), log.vrefint, log.lsi);
    damage(log);
    let f = super::run(case, log, shared, expect, true);
    (log.frames, log.vrefint, log.lsi) = saved;
    let ok = !f.passed() && want.iter().all(|&c| f.flagged(c));
    println!(
        "self-test: {name}: {} (flagged {:?}, want {:?})",
        if ok { "caught" } else { "FAILED: not caught" },
        f.flagged_list(),
        want
    );
    ok
}

/// Every fault must be caught; the log is restored after each.
pub fn run(case: &EmuCase, log: &mut Log, shared: &Shared, expect: &Expect) -> bool {
    let mut ok = true;
    ok &= expect_flagged(
        "one bit flipped in the 10th status frame",
        case,
        log,
        shared,
        expect,
        |log| {
            let i = nth(log, MessageKind::Status, 10);
            let f = log.frames[i].frame;
            let mut data = [0u8; 8];
            data.copy_from_slice(f.data());
            data[3] ^= 0x04;
            log.frames[i].frame = CanFrame::new(f.id(), &data).expect("8 bytes");
        },
        &[Check::Decode],
    );
    ok &= expect_flagged(
        "the 20th status frame lost",
        case,
        log,
        shared,
        expect,
        |log| {
            let i = nth(log, MessageKind::Status, 20);
            log.frames.remove(i);
        },
        &[Check::Counter, Check::Schedule],
    );
    ok &= expect_flagged(
        "a heartbeat sent 1 ms late",
        case,
        log,
        shared,
        expect,
        |log| {
            let i = nth(log, MessageKind::Heartbeat, 2);
            log.frames[i].at += Duration::from_millis(1);
        },
        &[Check::Schedule],
    );
    ok &= expect_flagged(
        "an alarm frame announcing the wrong leak",
        case,
        log,
        shared,
        expect,
        |log| wrong_verdict(log, case, expect.identity.node),
        &[Check::Content, Check::Verdict],
    );
    ok &= expect_flagged(
        "one LSI measurement skipped (2 s between two)",
        case,
        log,
        shared,
        expect,
        |log| {
            if let Some((lo, hi)) = log.lsi.gaps {
                log.lsi.gaps = Some((lo, hi * 2));
            }
            log.lsi.count -= 1;
        },
        &[Check::Diagnostics],
    );
    ok
}
