//! RAM the device end needs (the firmware's budget is 48 KiB in all): the
//! `Device` itself and the state of its futures, which live on the serial
//! task's stack or in its task arena. Sizes on the host are those of the
//! target up to pointer width (the buffers dominate).

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use link::frame::{Decoder, Frame, MAX_WIRE};
use link::{Device, Message, Storage};

struct Nothing;
#[derive(Debug)]
struct E;
impl NorFlashError for E {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}
impl ErrorType for Nothing {
    type Error = E;
}
impl ReadNorFlash for Nothing {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, _: u32, _: &mut [u8]) -> Result<(), E> {
        Err(E)
    }
    fn capacity(&self) -> usize {
        0
    }
}
impl NorFlash for Nothing {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 16384;
    async fn erase(&mut self, _: u32, _: u32) -> Result<(), E> {
        Err(E)
    }
    async fn write(&mut self, _: u32, _: &[u8]) -> Result<(), E> {
        Err(E)
    }
}

#[test]
fn device_ram() {
    type D = Device<Nothing, Nothing>;
    let storage = core::mem::size_of::<Storage<Nothing, Nothing>>();
    let device = core::mem::size_of::<D>();
    let decoder = core::mem::size_of::<Decoder>();
    let mut dev = embassy_futures::block_on(Device::start(
        Storage::new(Nothing, 0..32768, Nothing, 0..16384),
        link::DeviceInfo {
            firmware: "x",
            serial: heapless::String::new(),
            period_us: 1000,
        },
        &monitor::Params::NOMINAL,
        link::ResetCause::PowerOn,
    ));
    let frame = Frame {
        seq: 0,
        msg: Message::ParamsCommit,
    };
    let mut out = [0u8; MAX_WIRE];
    let handle = core::mem::size_of_val(&dev.handle(&frame, 0, &mut out));
    eprintln!(
        "RAM: Device {device} B (of which Storage {storage} B), Decoder {decoder} B, tx buffer {MAX_WIRE} B, Device::handle future {handle} B"
    );
    assert!(device + decoder + MAX_WIRE + handle < 16 * 1024);
}
