//! The device side of the link: answers commands, builds the stream, keeps
//! the parameter set and the event memory. Transport-agnostic: the
//! firmware's serial task (or the simulated device) feeds it frames and
//! sends what it returns. It never blocks on the host: a block that cannot
//! be sent is dropped by the caller and counted with
//! [`Device::block_dropped`].

use crate::frame::{encode, Frame, MAX_WIRE};
use crate::message::{
    EventKind, EventRecord, Identity, Message, Refusal, ResetCause, SampleBlock, CHUNK,
    EVENTS_PER_REPLY, PROTOCOL_VERSION,
};
use crate::storage::{encode_params, Erase, Loaded, Storage, StoreError, PARAMS_MAX};
use crate::stream::BlockBuilder;
use embedded_storage_async::nor_flash::NorFlash;
use monitor::{Params, Sample};

/// What the device says about itself.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// Firmware version.
    pub firmware: &'static str,
    /// Board serial number.
    pub serial: heapless::String<24>,
    /// Sample period, µs.
    pub period_us: u32,
}

struct Upload {
    open: bool,
    len: usize,
    crc: u32,
    got: usize,
    buf: [u8; PARAMS_MAX],
}

/// The link's device end.
pub struct Device<P: NorFlash, E: NorFlash> {
    storage: Storage<P, E>,
    info: DeviceInfo,
    active: Loaded,
    active_enc: [u8; PARAMS_MAX],
    active_len: usize,
    upload: Upload,
    boot: u32,
    streaming: bool,
    builder: BlockBuilder,
    changed: bool,
    /// In-service events that needed a page erase: stored at the next
    /// upload (out of service), listed after the stored ones meanwhile.
    pending: heapless::Deque<EventRecord, PENDING>,
    /// Events lost because `pending` was full (since boot).
    lost: u32,
}

/// In-service events kept in RAM while the queue would need an erase.
pub const PENDING: usize = 16;

impl<P: NorFlash, E: NorFlash> Device<P, E> {
    /// Boot (out of service: it may erase): pick the newest valid
    /// parameter set (else `default`), count the boot, record the reset
    /// and its cause, and leave the event queue room for in-service
    /// events. ([`Self::new`] and [`Self::boot_up`] in two steps, for a
    /// device built in place in a static.)
    pub async fn start(
        storage: Storage<P, E>,
        info: DeviceInfo,
        default: &Params,
        cause: ResetCause,
    ) -> Self {
        let mut dev = Self::new(storage, info, default);
        dev.boot_up(cause).await;
        dev
    }

    /// A device not booted yet, running `default` (version 0).
    pub fn new(storage: Storage<P, E>, info: DeviceInfo, default: &Params) -> Self {
        let mut active_enc = [0; PARAMS_MAX];
        let enc = encode_params(default, &mut active_enc).unwrap_or(&[]);
        let id = crate::storage::params_id(enc, 0);
        let active_len = enc.len();
        Self {
            storage,
            info,
            active: Loaded {
                params: default.clone(),
                id,
                stored: false,
            },
            active_enc,
            active_len,
            upload: Upload {
                open: false,
                len: 0,
                crc: 0,
                got: 0,
                buf: [0; PARAMS_MAX],
            },
            boot: 0,
            streaming: false,
            builder: BlockBuilder::new(),
            changed: false,
            pending: heapless::Deque::new(),
            lost: 0,
        }
    }

    /// Boot (see [`Self::start`]), in place.
    pub async fn boot_up(&mut self, cause: ResetCause) {
        let loaded = self.storage.load_params(&self.active.params).await;
        if loaded.stored {
            self.active_len =
                encode_params(&loaded.params, &mut self.active_enc).map_or(0, |e| e.len());
            self.active = loaded;
        }
        self.boot = self.storage.bump_boot().await;
        let _ = self
            .storage
            .append_event_making_room(&EventRecord {
                boot: self.boot,
                uptime_ms: 0,
                kind: EventKind::Reset { cause },
            })
            .await;
    }

    /// The active parameter set.
    pub fn params(&self) -> &Loaded {
        &self.active
    }

    /// True once after a new set became active (the monitor must restart
    /// its filters on it).
    pub fn take_changed(&mut self) -> bool {
        core::mem::take(&mut self.changed)
    }

    /// This boot's number.
    pub fn boot(&self) -> u32 {
        self.boot
    }

    /// Is the host streaming?
    pub fn streaming(&self) -> bool {
        self.streaming
    }

    /// Give the storage back (tests: "power off").
    pub fn into_storage(self) -> Storage<P, E> {
        self.storage
    }

    /// Record an event, in service: in flash at once where that needs no
    /// page erase, else kept in RAM (up to [`PENDING`]) until the next
    /// upload stores it. `Err` only when the flash failed or the event
    /// was lost.
    pub async fn log(&mut self, uptime_ms: u32, kind: EventKind) -> Result<(), StoreError> {
        let ev = EventRecord {
            boot: self.boot,
            uptime_ms,
            kind,
        };
        if self.pending.is_empty() {
            match self.storage.append_event(&ev, Erase::Never).await {
                Err(StoreError::NeedsErase) => {}
                other => return other,
            }
        }
        self.pending.push_back(ev).map_err(|_| {
            self.lost = self.lost.saturating_add(1);
            StoreError::NeedsErase
        })
    }

    /// Events waiting for an erase, and events lost since boot.
    pub fn pending_events(&self) -> (usize, u32) {
        (self.pending.len(), self.lost)
    }

    /// Out of service: store the pending events (erasing as needed).
    async fn flush_pending(&mut self) {
        while let Some(ev) = self.pending.front() {
            if self.storage.append_event(ev, Erase::Allowed).await.is_err() {
                return;
            }
            self.pending.pop_front();
        }
    }

    /// The monitor's sample of step `tick`; a completed block to send
    /// while streaming.
    pub fn sample(&mut self, tick: u32, s: &Sample) -> Option<SampleBlock> {
        if self.streaming {
            self.builder.push(tick, s)
        } else {
            None
        }
    }

    /// The block last returned by [`Self::sample`] could not be sent.
    pub fn block_dropped(&mut self) {
        self.builder.dropped();
    }

    /// The stream's blocks are built elsewhere (the firmware builds them
    /// in its estimator task, so that a slow host never delays it): take
    /// over that builder's progress ([`BlockBuilder::completed`],
    /// [`BlockBuilder::dropped_count`]) for the `StreamEnd` reply.
    pub fn stream_progress(&mut self, blocks: u32, dropped: u32) {
        self.builder.set_progress(blocks, dropped);
    }

    /// Answer one frame into `out` (at least [`MAX_WIRE`] bytes); returns
    /// the bytes to send.
    pub async fn handle(&mut self, frame: &Frame<'_>, uptime_ms: u32, out: &mut [u8]) -> usize {
        debug_assert!(out.len() >= MAX_WIRE);
        let seq = frame.seq;
        let refuse = |reason, field: &str, out: &mut [u8]| {
            encode(seq, &Message::Refused { reason, field }, out).unwrap_or(0)
        };
        match &frame.msg {
            Message::GetIdentity => self.identity(seq, out),
            Message::StartStream => {
                self.streaming = true;
                self.builder = BlockBuilder::new();
                encode(seq, &Message::Ack, out).unwrap_or(0)
            }
            Message::StopStream => {
                self.streaming = false;
                let end = Message::StreamEnd {
                    last_seq: self.builder.last_seq(),
                    dropped: self.builder.dropped_count(),
                };
                encode(seq, &end, out).unwrap_or(0)
            }
            Message::ParamsBegin { len, crc } => {
                if *len as usize > PARAMS_MAX {
                    return refuse(Refusal::TooLarge, "", out);
                }
                self.upload.open = true;
                self.upload.len = *len as usize;
                self.upload.crc = *crc;
                self.upload.got = 0;
                encode(seq, &Message::Ack, out).unwrap_or(0)
            }
            Message::ParamsChunk { offset, data } => {
                let u = &mut self.upload;
                if !u.open {
                    return refuse(Refusal::Unexpected, "", out);
                }
                // No overflow on a 32-bit target, whatever the offset.
                let off = *offset as usize;
                let Some(end) = off.checked_add(data.len()) else {
                    return refuse(Refusal::OutOfOrder, "", out);
                };
                if end <= u.got && u.buf[off..end] == **data {
                    // A repeat (the host did not see our ack).
                } else if off != u.got {
                    return refuse(Refusal::OutOfOrder, "", out);
                } else if end > u.len {
                    return refuse(Refusal::TooLarge, "", out);
                } else {
                    u.buf[off..end].copy_from_slice(data);
                    u.got = end;
                }
                encode(seq, &Message::Ack, out).unwrap_or(0)
            }
            Message::ParamsCommit => self.commit(seq, uptime_ms, out).await,
            Message::ParamsRead { offset } => {
                let total = self.active_len;
                let from = (*offset as usize).min(total);
                let to = (from + CHUNK).min(total);
                let msg = Message::ParamsData {
                    total: total as u32,
                    offset: from as u32,
                    data: &self.active_enc[from..to],
                };
                encode(seq, &msg, out).unwrap_or(0)
            }
            Message::EventsRead { skip } => {
                let mut events = heapless::Vec::<EventRecord, EVENTS_PER_REPLY>::new();
                match self.storage.read_events(*skip, &mut events).await {
                    Ok(stored) => {
                        // The pending events follow the stored ones.
                        let from = skip.saturating_sub(stored) as usize;
                        for ev in self.pending.iter().skip(from) {
                            if events.push(*ev).is_err() {
                                break;
                            }
                        }
                        let msg = Message::Events {
                            total: stored + self.pending.len() as u32,
                            skip: *skip,
                            events,
                        };
                        encode(seq, &msg, out).unwrap_or(0)
                    }
                    Err(_) => refuse(Refusal::Storage, "", out),
                }
            }
            _ => refuse(Refusal::Unexpected, "", out),
        }
    }

    fn identity(&self, seq: u16, out: &mut [u8]) -> usize {
        let id = Identity {
            protocol: PROTOCOL_VERSION,
            firmware: self.info.firmware,
            serial: &self.info.serial,
            params: self.active.id,
            boot: self.boot,
            period_us: self.info.period_us,
        };
        encode(seq, &Message::Identity(id), out).unwrap_or(0)
    }

    async fn commit(&mut self, seq: u16, uptime_ms: u32, out: &mut [u8]) -> usize {
        let refuse = |reason, field: &str, out: &mut [u8]| {
            encode(seq, &Message::Refused { reason, field }, out).unwrap_or(0)
        };
        let u = &mut self.upload;
        if !u.open {
            return refuse(Refusal::Unexpected, "", out);
        }
        u.open = false;
        let enc = &u.buf[..u.got];
        if u.got != u.len || crate::frame::CRC32.checksum(enc) != u.crc {
            return refuse(Refusal::Incomplete, "", out);
        }
        let Some(params) = crate::storage::decode_params(enc) else {
            return refuse(Refusal::Undecodable, "", out);
        };
        if let Err(e) = params.validate() {
            return refuse(Refusal::Invalid, e.field, out);
        }
        // The device stores its own canonical encoding of what it decoded.
        let Some(enc) = encode_params(&params, &mut self.upload.buf) else {
            return refuse(Refusal::TooLarge, "", out);
        };
        let len = enc.len();
        let stored = self.storage.store_params(enc, self.active.id).await;
        let Ok(id) = stored else {
            return refuse(Refusal::Storage, "", out);
        };
        // What boot would pick now must be the new set.
        let now = self.storage.load_params(&self.active.params).await;
        if now.id != id || now.params != params {
            return refuse(Refusal::Storage, "", out);
        }
        self.active = now;
        self.active_enc[..len].copy_from_slice(&self.upload.buf[..len]);
        self.active_len = len;
        self.changed = true;
        // Still out of service (the monitor restarts on the new set).
        self.flush_pending().await;
        let _ = self
            .storage
            .append_event(
                &EventRecord {
                    boot: self.boot,
                    uptime_ms,
                    kind: EventKind::ParamsChanged { params: id },
                },
                Erase::Allowed,
            )
            .await;
        self.identity(seq, out)
    }
}
