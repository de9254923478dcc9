//! The host end: a blocking client over any byte transport (`Read +
//! Write` whose reads time out, as a serial port's do).

use crate::frame::{encode, Decoder, DecoderStats, MAX_WIRE};
use crate::message::{
    EventRecord, Message, ParamsId, Refusal, SampleBlock, CHUNK, PROTOCOL_VERSION,
};
use std::collections::VecDeque;
use std::fmt;
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

/// A device's identity, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceIdentity {
    /// Protocol version.
    pub protocol: u8,
    /// Firmware version.
    pub firmware: String,
    /// Board serial number.
    pub serial: String,
    /// Active parameter set.
    pub params: ParamsId,
    /// Boot counter.
    pub boot: u32,
    /// Sample period, µs.
    pub period_us: u32,
}

/// A reply, owned.
#[derive(Clone, Debug, PartialEq)]
enum Reply {
    Identity(DeviceIdentity),
    Ack,
    Refused {
        reason: Refusal,
        field: String,
    },
    StreamEnd {
        last_seq: u32,
        dropped: u32,
    },
    ParamsData {
        total: u32,
        offset: u32,
        data: Vec<u8>,
    },
    Events {
        total: u32,
        events: Vec<EventRecord>,
    },
}

/// Why a request failed.
#[derive(Debug)]
pub enum ClientError {
    /// The transport failed.
    Io(io::Error),
    /// No reply in time (after retries).
    Timeout,
    /// The device refused (`field`: the offending parameter, if any).
    Refused {
        /// Why.
        reason: Refusal,
        /// Offending parameter, or empty.
        field: String,
    },
    /// A reply that makes no sense here.
    Protocol(String),
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(e) => write!(f, "link: {e}"),
            Self::Timeout => write!(f, "the device did not answer"),
            Self::Refused { reason, field } if field.is_empty() => {
                write!(f, "the device refused: {reason:?}")
            }
            Self::Refused { reason, field } => {
                write!(f, "the device refused parameter `{field}`: {reason:?}")
            }
            Self::Protocol(m) => write!(f, "protocol: {m}"),
        }
    }
}

impl std::error::Error for ClientError {}

impl From<io::Error> for ClientError {
    fn from(e: io::Error) -> Self {
        Self::Io(e)
    }
}

/// The host end of a link.
pub struct Client<T: Read + Write> {
    io: T,
    dec: Decoder,
    seq: u16,
    blocks: VecDeque<SampleBlock>,
    /// Replies with the number of blocks queued before each arrived.
    replies: VecDeque<(u16, Reply, usize)>,
    /// Blocks queued before the last reply returned by `request`.
    blocks_before_reply: usize,
    /// How long to wait for a reply before sending the request again.
    pub timeout: Duration,
    /// Attempts per request.
    pub attempts: u32,
}

impl<T: Read + Write> Client<T> {
    /// A client on `io`. Sends a lone delimiter so the device drops any
    /// half-received frame.
    pub fn new(mut io: T) -> io::Result<Self> {
        io.write_all(&[0])?;
        io.flush()?;
        Ok(Self {
            io,
            dec: Decoder::new(),
            seq: 0,
            blocks: VecDeque::new(),
            replies: VecDeque::new(),
            blocks_before_reply: 0,
            timeout: Duration::from_millis(500),
            attempts: 3,
        })
    }

    /// Frames accepted and dropped on the way in.
    pub fn stats(&self) -> DecoderStats {
        self.dec.stats
    }

    fn send(&mut self, seq: u16, msg: &Message<'_>) -> io::Result<()> {
        let mut out = [0u8; MAX_WIRE];
        let n = encode(seq, msg, &mut out)
            .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "message too big"))?;
        self.io.write_all(&out[..n])?;
        self.io.flush()
    }

    /// Read what is there (waiting at most the transport's read timeout)
    /// into the queues.
    fn pump(&mut self) -> io::Result<()> {
        let mut buf = [0u8; 4096];
        let n = match self.io.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                ) =>
            {
                return Ok(())
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => return Ok(()),
            Err(e) => return Err(e),
        };
        if n == 0 {
            return Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the device closed the link",
            ));
        }
        for &b in &buf[..n] {
            let Some(Ok(frame)) = self.dec.push(b) else {
                continue;
            };
            let seq = frame.seq;
            let reply = match frame.msg {
                Message::Block(b) => {
                    self.blocks.push_back(b);
                    continue;
                }
                Message::Identity(id) => Reply::Identity(DeviceIdentity {
                    protocol: id.protocol,
                    firmware: id.firmware.to_string(),
                    serial: id.serial.to_string(),
                    params: id.params,
                    boot: id.boot,
                    period_us: id.period_us,
                }),
                Message::Ack => Reply::Ack,
                Message::Refused { reason, field } => Reply::Refused {
                    reason,
                    field: field.to_string(),
                },
                Message::StreamEnd { last_seq, dropped } => Reply::StreamEnd { last_seq, dropped },
                Message::ParamsData {
                    total,
                    offset,
                    data,
                } => Reply::ParamsData {
                    total,
                    offset,
                    data: data.to_vec(),
                },
                Message::Events { total, events, .. } => Reply::Events {
                    total,
                    events: events.to_vec(),
                },
                _ => continue,
            };
            self.replies.push_back((seq, reply, self.blocks.len()));
        }
        Ok(())
    }

    /// Send `msg` and wait for its reply; sent again on silence if
    /// `retry`.
    fn request(&mut self, msg: &Message<'_>, retry: bool) -> Result<Reply, ClientError> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let attempts = if retry { self.attempts.max(1) } else { 1 };
        for _ in 0..attempts {
            self.send(seq, msg)?;
            let deadline = Instant::now() + self.timeout;
            while Instant::now() < deadline {
                // Replies to older requests (answered late) are dropped.
                while let Some((s, r, before)) = self.replies.pop_front() {
                    if s == seq {
                        self.blocks_before_reply = before;
                        return match r {
                            Reply::Refused { reason, field } => {
                                Err(ClientError::Refused { reason, field })
                            }
                            r => Ok(r),
                        };
                    }
                }
                self.pump()?;
            }
        }
        Err(ClientError::Timeout)
    }

    /// Who is there. Refuses a device of another protocol version.
    pub fn identity(&mut self) -> Result<DeviceIdentity, ClientError> {
        match self.request(&Message::GetIdentity, true)? {
            Reply::Identity(id) if id.protocol == PROTOCOL_VERSION => Ok(id),
            Reply::Identity(id) => Err(ClientError::Protocol(format!(
                "the device speaks protocol {}, this host {PROTOCOL_VERSION}",
                id.protocol
            ))),
            r => Err(unexpected(&r)),
        }
    }

    /// Start the sample stream (block numbers from 0). Blocks of an
    /// earlier stream still on the way (a host that went away without
    /// stopping it) arrive before the acknowledgement and are discarded.
    pub fn start_stream(&mut self) -> Result<(), ClientError> {
        self.blocks.clear();
        match self.request(&Message::StartStream, true)? {
            Reply::Ack => {
                let stale = self.blocks_before_reply.min(self.blocks.len());
                self.blocks.drain(..stale);
                Ok(())
            }
            r => Err(unexpected(&r)),
        }
    }

    /// Stop it: (last block sequence number, blocks dropped by the
    /// device). Blocks received before the reply stay in the queue.
    pub fn stop_stream(&mut self) -> Result<(u32, u32), ClientError> {
        match self.request(&Message::StopStream, true)? {
            Reply::StreamEnd { last_seq, dropped } => Ok((last_seq, dropped)),
            r => Err(unexpected(&r)),
        }
    }

    /// The next stream block, waiting up to `wait`.
    pub fn next_block(&mut self, wait: Duration) -> Result<Option<SampleBlock>, ClientError> {
        let deadline = Instant::now() + wait;
        loop {
            if let Some(b) = self.blocks.pop_front() {
                return Ok(Some(b));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            self.pump()?;
        }
    }

    /// Upload a parameter encoding, commit it; the identity now active.
    pub fn upload_params(&mut self, enc: &[u8]) -> Result<DeviceIdentity, ClientError> {
        let crc = crate::frame::CRC32.checksum(enc);
        let begin = Message::ParamsBegin {
            len: enc.len() as u32,
            crc,
        };
        expect_ack(self.request(&begin, true)?)?;
        for (i, chunk) in enc.chunks(CHUNK).enumerate() {
            let msg = Message::ParamsChunk {
                offset: (i * CHUNK) as u32,
                data: chunk,
            };
            expect_ack(self.request(&msg, true)?)?;
        }
        // Not repeated: a lost reply is resolved by asking the identity.
        match self.request(&Message::ParamsCommit, false) {
            Ok(Reply::Identity(id)) => Ok(id),
            Ok(r) => Err(unexpected(&r)),
            Err(ClientError::Timeout) => {
                let id = self.identity()?;
                if id.params.crc == crc {
                    Ok(id)
                } else {
                    Err(ClientError::Timeout)
                }
            }
            Err(e) => Err(e),
        }
    }

    /// The active parameter set's encoding.
    pub fn read_params(&mut self) -> Result<Vec<u8>, ClientError> {
        let mut out = Vec::new();
        loop {
            let msg = Message::ParamsRead {
                offset: out.len() as u32,
            };
            match self.request(&msg, true)? {
                Reply::ParamsData {
                    total,
                    offset,
                    data,
                } if offset as usize == out.len() => {
                    out.extend_from_slice(&data);
                    if out.len() >= total as usize || data.is_empty() {
                        return Ok(out);
                    }
                }
                r => return Err(unexpected(&r)),
            }
        }
    }

    /// All stored events, oldest first.
    pub fn read_events(&mut self) -> Result<Vec<EventRecord>, ClientError> {
        let mut out = Vec::new();
        loop {
            let msg = Message::EventsRead {
                skip: out.len() as u32,
            };
            match self.request(&msg, true)? {
                Reply::Events { total, events } => {
                    let empty = events.is_empty();
                    out.extend(events);
                    if out.len() >= total as usize || empty {
                        return Ok(out);
                    }
                }
                r => return Err(unexpected(&r)),
            }
        }
    }
}

fn expect_ack(r: Reply) -> Result<(), ClientError> {
    match r {
        Reply::Ack => Ok(()),
        r => Err(unexpected(&r)),
    }
}

fn unexpected(r: &Reply) -> ClientError {
    ClientError::Protocol(format!("unexpected reply {r:?}"))
}
