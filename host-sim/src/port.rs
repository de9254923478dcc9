//! The device link for `record`, `params` and `events`: a serial port
//! (USB CDC-ACM on the board, a UART in QEMU), or the simulated device.
//!
//! `PORT` is a serial port path (`/dev/ttyACM0`, `COM3`), or
//! `sim:[RECORDING.csv][?key=value&…]` for the simulated device in this
//! process (the firmware's own link and storage code on a RAM flash),
//! streaming the recording's samples (a quiet hold when none is given).
//! Keys: `state=FILE` keeps the simulated flash between runs (so an upload
//! is still there for the next `params show`); `drop=N` drops every N-th
//! block at the device (as when the host is too slow); `corrupt=N`
//! corrupts every N-th block frame on the wire; `serial=S` sets the board
//! serial.

use anyhow::{bail, Context, Result};
use link::client::Client;
use monitor::{Params, Sample};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::time::Duration;

/// A byte link to a device.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Baud rate set on a real serial port (ignored by USB CDC-ACM).
pub const BAUD: u32 = 921_600;

/// Firmware version the simulated device reports.
pub const SIM_FIRMWARE: &str = concat!(env!("CARGO_PKG_VERSION"), "-sim");

/// Open `port` and connect a client.
pub fn connect(port: &str) -> Result<Client<Box<dyn Port>>> {
    let io: Box<dyn Port> = match port.strip_prefix("sim:") {
        Some(spec) => Box::new(sim(spec)?),
        None => Box::new(
            serialport::new(port, BAUD)
                .timeout(Duration::from_millis(50))
                .open()
                .with_context(|| format!("{port}: cannot open the serial port"))?,
        ),
    };
    Client::new(io).with_context(|| format!("{port}: cannot write"))
}

fn sim(spec: &str) -> Result<link::sim::SimPort> {
    let (file, query) = spec.split_once('?').unwrap_or((spec, ""));
    let mut state = None;
    let mut drop_every = None;
    let mut corrupt_every = None;
    let mut serial = "SIM-0001".to_string();
    for kv in query.split('&').filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        let n = || -> Result<u32> {
            match v.parse::<u32>() {
                Ok(n) if n > 0 => Ok(n),
                _ => bail!("sim: `{k}` wants a whole number > 0, not `{v}`"),
            }
        };
        match k {
            "state" => state = Some(PathBuf::from(v)),
            "drop" => drop_every = Some(n()?),
            "corrupt" => corrupt_every = Some(n()?),
            "serial" => serial = v.to_string(),
            _ => bail!("sim: unknown option `{k}` (state, drop, corrupt, serial)"),
        }
    }
    let source: link::sim::Source = if file.is_empty() {
        Box::new(|_| Some(quiet_hold()))
    } else {
        let path = PathBuf::from(file);
        let (samples, _) = crate::read_all(&path)?;
        Box::new(move |tick| samples.get(tick as usize).copied())
    };
    let cfg = link::sim::SimConfig {
        firmware: SIM_FIRMWARE,
        serial,
        period_us: 1000,
        source,
        state,
        drop_every,
        corrupt_every,
        default: Params::nominal(),
    };
    Ok(link::sim::spawn(cfg)?)
}

fn quiet_hold() -> Sample {
    Sample {
        t_s: 0.0,
        p_supply_bar: Some(50.0),
        p_piston_bar: Some(21.4),
        p_rod_bar: Some(12.95),
        p_tank_bar: Some(0.8),
        x_piston_m: Some(0.0412),
        u_valve: Some(0.0),
        temp_oil_c: None,
    }
}

/// A client error as an `anyhow` error naming the port.
pub fn link_err(port: &str) -> impl Fn(link::client::ClientError) -> anyhow::Error + '_ {
    move |e| anyhow::anyhow!("{port}: {e}")
}
