//! The CAN transmitter task (low priority): takes messages from the
//! outbox, most urgent first, encodes them (E2E counter and CRC) and
//! queues them for the bus. A write that finds every transmit buffer full
//! for [`TX_TIMEOUT`] — the bus is off, or no other node acknowledges —
//! is dropped and the stale frames still waiting are aborted, so the
//! task never hangs and the bus gets current data when it comes back.

use core::sync::atomic::Ordering;

use embassy_time::{with_timeout, Duration};
use monitor::protocol::{Encoder, Node};

use super::shared::Shared;
use crate::board::CanTransmit;

/// Longest wait for a free transmit buffer (about 80 frame times at
/// 500 kbit/s).
pub const TX_TIMEOUT: Duration = Duration::from_millis(20);

/// Run the transmitter for ever, with `node`'s identifiers.
pub async fn run<T: CanTransmit>(mut tx: T, node: Node, shared: &Shared) -> ! {
    let mut encoder = Encoder::for_node(node);
    let mut failing = false;
    loop {
        shared.wait_for_messages().await;
        shared.pass(super::supervisor::CAN_TX);
        while let Some(msg) = shared.take_next() {
            let frame = encoder.encode(&msg);
            match with_timeout(TX_TIMEOUT, tx.transmit(&frame)).await {
                Ok(Ok(displaced)) => {
                    shared.can.sent.fetch_add(1, Ordering::Relaxed);
                    // A waiting frame given up for this one is lost.
                    shared
                        .can
                        .dropped
                        .fetch_add(displaced as u32, Ordering::Relaxed);
                    if core::mem::take(&mut failing) {
                        defmt::info!("CAN: transmitting again");
                    }
                }
                Ok(Err(e)) => {
                    shared.can.dropped.fetch_add(1, Ordering::Relaxed);
                    defmt::warn!("CAN: frame {=u16:#x} rejected: {}", frame.id(), e);
                }
                Err(_timeout) => {
                    let aborted = tx.abort_pending() as u32;
                    shared.can.dropped.fetch_add(1 + aborted, Ordering::Relaxed);
                    if !core::mem::replace(&mut failing, true) {
                        defmt::warn!(
                            "CAN: no transmit buffer free for {} ms (bus off or no ACK): dropping frames",
                            TX_TIMEOUT.as_millis()
                        );
                    }
                }
            }
        }
    }
}
