//! The CAN receiver task (low priority): the only frame acted on is the
//! command frame, and only when its E2E protection is intact and its
//! counter is not a repeat of the previous command's. Nothing received
//! can change a parameter.

use core::sync::atomic::Ordering;

use embassy_time::Timer;
use monitor::protocol::{Decoder, Message, MessageKind, Received, Sequence};

use super::shared::Shared;
use crate::board::{CanReceive, CanRxError};

/// Run the receiver for ever.
pub async fn run<R: CanReceive>(mut rx: R, shared: &Shared) -> ! {
    let mut decoder = Decoder::new();
    loop {
        match rx.receive().await {
            Ok(frame) if frame.id() == MessageKind::Command.id() => match decoder.decode(&frame) {
                Ok(Received {
                    message: Message::Command(c),
                    sequence,
                    counter,
                }) if sequence != Sequence::Repeated => {
                    defmt::info!("CAN: command {} (counter {})", c.command, counter);
                    shared.commands.signal(c.command);
                }
                Ok(r) => {
                    shared.can.rejected.fetch_add(1, Ordering::Relaxed);
                    defmt::warn!("CAN: repeated command ignored (counter {})", r.counter);
                }
                Err(e) => {
                    shared.can.rejected.fetch_add(1, Ordering::Relaxed);
                    defmt::warn!("CAN: command rejected: {}", e);
                }
            },
            // Other traffic, if the hardware filter lets it through.
            Ok(_) | Err(CanRxError::Unsupported) => {}
            Err(CanRxError::Bus) => {
                shared.can.bus_errors.fetch_add(1, Ordering::Relaxed);
                // Errors can come back to back on a broken bus: do not spin.
                Timer::after_millis(1).await;
            }
        }
    }
}
