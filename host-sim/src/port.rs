//! The device link for `record`, `params` and `events`: a serial port
//! (USB CDC-ACM on the board), a TCP socket (the emulated board's UART in
//! QEMU), or the simulated device.
//!
//! `PORT` is a serial port path (`/dev/ttyACM0`, `COM3`),
//! `tcp:HOST:PORT` (`tcp:127.0.0.1:4567`, `tcp:[::1]:4567`) for a byte
//! stream over TCP, as QEMU serves a board's serial port with
//! `-chardev socket,…,server=on`, or
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
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::Duration;

/// A byte link to a device.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Baud rate set on a real serial port (ignored by USB CDC-ACM).
pub const BAUD: u32 = 921_600;

/// Read timeout of a serial port or TCP socket: how long a read waits
/// for the first byte (the client polls with it).
const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// How long to try each address of a `tcp:` port.
const TCP_CONNECT_TIMEOUT: Duration = Duration::from_secs(2);

/// How long a write to a `tcp:` port may block (the peer not reading)
/// before it fails.
const TCP_WRITE_TIMEOUT: Duration = Duration::from_secs(5);

/// Firmware version the simulated device reports.
pub const SIM_FIRMWARE: &str = concat!(env!("CARGO_PKG_VERSION"), "-sim");

/// Open `port` and connect a client.
pub fn connect(port: &str) -> Result<Client<Box<dyn Port>>> {
    let io: Box<dyn Port> = if let Some(spec) = port.strip_prefix("sim:") {
        Box::new(sim(spec)?)
    } else if let Some(addr) = port.strip_prefix("tcp:") {
        Box::new(tcp(addr).with_context(|| format!("{port}: cannot connect"))?)
    } else {
        Box::new(
            serialport::new(port, BAUD)
                .timeout(READ_TIMEOUT)
                // The board's USB CDC-ACM session lasts while DTR is held
                // (Windows does not assert it by itself).
                .dtr_on_open(true)
                .open()
                .with_context(|| format!("{port}: cannot open the serial port"))?,
        )
    };
    Client::new(io).with_context(|| format!("{port}: cannot write"))
}

/// The socket addresses of `HOST:PORT` (a name, an IPv4 address or an
/// IPv6 one in brackets).
fn tcp_addrs(addr: &str) -> Result<Vec<SocketAddr>> {
    let Some((host, port)) = addr.rsplit_once(':') else {
        bail!("`{addr}` is not HOST:PORT (e.g. tcp:127.0.0.1:4567)");
    };
    let host = host
        .strip_prefix('[')
        .and_then(|h| h.strip_suffix(']'))
        .unwrap_or(host);
    if host.is_empty() {
        bail!("`{addr}` has no host (e.g. tcp:127.0.0.1:4567)");
    }
    let port: u16 = match port.parse() {
        Ok(p) if p > 0 => p,
        _ => bail!("`{port}` is not a TCP port number (1 to 65535)"),
    };
    let addrs: Vec<SocketAddr> = (host, port)
        .to_socket_addrs()
        .with_context(|| format!("cannot resolve `{host}`"))?
        .collect();
    if addrs.is_empty() {
        bail!("`{host}` has no address");
    }
    Ok(addrs)
}

/// A TCP stream to `HOST:PORT` with the serial port's read timeout.
fn tcp(addr: &str) -> Result<TcpStream> {
    let mut last = None;
    for a in tcp_addrs(addr)? {
        match TcpStream::connect_timeout(&a, TCP_CONNECT_TIMEOUT) {
            Ok(s) => {
                s.set_read_timeout(Some(READ_TIMEOUT))?;
                s.set_write_timeout(Some(TCP_WRITE_TIMEOUT))?;
                // Requests are single small frames: send them at once.
                s.set_nodelay(true)?;
                return Ok(s);
            }
            Err(e) => last = Some(anyhow::Error::new(e).context(a.to_string())),
        }
    }
    Err(last.expect("at least one address"))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn err(port: &str) -> String {
        match connect(port) {
            Ok(_) => panic!("{port} connected"),
            Err(e) => format!("{e:#}"),
        }
    }

    #[test]
    fn tcp_addresses_parse() {
        let v4 = tcp_addrs("127.0.0.1:4567").unwrap();
        assert_eq!(v4, ["127.0.0.1:4567".parse().unwrap()]);
        let v6 = tcp_addrs("[::1]:4567").unwrap();
        assert_eq!(v6, ["[::1]:4567".parse().unwrap()]);
    }

    #[test]
    fn a_malformed_tcp_port_is_a_clear_error() {
        for (port, says) in [
            ("tcp:nohost", "`nohost` is not HOST:PORT"),
            ("tcp::4567", "has no host"),
            ("tcp:127.0.0.1:", "`` is not a TCP port number"),
            ("tcp:127.0.0.1:0", "`0` is not a TCP port number"),
            ("tcp:127.0.0.1:99999", "`99999` is not a TCP port number"),
        ] {
            let e = err(port);
            assert!(e.starts_with(&format!("{port}: cannot connect: ")), "{e}");
            assert!(e.contains(says), "{port}: {e}");
        }
    }

    #[test]
    fn a_refused_tcp_connection_names_the_port() {
        // A port that was free a moment ago: nothing listens there.
        let free = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = format!("tcp:{}", free.local_addr().unwrap());
        drop(free);
        let e = err(&port);
        assert!(e.starts_with(&format!("{port}: cannot connect: ")), "{e}");
    }
}
