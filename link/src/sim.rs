//! A simulated device in a thread: the same [`Device`] and storage as the
//! firmware, on RAM flash, speaking the protocol over an in-process byte
//! pipe ([`SimPort`]). Host tools are tested end to end with it.

use crate::device::{Device, DeviceInfo};
use crate::frame::{encode, Decoder, MAX_WIRE};
use crate::message::{Message, ResetCause};
use crate::ram_flash::RamFlash;
use crate::storage::Storage;
use monitor::{Params, Sample};
use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, SyncSender};
use std::thread::JoinHandle;
use std::time::Duration;

/// Erase page of the simulated flash: a 16 KiB sector of the STM32F405.
pub const SIM_PAGE: usize = 16 * 1024;
/// The simulated flash.
pub type SimFlash = RamFlash<SIM_PAGE>;

/// Where the samples come from: called with the sample counter, `None`
/// when there are no more.
pub type Source = Box<dyn FnMut(u32) -> Option<Sample> + Send>;

/// How the simulated device behaves.
pub struct SimConfig {
    /// Firmware version it reports.
    pub firmware: &'static str,
    /// Serial number it reports.
    pub serial: String,
    /// Sample period, µs.
    pub period_us: u32,
    /// Its samples.
    pub source: Source,
    /// Keep the flash in this file (two images, parameters then events),
    /// so that successive connections see the same device.
    pub state: Option<PathBuf>,
    /// Drop every n-th block at the device, as when the host is slow.
    pub drop_every: Option<u32>,
    /// Corrupt one byte of every n-th block frame on the wire.
    pub corrupt_every: Option<u32>,
    /// The compiled-in default parameters.
    pub default: Params,
}

/// The host's end of the pipe to a simulated device.
pub struct SimPort {
    to_dev: Option<Sender<Vec<u8>>>,
    from_dev: Receiver<Vec<u8>>,
    pending: Vec<u8>,
    pos: usize,
    /// Read timeout.
    pub timeout: Duration,
    thread: Option<JoinHandle<()>>,
}

impl Read for SimPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pos >= self.pending.len() {
            match self.from_dev.recv_timeout(self.timeout) {
                Ok(v) => {
                    self.pending = v;
                    self.pos = 0;
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(io::Error::new(io::ErrorKind::TimedOut, "timeout"))
                }
                Err(RecvTimeoutError::Disconnected) => return Ok(0),
            }
        }
        let n = buf.len().min(self.pending.len() - self.pos);
        buf[..n].copy_from_slice(&self.pending[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let tx = self.to_dev.as_ref().ok_or(io::ErrorKind::BrokenPipe)?;
        tx.send(buf.to_vec())
            .map_err(|_| io::Error::from(io::ErrorKind::BrokenPipe))?;
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Drop for SimPort {
    fn drop(&mut self) {
        // Closing both ends stops the device (also one blocked sending to
        // us), which then saves its flash.
        self.to_dev = None;
        let (_, closed) = mpsc::sync_channel(1);
        drop(std::mem::replace(&mut self.from_dev, closed));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn load_state(path: &Option<PathBuf>) -> (SimFlash, SimFlash) {
    let fresh = || (SimFlash::new(2), SimFlash::new(2));
    let Some(path) = path else { return fresh() };
    match std::fs::read(path) {
        Ok(bytes) if bytes.len() == 4 * SIM_PAGE => {
            let (p, e) = bytes.split_at(2 * SIM_PAGE);
            (
                SimFlash::from_bytes(p.to_vec()),
                SimFlash::from_bytes(e.to_vec()),
            )
        }
        _ => fresh(),
    }
}

/// Start a simulated device (it boots: reset event, boot counter).
pub fn spawn(mut cfg: SimConfig) -> io::Result<SimPort> {
    let (to_dev, dev_rx) = mpsc::channel::<Vec<u8>>();
    let (dev_tx, from_dev) = mpsc::sync_channel::<Vec<u8>>(1024);
    let (pf, ef) = load_state(&cfg.state);
    let thread = std::thread::Builder::new()
        .name("sim-device".into())
        .spawn(move || {
            let storage = Storage::new(pf, 0..2 * SIM_PAGE as u32, ef, 0..2 * SIM_PAGE as u32);
            let info = DeviceInfo {
                firmware: cfg.firmware,
                serial: heapless::String::try_from(cfg.serial.as_str()).unwrap_or_default(),
                period_us: cfg.period_us,
            };
            let dev = embassy_futures::block_on(Device::start(
                storage,
                info,
                &cfg.default,
                ResetCause::PowerOn,
            ));
            let dev = run(dev, &mut cfg, &dev_rx, &dev_tx);
            if let Some(path) = &cfg.state {
                let (p, e) = dev.into_storage().into_flash();
                let mut bytes = p.as_bytes().to_vec();
                bytes.extend_from_slice(e.as_bytes());
                let _ = std::fs::write(path, bytes);
            }
        })?;
    Ok(SimPort {
        to_dev: Some(to_dev),
        from_dev,
        pending: Vec::new(),
        pos: 0,
        timeout: Duration::from_millis(50),
        thread: Some(thread),
    })
}

type SimDevice = Device<SimFlash, SimFlash>;

fn run(
    mut dev: SimDevice,
    cfg: &mut SimConfig,
    rx: &Receiver<Vec<u8>>,
    tx: &SyncSender<Vec<u8>>,
) -> SimDevice {
    let mut dec = Decoder::new();
    let mut out = [0u8; MAX_WIRE];
    let mut tick = 0u32;
    let mut source_done = false;
    loop {
        // Commands first.
        let wait = if dev.streaming() && !source_done {
            Duration::ZERO
        } else {
            Duration::from_millis(5)
        };
        let bytes = match rx.recv_timeout(wait) {
            Ok(b) => b,
            Err(RecvTimeoutError::Timeout) => Vec::new(),
            Err(RecvTimeoutError::Disconnected) => return dev,
        };
        for b in bytes {
            let Some(Ok(frame)) = dec.push(b) else {
                continue;
            };
            let uptime = tick / 1000;
            let n = embassy_futures::block_on(dev.handle(&frame, uptime, &mut out));
            if tx.send(out[..n].to_vec()).is_err() {
                return dev;
            }
        }
        if dev.take_changed() {
            // The monitor would restart its filters here.
        }
        // Then one block's worth of samples.
        if dev.streaming() && !source_done {
            for _ in 0..crate::message::SAMPLES_PER_BLOCK {
                let Some(s) = (cfg.source)(tick) else {
                    source_done = true;
                    break;
                };
                let this = tick;
                tick = tick.wrapping_add(1);
                let Some(block) = dev.sample(this, &s) else {
                    continue;
                };
                let nth = block.seq.wrapping_add(1);
                if cfg.drop_every.is_some_and(|n| nth.is_multiple_of(n)) {
                    dev.block_dropped();
                    continue;
                }
                let Ok(n) = encode(block.seq as u16, &Message::Block(block), &mut out) else {
                    continue;
                };
                let mut frame = out[..n].to_vec();
                if cfg.corrupt_every.is_some_and(|k| nth.is_multiple_of(k)) {
                    // Flip bits of a byte in the middle (not the delimiter).
                    frame[n / 2] ^= 0x5A;
                }
                // Lossless (the host tools are tested, not the host's
                // speed): wait for the host. `drop_every` stands in for
                // the firmware's drop-and-count when the host is slow.
                if tx.send(frame).is_err() {
                    return dev;
                }
            }
        }
    }
}
