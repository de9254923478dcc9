//! The commissioning link task (low priority): the `link` crate's device
//! end on the board's serial port. It answers the host's commands (the
//! identity, the parameter upload and read-back, the event memory),
//! forwards the sample blocks the estimator built, and stores the events
//! the estimator reported. Parameters change only here, never over CAN.
//!
//! Flash: an upload stores the set out of service (the monitor restarts
//! on it, so its filters warm up and the relay stays off meanwhile); an
//! event is written in service only where no page erase is needed
//! (`link::storage::Erase`).

use embassy_futures::select::{select3, Either3};
use embassy_time::{with_timeout, Duration, Instant};
use embedded_storage_async::nor_flash::NorFlash;
use link::frame::{encode, Decoder, MAX_WIRE};
use link::{Device, Loaded, Message};
use monitor::protocol::{IdentityFrame, Node};
use monitor::Monitor;

use super::shared::Shared;
use crate::board::{Disconnected, SerialPort};

/// The longest a write to the host may take before the host counts as
/// gone (a USB host that stopped reading, a closed terminal).
const WRITE_TIMEOUT: Duration = Duration::from_millis(200);

/// Bytes read from the port at a time.
const READ_CHUNK: usize = 64;

/// The `LM_Identity` frame of the set `loaded` on `node`.
pub fn identity_frame(node: Node, loaded: &Loaded) -> IdentityFrame {
    IdentityFrame {
        node,
        params_crc: loaded.id.crc,
        // The frame carries the version counter's low 16 bits.
        params_version: loaded.id.version as u16,
    }
}

/// Milliseconds since boot, as the event memory stamps events.
pub fn uptime_ms() -> u32 {
    Instant::now().as_millis() as u32
}

/// Run the link for ever. `node` is the node the CAN tasks run on (read
/// at boot: a new node number in an upload takes effect at the next
/// reset).
pub async fn run<S: SerialPort, P: NorFlash, E: NorFlash>(
    mut port: S,
    device: &mut Device<P, E>,
    node: Node,
    shared: &Shared,
) -> ! {
    let mut decoder = Decoder::new();
    let mut rx = [0u8; READ_CHUNK];
    let mut tx = [0u8; MAX_WIRE];
    loop {
        port.wait_connected().await;
        decoder.reset();
        // A session ends when the host goes away: streaming stops.
        let _ = session(
            &mut port,
            device,
            node,
            shared,
            &mut decoder,
            &mut rx,
            &mut tx,
        )
        .await;
        shared.stream.set_streaming(false);
    }
}

async fn session<S: SerialPort, P: NorFlash, E: NorFlash>(
    port: &mut S,
    device: &mut Device<P, E>,
    node: Node,
    shared: &Shared,
    decoder: &mut Decoder,
    rx: &mut [u8; READ_CHUNK],
    tx: &mut [u8; MAX_WIRE],
) -> Result<(), Disconnected> {
    loop {
        match select3(
            port.read(rx),
            shared.stream.next_block(),
            shared.next_memory(),
        )
        .await
        {
            Either3::First(read) => {
                let n = read?;
                for &byte in &rx[..n] {
                    // Damaged frames are dropped (the host repeats).
                    let Some(Ok(frame)) = decoder.push(byte) else {
                        continue;
                    };
                    let (completed, dropped) = shared.stream.progress();
                    device.stream_progress(completed, dropped);
                    let len = device.handle(&frame, uptime_ms(), tx).await;
                    // A start (again) begins a new stream; a stop ends it.
                    if matches!(frame.msg, Message::StartStream | Message::StopStream) {
                        shared.stream.set_streaming(device.streaming());
                    }
                    if device.take_changed() {
                        restart_monitor(device.params(), node, shared);
                    }
                    write(port, &tx[..len]).await?;
                }
            }
            Either3::Second(block) => {
                let Ok(len) = encode(block.seq as u16, &Message::Block(block), tx) else {
                    shared.stream.lost();
                    continue;
                };
                if write(port, &tx[..len]).await.is_err() {
                    shared.stream.lost();
                    return Err(Disconnected);
                }
            }
            Either3::Third((uptime_ms, kind)) => {
                // A flash failure or a full RAM queue is counted by the
                // device (`Device::pending_events`); nothing else to do.
                let _ = device.log(uptime_ms, kind).await;
            }
        }
    }
}

/// How long the link task waits for the estimator to take a new monitor
/// (it takes it at its next block, within 1 ms, unless it stalled).
const SWAP_TIMEOUT: Duration = Duration::from_millis(100);

/// Build the monitor on the set now active (here, not in the estimator:
/// see `Shared::lend_monitor`) and have the estimator restart on it.
/// Not inlined: the monitor lives in this frame, on the stack, only
/// while it is lent.
#[inline(never)]
fn restart_monitor(loaded: &Loaded, node: Node, shared: &Shared) {
    // The device validated the set, as `Monitor::new` does again.
    let Ok(mut monitor) = Monitor::new(&loaded.params) else {
        return;
    };
    let until = Instant::now() + SWAP_TIMEOUT;
    if !shared.lend_monitor(&mut monitor, identity_frame(node, loaded), || {
        Instant::now() > until
    }) {
        defmt::warn!("the estimator did not take the new parameter set's monitor");
    }
}

async fn write<S: SerialPort>(port: &mut S, bytes: &[u8]) -> Result<(), Disconnected> {
    with_timeout(WRITE_TIMEOUT, port.write_all(bytes))
        .await
        .unwrap_or(Err(Disconnected))
}
