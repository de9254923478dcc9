//! `host-sim decode`: the leak monitor's CAN frames in a candump log
//! (`candump -l`, lines `(sec.usec) iface id#hex`), decoded with the same
//! protocol code the firmware encodes with. Every frame's E2E protection
//! is checked: bad CRCs, invalid counters, counter jumps (lost frames) and
//! repeated counters are flagged.

use anyhow::{bail, Context, Result};
use monitor::protocol::{DecodeError, Decoder, E2eError, MessageKind, Received, Sequence};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::{BufRead, Write};

/// One frame of a candump log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogFrame {
    /// The timestamp as written (seconds.microseconds).
    pub time: String,
    /// Interface name.
    pub iface: String,
    /// Identifier (11 or 29 bits).
    pub id: u32,
    /// 29-bit identifier.
    pub extended: bool,
    /// Remote frame.
    pub remote: bool,
    /// CAN FD frame.
    pub fd: bool,
    /// Data bytes.
    pub data: Vec<u8>,
}

fn hex_bytes(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).ok())
        .collect()
}

/// Parse one log line; `Ok(None)` for a blank or `#` comment line.
pub fn parse_line(line: &str) -> Result<Option<LogFrame>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let mut parts = line.split_whitespace();
    let (Some(time), Some(iface), Some(frame)) = (parts.next(), parts.next(), parts.next()) else {
        return Err("expected `(sec.usec) iface id#data`".into());
    };
    // Newer candump versions may append a direction flag (R or T).
    match parts.next() {
        None | Some("R") | Some("T") => {}
        Some(extra) => return Err(format!("unexpected `{extra}` after the frame")),
    }
    let time = time
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .filter(|t| {
            let mut it = t.splitn(2, '.');
            let whole = it.next().unwrap_or("");
            let frac = it.next().unwrap_or("");
            !whole.is_empty()
                && !frac.is_empty()
                && whole.bytes().all(|b| b.is_ascii_digit())
                && frac.bytes().all(|b| b.is_ascii_digit())
        })
        .ok_or_else(|| format!("bad timestamp `{time}`, expected `(seconds.microseconds)`"))?;
    let (id_text, rest) = frame
        .split_once('#')
        .ok_or_else(|| format!("bad frame `{frame}`, expected `id#data`"))?;
    let extended = match id_text.len() {
        3 => false,
        8 => true,
        _ => return Err(format!("bad identifier `{id_text}`: 3 or 8 hex digits")),
    };
    let id = u32::from_str_radix(id_text, 16)
        .ok()
        .filter(|&id| id <= if extended { 0x1FFF_FFFF } else { 0x7FF })
        .ok_or_else(|| format!("bad identifier `{id_text}`"))?;
    let (fd, remote, data) = if let Some(fd) = rest.strip_prefix('#') {
        // CAN FD: one flags nibble, then data.
        let bytes = fd
            .get(1..)
            .and_then(hex_bytes)
            .filter(|d| d.len() <= 64)
            .ok_or_else(|| format!("bad CAN FD data `{fd}`"))?;
        (true, false, bytes)
    } else if let Some(r) = rest.strip_prefix('R') {
        if !(r.is_empty() || (r.len() == 1 && r.as_bytes()[0].is_ascii_digit())) {
            return Err(format!("bad remote frame `{rest}`"));
        }
        (false, true, Vec::new())
    } else {
        let bytes = hex_bytes(rest)
            .filter(|d| d.len() <= 8)
            .ok_or_else(|| format!("bad data `{rest}`: up to 8 bytes as hex pairs"))?;
        (false, false, bytes)
    };
    Ok(Some(LogFrame {
        time: time.to_string(),
        iface: iface.to_string(),
        id,
        extended,
        remote,
        fd,
        data,
    }))
}

/// How a frame fared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Decoded, counter in order (or the first of its kind).
    Ok,
    /// Decoded, but frames of this kind were lost before it.
    CounterJump,
    /// Decoded, but with the same counter as the previous frame.
    RepeatedCounter,
    /// CRC does not match: not decoded.
    BadCrc,
    /// Counter 15: not decoded.
    InvalidCounter,
    /// Wrong length: not decoded.
    BadLength,
    /// A field holds an undefined value: not decoded.
    BadField,
    /// Not one of the leak monitor's frames.
    Foreign,
}

/// One decoded log line (the `--json` output, one object per line).
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    /// Timestamp, s.
    pub t: f64,
    /// Interface.
    pub iface: String,
    /// Identifier.
    pub id: u32,
    /// DBC message name, if it is one of ours.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<&'static str>,
    /// What the checks found.
    pub outcome: Outcome,
    /// E2E counter.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counter: Option<u8>,
    /// Frames lost before this one (counter jump).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lost: Option<u8>,
    /// Physical value per signal (`null`: not available).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub signals: Option<BTreeMap<&'static str, Option<f64>>>,
    /// The error or the human-readable signal list.
    pub text: String,
    /// Data bytes, hex.
    pub data: String,
}

fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02X}")).collect()
}

fn record(f: &LogFrame, decoder: &mut Decoder) -> FrameRecord {
    let mut r = FrameRecord {
        t: f.time.parse().unwrap_or(f64::NAN),
        iface: f.iface.clone(),
        id: f.id,
        message: None,
        outcome: Outcome::Foreign,
        counter: None,
        lost: None,
        signals: None,
        text: String::new(),
        data: hex(&f.data),
    };
    if f.extended || f.remote || f.fd {
        r.text = "not a leak-monitor frame".into();
        return r;
    }
    let Some(frame) = monitor::protocol::CanFrame::new(f.id as u16, &f.data) else {
        r.text = "not a leak-monitor frame".into();
        return r;
    };
    r.message = MessageKind::from_id(f.id as u16).map(MessageKind::name);
    match decoder.decode(&frame) {
        Ok(Received {
            message,
            counter,
            sequence,
        }) => {
            r.counter = Some(counter);
            r.outcome = match sequence {
                Sequence::First | Sequence::InOrder => Outcome::Ok,
                Sequence::Repeated => Outcome::RepeatedCounter,
                Sequence::Lost(n) => {
                    r.lost = Some(n);
                    Outcome::CounterJump
                }
            };
            let signals = message.signals();
            r.text = signals
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(" ");
            r.signals = Some(
                signals
                    .iter()
                    .map(|s| (s.name, s.value.physical()))
                    .collect(),
            );
        }
        Err(e) => {
            (r.outcome, r.text) = match e {
                DecodeError::NotADataFrame | DecodeError::UnknownId(_) => {
                    (Outcome::Foreign, "not a leak-monitor frame".into())
                }
                DecodeError::Length { len, .. } => {
                    (Outcome::BadLength, format!("BAD LENGTH {len} (expected 8)"))
                }
                DecodeError::E2e {
                    error: E2eError::Crc { received, computed },
                    ..
                } => (
                    Outcome::BadCrc,
                    format!("BAD CRC (received {received:02X}, computed {computed:02X})"),
                ),
                DecodeError::E2e {
                    error: E2eError::InvalidCounter,
                    ..
                } => (Outcome::InvalidCounter, "INVALID COUNTER 15".into()),
                DecodeError::E2e {
                    error: E2eError::TooShort,
                    ..
                } => (Outcome::BadLength, "BAD LENGTH".into()),
                DecodeError::Field { error, .. } => (
                    Outcome::BadField,
                    format!("BAD FIELD {} = {}", error.field, error.raw),
                ),
            };
        }
    }
    r
}

/// Counts over a log.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Summary {
    /// Frames read.
    pub frames: u64,
    /// Leak-monitor frames decoded.
    pub decoded: u64,
    /// Frames with a bad CRC.
    pub bad_crc: u64,
    /// Frames with counter 15, a wrong length or an undefined field.
    pub malformed: u64,
    /// Counter jumps.
    pub counter_jumps: u64,
    /// Frames lost according to the counters.
    pub frames_lost: u64,
    /// Repeated counters.
    pub repeated: u64,
    /// Other traffic.
    pub foreign: u64,
}

impl Summary {
    /// Were any protection or format errors seen?
    pub fn has_errors(&self) -> bool {
        self.bad_crc + self.malformed + self.counter_jumps + self.repeated > 0
    }

    fn add(&mut self, r: &FrameRecord) {
        self.frames += 1;
        match r.outcome {
            Outcome::Ok => self.decoded += 1,
            Outcome::CounterJump => {
                self.decoded += 1;
                self.counter_jumps += 1;
                self.frames_lost += r.lost.unwrap_or(0) as u64;
            }
            Outcome::RepeatedCounter => {
                self.decoded += 1;
                self.repeated += 1;
            }
            Outcome::BadCrc => self.bad_crc += 1,
            Outcome::InvalidCounter | Outcome::BadLength | Outcome::BadField => self.malformed += 1,
            Outcome::Foreign => self.foreign += 1,
        }
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} frames: {} decoded, {} bad CRC, {} malformed, {} counter jumps ({} frames lost), {} repeated, {} other",
            self.frames,
            self.decoded,
            self.bad_crc,
            self.malformed,
            self.counter_jumps,
            self.frames_lost,
            self.repeated,
            self.foreign
        )
    }
}

/// A line for people.
pub fn format_record(r: &FrameRecord, time: &str) -> String {
    let name = r.message.unwrap_or("-");
    let id = format!("{:03X}", r.id);
    let flag = match r.outcome {
        Outcome::CounterJump => format!(" COUNTER JUMP ({} lost)", r.lost.unwrap_or(0)),
        Outcome::RepeatedCounter => " REPEATED COUNTER".to_string(),
        _ => String::new(),
    };
    match r.counter {
        Some(c) => format!(
            "({time}) {} {id} {name:<12} #{c:<2}{flag} {}",
            r.iface, r.text
        ),
        None => format!(
            "({time}) {} {id} {name:<12} {} [{}]",
            r.iface, r.text, r.data
        ),
    }
}

/// Decode a candump log from `input`, writing one line per frame (or one
/// JSON object per frame) to `out`. `name` labels errors.
pub fn decode_log(
    input: impl BufRead,
    name: &str,
    json: bool,
    out: &mut impl Write,
) -> Result<Summary> {
    let mut decoder = Decoder::new();
    let mut summary = Summary::default();
    for (i, line) in input.lines().enumerate() {
        let line = line.with_context(|| format!("{name}:{}: cannot read", i + 1))?;
        let frame = match parse_line(&line) {
            Ok(Some(f)) => f,
            Ok(None) => continue,
            Err(e) => bail!("{name}:{}: {e}: `{}`", i + 1, line.trim()),
        };
        let r = record(&frame, &mut decoder);
        summary.add(&r);
        if json {
            serde_json::to_writer(&mut *out, &r)?;
            writeln!(out)?;
        } else {
            writeln!(out, "{}", format_record(&r, &frame.time))?;
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_candump_lines() {
        let f = parse_line("(1700000000.123456) can0 301#00112233AABBCCDD")
            .unwrap()
            .unwrap();
        assert_eq!(f.time, "1700000000.123456");
        assert_eq!(f.iface, "can0");
        assert_eq!(f.id, 0x301);
        assert!(!f.extended && !f.remote && !f.fd);
        assert_eq!(f.data, [0x00, 0x11, 0x22, 0x33, 0xAA, 0xBB, 0xCC, 0xDD]);
        let f = parse_line("(1.000001) vcan0 12345678#ab R")
            .unwrap()
            .unwrap();
        assert!(f.extended && f.id == 0x1234_5678 && f.data == [0xAB]);
        assert!(parse_line("(1.0) can0 123#R").unwrap().unwrap().remote);
        assert!(parse_line("(1.0) can0 123##1AABB").unwrap().unwrap().fd);
        assert_eq!(parse_line("").unwrap(), None);
        assert_eq!(parse_line("# comment").unwrap(), None);
        assert!(parse_line("(1.0) can0 300#")
            .unwrap()
            .unwrap()
            .data
            .is_empty());
    }

    #[test]
    fn rejects_malformed_lines_with_a_reason() {
        for (line, why) in [
            ("can0 301#00", "expected"),
            ("(1) can0 301#00", "timestamp"),
            ("(1.x) can0 301#00", "timestamp"),
            ("(1.0) can0 3011#00", "identifier"),
            ("(1.0) can0 801#00", "identifier"),
            ("(1.0) can0 301-00", "id#data"),
            ("(1.0) can0 301#0", "data"),
            ("(1.0) can0 301#001122334455667788", "data"),
            ("(1.0) can0 301#zz", "data"),
            ("(1.0) can0 301#00 extra", "unexpected"),
        ] {
            let e = parse_line(line).unwrap_err();
            assert!(e.contains(why), "{line}: {e}");
        }
    }
}
