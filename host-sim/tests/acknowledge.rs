//! Acknowledge floods during real leaks: a controller holding the key
//! answers every challenge it is shown, every 1 s, 100 ms or 1 ms, through
//! the device's acknowledge path (`protocol::gate::AckGate` → the monitor's
//! latch and acknowledge policy → `device::alarm::AlarmOutput`, in the
//! order `device::Estimator` runs them). The fail-safe relay's energised
//! time is measured from the first alarm on: it must be zero. The same
//! floods with the policy's times set to zero (what the firmware did before
//! the policy: every acknowledge accepted at once, the relay back with the
//! next healthy verdict) are accepted many times more. They energised the
//! relay for 46–94 % of the time after the alarm until the healthy claim
//! needed every reported leak size below the alarm level (`8f62a4a`); now
//! they keep it off too (the leak is still reported after each accepted
//! acknowledge), and the policy's own tests (`decision::acknowledge`) show
//! what it holds back.
//!
//! The one window documented in `docs/acknowledge.md` (the relay follows
//! the monitor's own `healthy` before it first detects the leak) is
//! measured separately and is the same with and without a flood.

use std::path::Path;

use host_sim::sim::{Profile, Rig, Scenario, Simulation};
use monitor::acknowledge::{AckRejected, AckResult, AckTiming};
use monitor::device::alarm::AlarmOutput;
use monitor::protocol::auth::{acknowledge_frame, AckKey};
use monitor::protocol::gate::{AckGate, GateOutcome};
use monitor::protocol::Command;
use monitor::status::health;
use monitor::{AckOutcome, Event, Monitor, Params, Sample};

fn key() -> AckKey {
    AckKey::installation(*b"rig-21-ack-key-!")
}

/// What one run measured.
#[derive(Debug, Default)]
struct Report {
    /// Samples from the first alarm on, and how many had the relay
    /// energised.
    after_alarm: usize,
    energised_after_alarm: usize,
    /// Samples before the first alarm with the relay energised (the
    /// monitor's own healthy verdict: the documented window).
    energised_before_alarm: usize,
    first_alarm_ms: Option<u64>,
    /// Acknowledge attempts the controller made, and the events they gave.
    attempts: usize,
    events: Vec<(u64, AckResult)>,
    /// A repeated acknowledge inside the evidence period changed nothing.
    evidence_pending_checked: usize,
}

impl Report {
    fn fraction(&self) -> f64 {
        self.energised_after_alarm as f64 / self.after_alarm.max(1) as f64
    }

    fn count(&self, r: AckResult) -> usize {
        self.events.iter().filter(|(_, o)| *o == r).count()
    }
}

/// Run `samples` (period `period_s`) through the device's sequence with a
/// controller acknowledging every `every_ms` (none: no acknowledge), with
/// the acknowledge policy's `timing` (none: the documented one).
fn run(
    samples: impl Iterator<Item = Sample>,
    period_s: f64,
    every_ms: Option<u64>,
    timing: Option<AckTiming>,
) -> Report {
    let params = Params::nominal();
    let mut monitor: Monitor<f32> = Monitor::new(&params).expect("nominal parameters");
    if let Some(t) = timing {
        monitor = monitor.with_ack_timing(t);
    }
    let mut gate = AckGate::new(&key(), 0x5EED, 0);
    let mut raised = 0u32;
    let mut counter = 0u8;
    let mut pending: Option<Command> = None;
    let mut r = Report::default();
    let period_ms = (period_s * 1000.0).round() as u64;
    for (k, sample) in samples.enumerate() {
        let t_ms = k as u64 * period_ms;
        // The estimator: the command received since the last block, then
        // the sample (`device::Estimator::on_block`).
        if let Some(Command::AcknowledgeAlarm) = pending.take() {
            let before = monitor.clone();
            let outcome = monitor.acknowledge();
            if outcome == AckOutcome::Refused(AckRejected::EvidencePending) {
                // Nothing changed: the same monitor gives the same status.
                let mut a = before;
                let mut b = monitor.clone();
                assert_eq!(a.step(&sample), b.step(&sample), "at {t_ms} ms");
                r.evidence_pending_checked += 1;
            }
            r.events.push((t_ms, outcome.result()));
        }
        let status = monitor.step(&sample);
        for e in &status.events {
            if let Event::AlarmRaised(_) = e {
                raised += 1;
                r.first_alarm_ms.get_or_insert(t_ms);
            }
        }
        let relay = AlarmOutput::of(&status, false).relay_energised();
        if status.health & health::ACK_EVIDENCE != 0 {
            assert!(!relay, "relay on during the evidence period at {t_ms} ms");
        }
        if r.first_alarm_ms.is_some() {
            r.after_alarm += 1;
            r.energised_after_alarm += relay as usize;
        } else {
            r.energised_before_alarm += relay as usize;
        }
        // The CAN receive task: renew the challenge on a raised alarm; the
        // controller reads it and answers.
        gate.alarms_raised(raised, t_ms);
        if every_ms.is_some_and(|e| t_ms.is_multiple_of(e)) {
            let frame = acknowledge_frame(&key(), gate.challenges().current, counter);
            counter = (counter + 1) % 15;
            r.attempts += 1;
            match gate.receive(&frame, t_ms, t_ms) {
                GateOutcome::Authentic(a) => pending = Some(a.command),
                GateOutcome::Rejected(e) => r.events.push((e.t_ms, e.outcome)),
                GateOutcome::NotACommand => unreachable!("a command frame"),
            }
        }
    }
    r
}

fn recording(name: &str) -> (Vec<Sample>, f64) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name);
    let (samples, period) = host_sim::read_all(&path).expect("example recording");
    (samples, period.expect("sample period"))
}

const ZERO: AckTiming = AckTiming {
    hold_off_ms: 0,
    min_interval_ms: 0,
    evidence_ms: 0,
};

#[test]
fn acknowledge_floods_during_a_recorded_leak_never_energise_the_relay() {
    // examples/internal.csv.gz: 0.4 l/min across the piston seal from the
    // first sample, 18 s.
    let (samples, period) = recording("internal.csv.gz");
    let quiet = run(samples.iter().copied(), period, None, None);
    let first = quiet.first_alarm_ms.expect("the leak is detected");
    println!(
        "no acknowledge: alarm at {first} ms; relay energised {} ms before it (the documented window), {:.1} % after",
        quiet.energised_before_alarm,
        100.0 * quiet.fraction()
    );
    assert_eq!(quiet.energised_after_alarm, 0);
    for every_ms in [1000, 100, 1] {
        let policy = run(samples.iter().copied(), period, Some(every_ms), None);
        let before = run(samples.iter().copied(), period, Some(every_ms), Some(ZERO));
        println!(
            "acknowledge every {every_ms} ms: relay energised {:.1} % of the {} ms after the alarm \
             (without the policy: {:.1} %); {} attempts, {} accepted, {} hold_off, {} rate_limited, \
             {} evidence_pending, {} busy, {} nothing_latched",
            100.0 * policy.fraction(),
            policy.after_alarm,
            100.0 * before.fraction(),
            policy.attempts,
            policy.count(AckResult::Accepted),
            policy.count(AckResult::Rejected(AckRejected::HoldOff)),
            policy.count(AckResult::Rejected(AckRejected::RateLimited)),
            policy.count(AckResult::Rejected(AckRejected::EvidencePending)),
            policy.count(AckResult::Rejected(AckRejected::Busy)),
            policy.count(AckResult::Rejected(AckRejected::NothingLatched)),
        );
        assert_eq!(policy.first_alarm_ms, Some(first));
        assert_eq!(
            policy.energised_after_alarm, 0,
            "relay energised after the alarm with acknowledges every {every_ms} ms"
        );
        // The documented window only: the same as without acknowledges.
        assert_eq!(policy.energised_before_alarm, quiet.energised_before_alarm);
        // Without the policy every acknowledge is accepted at once (so
        // the policy is what holds them back) — and the relay stays off
        // all the same: after each, the leak is still reported above its
        // alarm level, and the monitor claims no `healthy`.
        assert!(
            before.count(AckResult::Accepted) > policy.count(AckResult::Accepted),
            "without the policy the flood every {every_ms} ms should be accepted more often"
        );
        assert_eq!(before.energised_after_alarm, 0);
        // Every attempt is one event.
        assert_eq!(policy.events.len(), policy.attempts);
        assert!(policy.count(AckResult::Rejected(AckRejected::HoldOff)) > 0);
    }
}

#[test]
fn acknowledge_floods_during_a_long_simulated_leak_never_energise_the_relay() {
    // 150 s with an internal leak of 0.4 l/min from 5 s: several accepted
    // acknowledges, each followed by the leak raised again.
    let scenario = Scenario {
        duration_s: 150.0,
        supply_bar: 50.0,
        internal_lpm: 0.4,
        leak_onset_s: 5.0,
        seed: 31,
        profile: Profile::Thesis,
        ..Scenario::default()
    };
    let samples: Vec<Sample> = Simulation::new(scenario, Rig::reference())
        .map(Sample::from)
        .collect();
    for every_ms in [1000, 100, 1] {
        let policy = run(samples.iter().copied(), 0.001, Some(every_ms), None);
        let before = run(samples.iter().copied(), 0.001, Some(every_ms), Some(ZERO));
        let accepted: Vec<u64> = policy
            .events
            .iter()
            .filter(|(_, o)| *o == AckResult::Accepted)
            .map(|(t, _)| *t)
            .collect();
        println!(
            "simulated leak, acknowledge every {every_ms} ms: alarm at {:?} ms, relay energised {:.1} % after it \
             (without the policy {:.1} %), before it {} ms; accepted at {accepted:?}; {} repeated acknowledges \
             inside the evidence period changed nothing",
            policy.first_alarm_ms,
            100.0 * policy.fraction(),
            100.0 * before.fraction(),
            policy.energised_before_alarm,
            policy.evidence_pending_checked,
        );
        assert_eq!(policy.energised_after_alarm, 0);
        assert!(before.count(AckResult::Accepted) > accepted.len());
        assert_eq!(before.energised_after_alarm, 0);
        assert!(accepted.len() >= 2, "accepted {accepted:?}");
        assert!(accepted.windows(2).all(|w| w[1] - w[0] >= 60_000));
        assert!(accepted[0] >= policy.first_alarm_ms.unwrap() + 10_000);
        if every_ms <= 100 {
            // Faster than the leak is raised again: acknowledges arrive
            // inside the evidence period, and change nothing.
            assert!(policy.evidence_pending_checked > 0);
        }
        assert_eq!(policy.events.len(), policy.attempts);
    }
}
