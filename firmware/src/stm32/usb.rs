//! The commissioning link's transport: USB CDC-ACM (a virtual serial
//! port) on the OTG FS core, PA11 (DM) / PA12 (DP), with embassy-usb.
//!
//! The USB device task ([`device`]) answers the host's enumeration and
//! control requests; [`UsbSerial`] is the board's `SerialPort` for the
//! link task. Both run in the low-priority thread executor; the OTG FS
//! interrupt runs below the estimator's executor, so USB traffic never
//! delays a sample.
//!
//! No VBUS sensing (PA9, OTG FS VBUS, is not in this board's pin map):
//! the device presents its D+ pull-up whether or not a host is there. The
//! USB specification wants a self-powered device to sense VBUS and drop
//! the pull-up without a host; with PA9 wired, set `vbus_detection`.

use embassy_futures::select::{select, Either};
use embassy_stm32::interrupt::{self, InterruptExt, Priority};
use embassy_stm32::peripherals::{PA11, PA12, USB_OTG_FS};
use embassy_stm32::usb::{self, Driver};
use embassy_stm32::{bind_interrupts, Peri};
use embassy_usb::class::cdc_acm::{CdcAcmClass, ControlChanged, Receiver, Sender, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::{Builder, UsbDevice};
use firmware::board::{Disconnected, SerialPort};
use static_cell::StaticCell;

/// USB vendor ID: a **test** ID (the one embassy's examples use), not
/// assigned to this product. A product needs its own VID/PID pair (from
/// the USB-IF, or a sublicensed PID from its silicon or tool vendor).
pub const TEST_VID: u16 = 0xc0de;
/// USB product ID: a **test** ID, see [`TEST_VID`].
pub const TEST_PID: u16 = 0xcafe;

/// Manufacturer string.
const MANUFACTURER: &str = "Leak monitor project";
/// Product string.
const PRODUCT: &str = "Hydraulic cylinder leak monitor";

/// Full-speed bulk packet size; the link task reads 64 bytes at a time.
const MAX_PACKET: usize = 64;

/// Priority of the OTG FS interrupt: below the estimator's executor
/// (P6), above thread mode. Its handler only moves packets between the
/// FIFOs and the endpoint buffers.
const USB_PRIORITY: Priority = Priority::P7;

bind_interrupts!(struct UsbIrqs {
    OTG_FS => usb::InterruptHandler<USB_OTG_FS>;
});

/// The OTG FS driver.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

static EP_OUT_BUFFER: StaticCell<[u8; 256]> = StaticCell::new();
static CONFIG_DESCRIPTOR: StaticCell<[u8; 256]> = StaticCell::new();
static BOS_DESCRIPTOR: StaticCell<[u8; 256]> = StaticCell::new();
static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
static CDC_STATE: StaticCell<State<'static>> = StaticCell::new();

/// Build the USB device (a CDC-ACM function) and its serial port;
/// `serial_number` is the USB serial number string (the chip's unique
/// ID). Run the device with [`device`]. Not inlined: the builder and its
/// results are kilobytes, built on the stack at boot.
#[inline(never)]
pub fn start(
    otg: Peri<'static, USB_OTG_FS>,
    dm: Peri<'static, PA11>,
    dp: Peri<'static, PA12>,
    serial_number: &'static str,
) -> (UsbDevice<'static, UsbDriver>, UsbSerial) {
    interrupt::OTG_FS.set_priority(USB_PRIORITY);
    let mut config = usb::Config::default();
    // Self-powered in the field, but PA9 (VBUS) is not in the pin map:
    // see the module's documentation.
    config.vbus_detection = false;
    let driver = Driver::new_fs(otg, UsbIrqs, dp, dm, EP_OUT_BUFFER.init([0; 256]), config);

    let mut config = embassy_usb::Config::new(TEST_VID, TEST_PID);
    config.manufacturer = Some(MANUFACTURER);
    config.product = Some(PRODUCT);
    config.serial_number = Some(serial_number);
    config.max_packet_size_0 = MAX_PACKET as u8;

    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESCRIPTOR.init([0; 256]),
        BOS_DESCRIPTOR.init([0; 256]),
        &mut [], // no Microsoft OS descriptors
        CONTROL_BUF.init([0; 64]),
    );
    let class = CdcAcmClass::new(
        &mut builder,
        CDC_STATE.init(State::new()),
        MAX_PACKET as u16,
    );
    let (tx, rx, control) = class.split_with_control();
    let port = UsbSerial {
        tx,
        rx,
        control,
        pending: [0; MAX_PACKET],
        start: 0,
        end: 0,
    };
    (builder.build(), port)
}

/// The USB device task: enumeration, control requests, bus events.
#[embassy_executor::task]
pub async fn device(mut usb: UsbDevice<'static, UsbDriver>) -> ! {
    usb.run().await
}

/// The CDC-ACM data interface as the link's serial port.
///
/// A host counts as connected while the interface is configured and the
/// host holds DTR (a terminal or the host tool has the port open): bytes
/// written to a port nobody has open would only fill the IN endpoint.
pub struct UsbSerial {
    tx: Sender<'static, UsbDriver>,
    rx: Receiver<'static, UsbDriver>,
    control: ControlChanged<'static>,
    /// A packet read for a caller whose buffer was shorter than a packet:
    /// `pending[start..end]` is still to be handed out.
    pending: [u8; MAX_PACKET],
    start: usize,
    end: usize,
}

/// Wait until the host drops DTR (closes the port).
async fn dtr_dropped(control: &ControlChanged<'static>) {
    while control.dtr() {
        control.control_changed().await;
    }
}

/// Every endpoint error ends the session: `Disabled` is the host gone
/// (unplugged, bus reset, deconfigured); `BufferOverflow` cannot happen
/// (reads take whole packets, writes at most one packet).
fn disconnected(_: EndpointError) -> Disconnected {
    Disconnected
}

impl SerialPort for UsbSerial {
    async fn wait_connected(&mut self) {
        loop {
            self.rx.wait_connection().await;
            if self.control.dtr() {
                // A new session: nothing of the last one is handed out.
                self.start = 0;
                self.end = 0;
                return;
            }
            self.control.control_changed().await;
        }
    }

    /// Cancel-safe: a packet is taken out of the endpoint only in the poll
    /// that completes the read (embassy-usb-synopsys-otg copies it and
    /// frees the endpoint buffer in the same poll), and `pending` changes
    /// only in polls that return.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Disconnected> {
        if buf.is_empty() {
            return Ok(0);
        }
        if self.start < self.end {
            let n = (self.end - self.start).min(buf.len());
            buf[..n].copy_from_slice(&self.pending[self.start..self.start + n]);
            self.start += n;
            return Ok(n);
        }
        let control = &self.control;
        loop {
            let read = if buf.len() >= MAX_PACKET {
                match select(self.rx.read_packet(buf), dtr_dropped(control)).await {
                    Either::First(read) => read.map_err(disconnected)?,
                    Either::Second(()) => return Err(Disconnected),
                }
            } else {
                let n = match select(self.rx.read_packet(&mut self.pending), dtr_dropped(control))
                    .await
                {
                    Either::First(read) => read.map_err(disconnected)?,
                    Either::Second(()) => return Err(Disconnected),
                };
                let taken = n.min(buf.len());
                buf[..taken].copy_from_slice(&self.pending[..taken]);
                self.start = taken;
                self.end = n;
                taken
            };
            // A zero-length packet carries nothing: wait for the next one.
            if read > 0 {
                return Ok(read);
            }
        }
    }

    /// Whole packets of 64 bytes, and a zero-length packet after a last
    /// packet of exactly 64 bytes, so the host's read completes without
    /// waiting for more data.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), Disconnected> {
        for packet in bytes.chunks(MAX_PACKET) {
            self.tx.write_packet(packet).await.map_err(disconnected)?;
        }
        if !bytes.is_empty() && bytes.len().is_multiple_of(MAX_PACKET) {
            self.tx.write_packet(&[]).await.map_err(disconnected)?;
        }
        Ok(())
    }
}
