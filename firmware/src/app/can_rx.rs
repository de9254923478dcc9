//! The CAN receiver task (low priority): the only frame acted on is the
//! command frame, and only when its E2E protection is intact and its
//! counter is not a repeat of the previous command's. Nothing received
//! can change a parameter.

use core::sync::atomic::Ordering;

use embassy_time::Timer;
use monitor::protocol::{CommandReceiver, CommandRejected};

use super::shared::Shared;
use crate::board::{CanReceive, CanRxError};

/// Run the receiver for ever.
pub async fn run<R: CanReceive>(mut rx: R, shared: &Shared) -> ! {
    let mut commands = CommandReceiver::new();
    loop {
        match rx.receive().await {
            Ok(frame) => match commands.receive(&frame) {
                Ok(command) => {
                    defmt::info!("CAN: command {}", command);
                    shared.commands.signal(command);
                }
                // Other traffic, if the hardware filter lets it through.
                Err(CommandRejected::NotACommand) => {}
                Err(e) => {
                    shared.can.rejected.fetch_add(1, Ordering::Relaxed);
                    defmt::warn!("CAN: command not acted on: {}", e);
                }
            },
            Err(CanRxError::Unsupported) => {}
            Err(CanRxError::Bus) => {
                shared.can.bus_errors.fetch_add(1, Ordering::Relaxed);
                // Errors can come back to back on a broken bus: do not spin.
                Timer::after_millis(1).await;
            }
        }
    }
}
