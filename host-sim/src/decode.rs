//! `host-sim decode`: the leak monitor's CAN frames in a candump log
//! (`candump -l`, lines `(sec.usec) iface id#hex`), decoded with the same
//! protocol code the firmware encodes with. Every frame's E2E protection
//! is checked: bad CRCs, invalid counters, counter jumps (lost frames) and
//! repeated counters are flagged. Lines are read with a length limit;
//! CAN error frames, CAN FD and CAN XL frames and odd DLCs are skipped and
//! counted (an error with `--strict`). Output is flushed after every
//! frame, so `candump -L can0 | host-sim decode -` is live. Frames of
//! every node's identifier block are decoded (each node's counters checked
//! on their own), or of one node only ([`Nodes`]).

use crate::recording::bounded::{read_line, Exceeded};
use anyhow::{anyhow, bail, Result};
use monitor::protocol::{DecodeError, E2eError, Node, Received, Sequence, Signal, SignalValue};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::{BufRead, Write};

/// Longest line of a candump log, bytes (a CAN XL line is under 5 KiB).
pub const MAX_LINE_BYTES: u64 = 64 * 1024;

/// A line that holds a frame the monitor never sends, skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// A CAN error frame (identifier with the error flag, `20000080#…`).
    ErrorFrame,
    /// A CAN FD frame (`id##flags data`).
    CanFd,
    /// A CAN XL frame (`prio#flags:sdt:af#data`).
    CanXl,
    /// A classic frame with a DLC above 8 (`_9` … `_F` suffix, or more
    /// than 8 data bytes).
    OddDlc,
}

impl Skip {
    /// For messages.
    pub fn describe(self) -> &'static str {
        match self {
            Self::ErrorFrame => "CAN error frame",
            Self::CanFd => "CAN FD frame",
            Self::CanXl => "CAN XL frame",
            Self::OddDlc => "classic frame with a DLC above 8",
        }
    }
}

/// What a log line holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Entry {
    /// A classic CAN frame.
    Frame(LogFrame),
    /// A frame that is skipped.
    Skipped(Skip),
}

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
    /// CAN FD frame (always `false`: FD frames are [`Skip::CanFd`]).
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
pub fn parse_line(line: &str) -> Result<Option<Entry>, String> {
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
    if rest.contains(':') {
        return Ok(Some(Entry::Skipped(Skip::CanXl)));
    }
    let extended = match id_text.len() {
        3 => false,
        8 => true,
        _ => return Err(format!("bad identifier `{id_text}`: 3 or 8 hex digits")),
    };
    let id = u32::from_str_radix(id_text, 16).map_err(|_| format!("bad identifier `{id_text}`"))?;
    if extended && id & CAN_ERR_FLAG != 0 {
        return Ok(Some(Entry::Skipped(Skip::ErrorFrame)));
    }
    if id > if extended { 0x1FFF_FFFF } else { 0x7FF } {
        return Err(format!("bad identifier `{id_text}`"));
    }
    if let Some(fd) = rest.strip_prefix('#') {
        // CAN FD: one flags nibble, then up to 64 data bytes.
        fd.get(1..)
            .and_then(hex_bytes)
            .filter(|d| d.len() <= 64)
            .ok_or_else(|| format!("bad CAN FD data `{fd}`"))?;
        return Ok(Some(Entry::Skipped(Skip::CanFd)));
    }
    let Some((remote, data)) = classic_data(rest)? else {
        return Ok(Some(Entry::Skipped(Skip::OddDlc)));
    };
    Ok(Some(Entry::Frame(LogFrame {
        time: time.to_string(),
        iface: iface.to_string(),
        id,
        extended,
        remote,
        fd: false,
        data,
    })))
}

/// The error flag of a SocketCAN identifier (`CAN_ERR_FLAG`).
const CAN_ERR_FLAG: u32 = 0x2000_0000;

/// A classic frame's data after `#`: (remote, bytes); `None` for a DLC
/// above 8.
fn classic_data(rest: &str) -> Result<Option<(bool, Vec<u8>)>, String> {
    if let Some(r) = rest.strip_prefix('R') {
        let dlc = r.strip_prefix('_').unwrap_or(r);
        let ok = r.is_empty() || (dlc.len() == 1 && dlc.as_bytes()[0].is_ascii_hexdigit());
        if !ok {
            return Err(format!("bad remote frame `{rest}`"));
        }
        let odd = u8::from_str_radix(dlc, 16).is_ok_and(|d| d > 8);
        return Ok((!odd).then(|| (true, Vec::new())));
    }
    // `data_D`: a raw DLC 9..F on a frame of 8 bytes (candump -8).
    let (hex, dlc) = match rest.split_once('_') {
        Some((h, d)) => (h, Some(d)),
        None => (rest, None),
    };
    let bytes =
        hex_bytes(hex).ok_or_else(|| format!("bad data `{rest}`: up to 8 bytes as hex pairs"))?;
    if let Some(d) = dlc {
        let ok = d.len() == 1 && u8::from_str_radix(d, 16).is_ok_and(|d| d > 8);
        if !ok || bytes.len() != 8 {
            return Err(format!("bad DLC suffix `_{d}` (9..F on 8 data bytes)"));
        }
        return Ok(None);
    }
    Ok((bytes.len() <= 8).then_some((false, bytes)))
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
    /// Node number of the monitor that sent it (or the command's
    /// addressee), if it is one of ours.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
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
    /// The bit-mask signals by flag name (`Health`, `FaultedChannels`);
    /// `signals` keeps their numeric value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flags: Option<BTreeMap<&'static str, Vec<String>>>,
    /// The error or the human-readable signal list.
    pub text: String,
    /// Data bytes, hex.
    pub data: String,
}

fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02X}")).collect()
}

fn record(f: &LogFrame, nodes: &mut Nodes) -> FrameRecord {
    let mut r = FrameRecord {
        t: f.time.parse().unwrap_or(f64::NAN),
        iface: f.iface.clone(),
        id: f.id,
        message: None,
        node: None,
        outcome: Outcome::Foreign,
        counter: None,
        lost: None,
        signals: None,
        flags: None,
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
    let Some((kind, node, decoder)) = nodes.locate(f.id) else {
        r.text = "not a leak-monitor frame".into();
        return r;
    };
    r.message = Some(kind.name());
    r.node = Some(node.number());
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
            r.text = signals.iter().map(describe).collect::<Vec<_>>().join(" ");
            let flags: BTreeMap<_, _> = signals
                .iter()
                .filter_map(|s| Some((s.name, flag_names(s)?)))
                .collect();
            r.flags = (!flags.is_empty()).then_some(flags);
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

/// The set bits of a bit-mask signal by name (unknown bits as `BITn`);
/// `None` for other signals.
fn flag_names(s: &Signal) -> Option<Vec<String>> {
    let SignalValue::Integer { value, .. } = s.value else {
        return None;
    };
    let name = |bit: u32| -> String {
        let mask = 1u32 << bit;
        let known = match s.name {
            "Health" => monitor::status::health::NAMES
                .iter()
                .find(|(m, _)| u32::from(*m) == mask)
                .map(|(_, n)| *n),
            _ => monitor::Channel::ALL.get(bit as usize).map(|c| c.name()),
        };
        known.map_or_else(|| format!("BIT{bit}"), str::to_string)
    };
    match s.name {
        "Health" | "FaultedChannels" => Some(
            (0..32)
                .filter(|b| value & (1 << b) != 0)
                .map(name)
                .collect(),
        ),
        _ => None,
    }
}

/// A signal for people: bit masks by flag name (`Health=WARMING_UP|DATA_GAP`,
/// `none` when clear).
fn describe(s: &Signal) -> String {
    match flag_names(s) {
        Some(names) if names.is_empty() => format!("{}=none", s.name),
        Some(names) => format!("{}={}", s.name, names.join("|")),
        None => s.to_string(),
    }
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
    /// Skipped lines: CAN error frames.
    pub error_frames: u64,
    /// Skipped lines: CAN FD frames.
    pub fd_frames: u64,
    /// Skipped lines: CAN XL frames.
    pub xl_frames: u64,
    /// Skipped lines: classic frames with a DLC above 8.
    pub odd_dlc: u64,
}

impl Summary {
    /// Were any protection or format errors seen (skipped lines count)?
    pub fn has_errors(&self) -> bool {
        self.bad_crc + self.malformed + self.counter_jumps + self.repeated + self.skipped() > 0
    }

    /// Lines skipped (error frames, CAN FD and XL, odd DLCs).
    pub fn skipped(&self) -> u64 {
        self.error_frames + self.fd_frames + self.xl_frames + self.odd_dlc
    }

    fn skip(&mut self, s: Skip) {
        *match s {
            Skip::ErrorFrame => &mut self.error_frames,
            Skip::CanFd => &mut self.fd_frames,
            Skip::CanXl => &mut self.xl_frames,
            Skip::OddDlc => &mut self.odd_dlc,
        } += 1;
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
        )?;
        if self.skipped() > 0 {
            write!(
                f,
                "; {} lines skipped ({} CAN error frames, {} CAN FD, {} CAN XL, {} DLC above 8)",
                self.skipped(),
                self.error_frames,
                self.fd_frames,
                self.xl_frames,
                self.odd_dlc
            )?;
        }
        Ok(())
    }
}

/// A line for people.
pub fn format_record(r: &FrameRecord, time: &str) -> String {
    let name = match (r.message, r.node) {
        (Some(m), Some(n)) if n != 0 => format!("{m}@{n}"),
        (m, _) => m.unwrap_or("-").to_string(),
    };
    let id = format!("{:03X}", r.id);
    let flag = match r.outcome {
        Outcome::CounterJump => format!(" COUNTER JUMP ({} lost)", r.lost.unwrap_or(0)),
        Outcome::RepeatedCounter => " REPEATED COUNTER".to_string(),
        _ => String::new(),
    };
    // As wide as the longest node-0 name, `LM_Sensitivity`.
    match r.counter {
        Some(c) => format!(
            "({time}) {} {id} {name:<14} #{c:<2}{flag} {}",
            r.iface, r.text
        ),
        None => format!(
            "({time}) {} {id} {name:<14} {} [{}]",
            r.iface, r.text, r.data
        ),
    }
}

/// Decode a candump log from `input`, writing one line per frame (or one
/// JSON object per frame) to `out`. `name` labels errors. Skipped lines
/// are counted only.
pub fn decode_log(
    input: impl BufRead,
    name: &str,
    json: bool,
    out: &mut impl Write,
) -> Result<Summary> {
    decode_stream(input, name, json, out, None, None)
}

/// As [`decode_log`], flushing `out` after every frame; with `strict`
/// (`Some(diagnostics)`), every skipped line is an error there naming it;
/// with `only`, the frames of that node only (others are foreign).
pub fn decode_stream(
    mut input: impl BufRead,
    name: &str,
    json: bool,
    out: &mut impl Write,
    mut strict: Option<&mut dyn Write>,
    only: Option<Node>,
) -> Result<Summary> {
    let mut nodes = Nodes::new(only);
    let mut summary = Summary::default();
    let mut raw = Vec::new();
    for n in 1.. {
        if read_line(&mut input, &mut raw, MAX_LINE_BYTES, n).map_err(|e| {
            match Exceeded::of(&e) {
                Some(_) => anyhow!(
                    "{name}:{n}: line longer than {MAX_LINE_BYTES} bytes (not a candump log?)"
                ),
                None => anyhow!("{name}:{n}: cannot read: {e}"),
            }
        })? == 0
        {
            break;
        }
        let line = std::str::from_utf8(&raw).map_err(|e| anyhow!("{name}:{n}: not text: {e}"))?;
        let frame = match parse_line(line) {
            Ok(Some(Entry::Frame(f))) => f,
            Ok(Some(Entry::Skipped(s))) => {
                summary.skip(s);
                if let Some(w) = strict.as_deref_mut() {
                    writeln!(w, "error: {name}:{n}: {}: `{}`", s.describe(), line.trim())?;
                }
                continue;
            }
            Ok(None) => continue,
            Err(e) => bail!("{name}:{n}: {e}: `{}`", line.trim()),
        };
        let r = record(&frame, &mut nodes);
        summary.add(&r);
        if json {
            serde_json::to_writer(&mut *out, &r)?;
            writeln!(out)?;
        } else {
            writeln!(out, "{}", format_record(&r, &frame.time))?;
        }
        out.flush()?;
    }
    Ok(summary)
}

mod nodes;
pub use nodes::Nodes;

#[cfg(test)]
mod tests;
