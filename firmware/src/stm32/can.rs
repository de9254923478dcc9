//! bxCAN1 at 500 kbit/s on PB8/PB9. Receive filter: the node's command
//! frame only. Automatic bus-off recovery is on (embassy sets ABOM), automatic
//! retransmission too: a frame nobody acknowledges stays in its mailbox
//! until the application's timeout aborts it.

use embassy_stm32::can::filter::Mask32;
use embassy_stm32::can::util::calc_can_timings;
use embassy_stm32::can::{
    Can, CanRx, CanTx, Fifo, Frame, Id, Mailbox, Rx0InterruptHandler, Rx1InterruptHandler,
    SceInterruptHandler, StandardId, TxInterruptHandler,
};
use embassy_stm32::peripherals::{CAN1, PB8, PB9};
use embassy_stm32::rcc::frequency;
use embassy_stm32::{bind_interrupts, Peri};
use embassy_time::{with_timeout, Duration};
use monitor::protocol::{CanFrame, MessageKind, Node, BITRATE_BPS};
use static_cell::StaticCell;

use firmware::board::{CanReceive, CanRxError, CanTransmit, CanTxError};

bind_interrupts!(struct Irqs {
    CAN1_RX0 => Rx0InterruptHandler<CAN1>;
    CAN1_RX1 => Rx1InterruptHandler<CAN1>;
    CAN1_SCE => SceInterruptHandler<CAN1>;
    CAN1_TX => TxInterruptHandler<CAN1>;
});

/// The driver lives for ever (dropping it would reset the controller).
static CAN: StaticCell<Can<'static>> = StaticCell::new();

/// Set up CAN1 for `node`'s command frame and wait for the bus to be
/// idle; returns the two halves.
pub async fn start(
    can: Peri<'static, CAN1>,
    rx: Peri<'static, PB8>,
    tx: Peri<'static, PB9>,
    node: Node,
) -> (Transmitter, Receiver) {
    let can = CAN.init(Can::new(can, rx, tx, Irqs));
    let command = StandardId::new(MessageKind::Command.id_at(node)).unwrap_or(StandardId::ZERO);
    can.modify_filters().enable_bank(
        0,
        Fifo::Fifo0,
        Mask32::frames_with_std_id(command, StandardId::MAX),
    );
    // The timing computed here rather than by `set_bitrate`, whose
    // `unwrap` links the whole `core::fmt` machinery (≈ 5 KB) for its
    // error's `Debug`.
    let timing = match calc_can_timings(frequency::<CAN1>(), BITRATE_BPS) {
        Ok(t) => t,
        Err(_) => defmt::panic!("CAN: no bit timing for {=u32} bit/s", BITRATE_BPS),
    };
    can.modify_config().set_bit_timing(timing);
    // Joining needs 11 recessive bits: a missing transceiver or a bus held
    // dominant keeps CAN (only CAN) waiting here.
    if with_timeout(Duration::from_secs(1), can.enable())
        .await
        .is_err()
    {
        defmt::warn!("CAN: bus not idle after 1 s (transceiver? termination?), still waiting");
        can.enable().await;
    }
    let (tx, rx) = can.split();
    (Transmitter(tx), Receiver(rx))
}

/// The transmitting half.
pub struct Transmitter(CanTx<'static>);

impl CanTransmit for Transmitter {
    async fn transmit(&mut self, frame: &CanFrame) -> Result<u8, CanTxError> {
        let id = StandardId::new(frame.id()).ok_or(CanTxError::Rejected)?;
        let f = Frame::new_data(id, frame.data()).map_err(|_| CanTxError::Rejected)?;
        let status = self.0.write(&f).await;
        Ok(status.dequeued_frame().is_some() as u8)
    }

    fn abort_pending(&mut self) -> u8 {
        [Mailbox::Mailbox0, Mailbox::Mailbox1, Mailbox::Mailbox2]
            .into_iter()
            .filter(|&mb| self.0.abort(mb))
            .count() as u8
    }
}

/// The receiving half.
pub struct Receiver(CanRx<'static>);

impl CanReceive for Receiver {
    async fn receive(&mut self) -> Result<CanFrame, CanRxError> {
        let envelope = self.0.read().await.map_err(|_| CanRxError::Bus)?;
        let f = envelope.frame;
        match *f.id() {
            Id::Standard(id) if !f.header().rtr() => {
                CanFrame::new(id.as_raw(), f.data()).ok_or(CanRxError::Unsupported)
            }
            _ => Err(CanRxError::Unsupported),
        }
    }
}
