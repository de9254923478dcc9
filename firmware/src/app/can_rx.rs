//! The CAN receiver task (low priority), owner of the acknowledge
//! challenge. The only frame acted on is the command frame, and only when
//! it passes every check of `CommandReceiver` (E2E P01 with its state
//! machine, a bounded rate of tag checks, and the truncated HMAC over the
//! current challenge; `docs/acknowledge.md`). Nothing received can change
//! a parameter.
//!
//! The challenge and the checks are `monitor::protocol::gate::AckGate`:
//! the challenge (`LM_Challenge`, sent at once when it changes and every
//! second) is seeded at boot by the caller (the STM32's RNG) and replaced
//! after every frame with a right tag (each answer is good once, whether
//! the acknowledge policy then accepts it or not), when the estimator
//! raises an alarm, and when it expires. The tag check runs here, never in
//! the estimator's millisecond; the estimator gets only authentic
//! commands and applies the acknowledge policy.

use core::sync::atomic::Ordering;

use embassy_futures::select::{select3, Either3};
use embassy_time::{Duration, Instant, Timer};
use monitor::protocol::auth::KeyKind;
use monitor::protocol::gate::{AckGate, GateOutcome};
use monitor::protocol::{ChallengeFrame, Message, Node};

use super::shared::Shared;
use crate::board::{CanReceive, CanRxError};

/// The challenge frame's refresh period.
pub const CHALLENGE_PERIOD: Duration = Duration::from_millis(1000);

/// Run the receiver for ever, for `node`'s command frame. `seed`: differs
/// at every boot (hardware RNG): the challenges of this boot are derived
/// from it.
pub async fn run<R: CanReceive>(mut rx: R, node: Node, shared: &Shared, seed: u64) -> ! {
    let now_ms = Instant::now().as_millis();
    let mut gate = AckGate::for_node(&crate::ack_key::ACK_KEY, node, seed, now_ms);
    if gate.key_kind() == KeyKind::Development {
        defmt::warn!("CAN: acknowledges are checked with the PUBLIC development key");
    }
    let mut sent: Option<ChallengeFrame> = None;
    let mut refresh_at = Instant::now();
    loop {
        let now_ms = Instant::now().as_millis();
        // A response computed before an alarm must not clear it.
        gate.alarms_raised(shared.ack.raised.load(Ordering::Acquire), now_ms);
        gate.tick(now_ms);
        let frame = gate.frame(
            shared.ack.last(),
            shared.ack.attempts.load(Ordering::Relaxed),
        );
        if sent != Some(frame) || Instant::now() >= refresh_at {
            shared.post(Message::Challenge(frame));
            sent = Some(frame);
            refresh_at = Instant::now() + CHALLENGE_PERIOD;
        }
        // Wake for a frame, for an attempt or alarm the estimator
        // recorded (publish at once), or for the refresh. The board's
        // receive future may be dropped: it is cancel-safe (a frame is
        // taken only when it is returned).
        let received = match select3(
            rx.receive(),
            shared.ack.changed.wait(),
            Timer::at(refresh_at),
        )
        .await
        {
            Either3::First(received) => received,
            Either3::Second(()) | Either3::Third(()) => continue,
        };
        match received {
            Ok(frame) => {
                let now_ms = Instant::now().as_millis();
                let t_ms = shared.sample_clock_ms(now_ms) as u64;
                // An alarm raised since the loop last looked renews the
                // challenge before this frame is checked against it.
                gate.alarms_raised(shared.ack.raised.load(Ordering::Acquire), now_ms);
                match gate.receive(&frame, now_ms, t_ms) {
                    GateOutcome::Authentic(authentic) => {
                        defmt::info!("CAN: authentic command {}", authentic.command);
                        shared.commands.signal(authentic.command);
                    }
                    GateOutcome::Rejected(event) => {
                        shared.can.rejected.fetch_add(1, Ordering::Relaxed);
                        shared.ack_attempt(event);
                    }
                    // Other traffic, if the hardware filter lets it through.
                    GateOutcome::NotACommand => {}
                }
            }
            Err(CanRxError::Unsupported) => {}
            Err(CanRxError::Bus) => {
                shared.can.bus_errors.fetch_add(1, Ordering::Relaxed);
                // Errors can come back to back on a broken bus: do not spin.
                Timer::after_millis(1).await;
            }
        }
    }
}
