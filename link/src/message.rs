//! What travels in a frame: commands (host → device), replies and the
//! sample stream (device → host), and the stored event records.
//!
//! Everything is encoded with `postcard` (little-endian, varint integers,
//! `f32` as its four IEEE-754 bytes): the encoding of a value is unique, so
//! the CRC of a parameter set's encoding identifies it.

use monitor::{Channel, Sample};
use serde::{Deserialize, Serialize};

/// Version of this protocol, in [`Identity::protocol`]. A host refuses a
/// device that speaks another one.
pub const PROTOCOL_VERSION: u8 = 1;

/// Samples per [`SampleBlock`]: 10 ms of the 1 kHz stream.
pub const SAMPLES_PER_BLOCK: usize = 10;

/// Most parameter bytes one chunk carries (upload and read-back).
pub const CHUNK: usize = 128;

/// Most events one [`Message::Events`] reply carries.
pub const EVENTS_PER_REPLY: usize = 8;

/// Number of channels in a [`WireSample`].
pub const CHANNELS: usize = Channel::ALL.len();

/// One message. Its variant index (postcard's first byte) is the frame's
/// type.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message<'a> {
    // ---- host → device ----
    /// Ask for the device's [`Identity`].
    GetIdentity,
    /// Start the sample stream ([`Message::Block`] frames); replied with
    /// [`Message::Ack`].
    StartStream,
    /// Stop it; replied with [`Message::StreamEnd`].
    StopStream,
    /// Begin a parameter upload of `len` bytes (the canonical encoding of
    /// a `monitor::Params`) whose CRC-32 is `crc`.
    ParamsBegin {
        /// Length of the encoding, bytes.
        len: u32,
        /// CRC-32 (ISO-HDLC) of the encoding.
        crc: u32,
    },
    /// Bytes `offset..offset + data.len()` of the upload, in order.
    ParamsChunk {
        /// Position of `data` in the encoding.
        offset: u32,
        /// At most [`CHUNK`] bytes.
        #[serde(borrow)]
        data: &'a [u8],
    },
    /// Validate, store, read back and activate the uploaded set; replied
    /// with the new [`Identity`] or a [`Message::Refused`].
    ParamsCommit,
    /// Read the active set's encoding from `offset` (replied with
    /// [`Message::ParamsData`]).
    ParamsRead {
        /// Position to read from.
        offset: u32,
    },
    /// Read stored events, oldest first, skipping the first `skip`
    /// (replied with [`Message::Events`]).
    EventsRead {
        /// Events to skip.
        skip: u32,
    },

    // ---- device → host ----
    /// Who is running what.
    Identity(#[serde(borrow)] Identity<'a>),
    /// A command was carried out.
    Ack,
    /// A command was refused.
    Refused {
        /// Why.
        reason: Refusal,
        /// The offending parameter (`section.field`) for
        /// [`Refusal::Invalid`], else empty.
        field: &'a str,
    },
    /// Samples. Sent unprompted while streaming.
    Block(SampleBlock),
    /// Reply to [`Message::StopStream`]: the last block sequence number
    /// the device assigned (sent or dropped) and how many it dropped.
    StreamEnd {
        /// Sequence number of the last block, `u32::MAX` if none.
        last_seq: u32,
        /// Blocks the device dropped because the host was slow.
        dropped: u32,
    },
    /// Part of the active parameter encoding.
    ParamsData {
        /// Length of the whole encoding.
        total: u32,
        /// Position of `data`.
        offset: u32,
        /// At most [`CHUNK`] bytes (empty at or past the end).
        data: &'a [u8],
    },
    /// Stored events.
    Events {
        /// Number of events stored.
        total: u32,
        /// Index of the first event in `events`.
        skip: u32,
        /// Up to [`EVENTS_PER_REPLY`] events, oldest first.
        events: heapless::Vec<EventRecord, EVENTS_PER_REPLY>,
    },
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// The command is unknown or not allowed now (e.g. a chunk without a
    /// begin).
    Unexpected,
    /// The upload is larger than the device accepts.
    TooLarge,
    /// A chunk is not where the upload stands.
    OutOfOrder,
    /// The upload's length or CRC does not match its begin.
    Incomplete,
    /// The bytes are not a parameter set of this firmware.
    Undecodable,
    /// `Params::validate` refused the set (see `field`).
    Invalid,
    /// Writing or reading back the flash failed; the old set stays active.
    Storage,
}

/// Identity of a parameter set: the CRC-32 of its canonical encoding and
/// the version counter it was stored with (0: the compiled-in default).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamsId {
    /// Version counter, incremented by every stored upload.
    pub version: u32,
    /// CRC-32 (ISO-HDLC) of the encoding.
    pub crc: u32,
}

/// What a device is and runs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Identity<'a> {
    /// [`PROTOCOL_VERSION`] of the device.
    pub protocol: u8,
    /// Firmware version (`CARGO_PKG_VERSION` of the firmware).
    pub firmware: &'a str,
    /// Board serial number (from the MCU's unique ID).
    pub serial: &'a str,
    /// The active parameter set.
    pub params: ParamsId,
    /// Boot counter (incremented at every start).
    pub boot: u32,
    /// Sample period of the stream, µs.
    pub period_us: u32,
}

/// One sample as the monitor saw it: bit `c` of `valid` set when channel
/// `c` (`Channel as usize`) holds a reading, the value in engineering
/// units (`Sample`'s units) as the monitor's `f32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WireSample {
    /// Validity mask, bit per channel.
    pub valid: u8,
    /// Values in `Channel::ALL` order (0 where not valid).
    pub values: [f32; CHANNELS],
}

impl WireSample {
    /// The sample's readings (its time is not carried here).
    pub fn from_sample(s: &Sample) -> Self {
        let mut w = Self::default();
        for c in Channel::ALL {
            if let Some(v) = s.get(c) {
                w.valid |= c.bit();
                w.values[c as usize] = v;
            }
        }
        w
    }

    /// The reading of `c`.
    pub fn get(&self, c: Channel) -> Option<f32> {
        (self.valid & c.bit() != 0).then_some(self.values[c as usize])
    }

    /// Back to a [`Sample`] at time `t_s`.
    pub fn to_sample(&self, t_s: f64) -> Sample {
        Sample {
            t_s,
            p_supply_bar: self.get(Channel::PSupply),
            p_piston_bar: self.get(Channel::PPiston),
            p_rod_bar: self.get(Channel::PRod),
            p_tank_bar: self.get(Channel::PTank),
            x_piston_m: self.get(Channel::XPiston),
            u_valve: self.get(Channel::UValve),
            temp_oil_c: self.get(Channel::TempOil),
        }
    }
}

/// [`SAMPLES_PER_BLOCK`] consecutive samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleBlock {
    /// Block sequence number: +1 for every block the device completes,
    /// whether it is sent or dropped, so the host sees every gap.
    pub seq: u32,
    /// Sample counter (monitor steps since boot) of the first sample.
    pub first_tick: u32,
    /// Blocks the device has dropped so far in this stream.
    pub dropped: u32,
    /// The samples.
    pub samples: [WireSample; SAMPLES_PER_BLOCK],
}

/// A leak named in an alarm event.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Leak {
    /// Across the piston seal.
    Internal,
    /// Rod side to tank.
    External,
    /// Both.
    Both,
}

/// Why the device (re)started.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// Power on.
    PowerOn,
    /// Supply dropped below the brown-out level.
    BrownOut,
    /// Independent or window watchdog.
    Watchdog,
    /// Software request (e.g. after a fault).
    Software,
    /// The reset pin.
    Pin,
    /// Not known.
    Unknown,
}

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum EventKind {
    /// A leak alarm was raised, with the estimated leak flows, l/min.
    AlarmRaised {
        /// Which leak.
        leak: Leak,
        /// Internal leak flow, l/min.
        internal_lpm: f32,
        /// External leak flow, l/min.
        external_lpm: f32,
    },
    /// The alarm cleared, with the leak flows at that moment, l/min.
    AlarmCleared {
        /// Internal leak flow, l/min.
        internal_lpm: f32,
        /// External leak flow, l/min.
        external_lpm: f32,
    },
    /// Sensor faults began on these channels (`Channel::bit` mask).
    SensorFault {
        /// Channel mask.
        channels: u8,
    },
    /// The sensor faults of these channels ended.
    SensorRecovered {
        /// Channel mask.
        channels: u8,
    },
    /// The operator acknowledged the alarm.
    Acknowledged,
    /// The device started.
    Reset {
        /// Why.
        cause: ResetCause,
    },
    /// A new parameter set became active.
    ParamsChanged {
        /// Its identity.
        params: ParamsId,
    },
}

/// One stored event.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventRecord {
    /// Boot counter at the time.
    pub boot: u32,
    /// Milliseconds since that boot.
    pub uptime_ms: u32,
    /// What happened.
    pub kind: EventKind,
}

/// Largest encoding of an [`EventRecord`].
pub const MAX_EVENT_BYTES: usize = 32;
