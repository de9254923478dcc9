//! The CAN protocol of the leak monitor, defined once for the firmware and
//! `host-sim` (and described by `can/leak-monitor.dbc`).
//!
//! Classic CAN, 500 kbit/s, 11-bit identifiers, 8 data bytes, every
//! multi-byte field little-endian (DBC byte order Intel). Every frame is
//! protected as AUTOSAR E2E profile 1 ([`e2e`]): byte 0 CRC-8 (SAE J1850
//! polynomial) over the identifier and bytes 1..8, rolling counter 0..=14
//! in the low nibble of byte 1.
//!
//! | id | frame | sent |
//! |---|---|---|
//! | 0x300 | [`AlarmFrame`] | at once on any change of the alarm output, and every 1 s |
//! | 0x301 | [`StatusFrame`] | every 100 ms |
//! | 0x302 | [`DetailFrame`] | every 1 s |
//! | 0x303 | [`HeartbeatFrame`] | every 1 s |
//! | 0x304 | [`ChallengeFrame`] | at once when it changes, and every 1 s |
//! | 0x305 | [`IdentityFrame`] | every 1 s: node, active parameter set |
//! | 0x306 | [`VersionFrame`] | every 1 s: firmware version |
//! | 0x307 | [`SensitivityFrame`] | every 1 s: the alarm level in use per leak (what `healthy` is measured against), evidence weight |
//! | 0x310 | [`CommandFrame`] | received: acknowledge a latched alarm, authenticated over the current challenge ([`auth`]) |
//!
//! The identifiers are node 0's. On a bus shared by several monitors each
//! has a node number ([`Node`], 0..=7, from the parameters' `can.node`)
//! that moves its whole block by `0x20 · node` (node 3: 0x360–0x367 and
//! the command at 0x370); the E2E Data ID and the acknowledge MAC use the
//! moved identifier, so a frame meant for one node fails every check on
//! another.
//!
//! Message structs hold each field as an integer in its wire unit (named
//! in the field), so encode → decode is exact; the conversions from the
//! monitor's floating-point [`Status`](crate::Status) round and saturate.

pub mod alarm;
pub mod auth;
pub mod challenge;
pub mod command;
pub mod detail;
pub mod e2e;
pub mod gate;
pub mod heartbeat;
pub mod identity;
pub mod outbox;
pub mod p01_receiver;
pub mod schedule;
pub mod sensitivity;
pub mod signal;
pub mod status;

pub use alarm::AlarmFrame;
pub use challenge::ChallengeFrame;
pub use command::{Authentic, Command, CommandFrame, CommandReceiver, CommandRejected};
pub use detail::DetailFrame;
pub use e2e::{E2eError, Sequence};
pub use heartbeat::{HeartbeatFrame, ResetCause};
pub use identity::{IdentityFrame, VersionFrame};
pub use sensitivity::SensitivityFrame;
pub use signal::{Signal, SignalValue, Signals};
pub use status::StatusFrame;

/// Bus bit rate, bit/s.
pub const BITRATE_BPS: u32 = 500_000;

/// Data bytes in every frame.
pub const FRAME_LEN: usize = 8;

/// A monitor's node number on a shared bus: moves its identifier block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Node(u8);

impl Node {
    /// The default node: the identifiers of the table above.
    pub const DEFAULT: Node = Node(0);
    /// Highest node number.
    pub const MAX: u8 = 7;
    /// Identifier distance between two nodes' blocks.
    pub const STRIDE: u16 = 0x20;
    /// Every node, in number order.
    pub const ALL: [Node; Self::MAX as usize + 1] = [
        Node(0),
        Node(1),
        Node(2),
        Node(3),
        Node(4),
        Node(5),
        Node(6),
        Node(7),
    ];

    /// Node `number`, if it is one (0..=[`Self::MAX`]).
    pub const fn new(number: u32) -> Option<Node> {
        if number <= Self::MAX as u32 {
            Some(Node(number as u8))
        } else {
            None
        }
    }

    /// The node's number.
    pub const fn number(self) -> u8 {
        self.0
    }
}

/// The frames of the protocol, in identifier (= bus priority) order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MessageKind {
    /// Alarm output (state, latched leak, relay).
    Alarm = 0,
    /// Verdict, leak sizes, health flags.
    Status = 1,
    /// Leak uncertainties, leading hypothesis, valve wear.
    Detail = 2,
    /// Liveness, reset cause, deadline and CPU load.
    Heartbeat = 3,
    /// The acknowledge challenge, key kind, last acknowledge outcome.
    Challenge = 4,
    /// Node number and the active parameter set's identity.
    Identity = 5,
    /// Firmware version.
    Version = 6,
    /// Alarm level in use per leak, evidence weight.
    Sensitivity = 7,
    /// Received command (acknowledge alarm).
    Command = 8,
}

impl MessageKind {
    /// Every kind, in identifier order.
    pub const ALL: [MessageKind; 9] = [
        Self::Alarm,
        Self::Status,
        Self::Detail,
        Self::Heartbeat,
        Self::Challenge,
        Self::Identity,
        Self::Version,
        Self::Sensitivity,
        Self::Command,
    ];

    /// Number of kinds.
    pub const COUNT: usize = Self::ALL.len();

    /// 11-bit CAN identifier; also the E2E Data ID.
    pub const fn id(self) -> u16 {
        match self {
            Self::Alarm => 0x300,
            Self::Status => 0x301,
            Self::Detail => 0x302,
            Self::Heartbeat => 0x303,
            Self::Challenge => 0x304,
            Self::Identity => 0x305,
            Self::Version => 0x306,
            Self::Sensitivity => 0x307,
            Self::Command => 0x310,
        }
    }

    /// 11-bit CAN identifier at `node` (see [`Node`]); also the E2E Data
    /// ID.
    pub const fn id_at(self, node: Node) -> u16 {
        self.id() + node.0 as u16 * Node::STRIDE
    }

    /// The kind of a node-0 identifier, if it is one of ours.
    pub fn from_id(id: u16) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.id() == id)
    }

    /// The kind and node of an identifier of any node's block.
    pub fn locate(id: u16) -> Option<(Self, Node)> {
        let base = Self::Alarm.id();
        let offset = id.checked_sub(base)?;
        let node = Node::new(u32::from(offset / Node::STRIDE))?;
        Some((Self::from_id(base + offset % Node::STRIDE)?, node))
    }

    /// Message name in the DBC file.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Alarm => "LM_Alarm",
            Self::Status => "LM_Status",
            Self::Detail => "LM_Detail",
            Self::Heartbeat => "LM_Heartbeat",
            Self::Challenge => "LM_Challenge",
            Self::Identity => "LM_Identity",
            Self::Version => "LM_Version",
            Self::Sensitivity => "LM_Sensitivity",
            Self::Command => "LM_Command",
        }
    }
}

/// A classic CAN data frame with a standard identifier, as sent or
/// received.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CanFrame {
    id: u16,
    len: u8,
    data: [u8; FRAME_LEN],
}

impl CanFrame {
    /// A frame; `None` if `id` is not an 11-bit identifier or `data` is
    /// longer than 8 bytes.
    pub fn new(id: u16, data: &[u8]) -> Option<Self> {
        if id > 0x7FF || data.len() > FRAME_LEN {
            return None;
        }
        let mut d = [0u8; FRAME_LEN];
        d[..data.len()].copy_from_slice(data);
        Some(Self {
            id,
            len: data.len() as u8,
            data: d,
        })
    }

    /// The 11-bit identifier.
    pub const fn id(&self) -> u16 {
        self.id
    }

    /// The data bytes.
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }
}

impl embedded_can::Frame for CanFrame {
    fn new(id: impl Into<embedded_can::Id>, data: &[u8]) -> Option<Self> {
        match id.into() {
            embedded_can::Id::Standard(s) => CanFrame::new(s.as_raw(), data),
            embedded_can::Id::Extended(_) => None,
        }
    }

    fn new_remote(_id: impl Into<embedded_can::Id>, _dlc: usize) -> Option<Self> {
        None
    }

    fn is_extended(&self) -> bool {
        false
    }

    fn is_remote_frame(&self) -> bool {
        false
    }

    fn id(&self) -> embedded_can::Id {
        // `new` only accepts 11-bit identifiers.
        embedded_can::StandardId::new(self.id)
            .unwrap_or(embedded_can::StandardId::ZERO)
            .into()
    }

    fn dlc(&self) -> usize {
        self.len as usize
    }

    fn data(&self) -> &[u8] {
        CanFrame::data(self)
    }
}

/// One decoded message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message {
    /// Alarm output.
    Alarm(AlarmFrame),
    /// Status.
    Status(StatusFrame),
    /// Detail.
    Detail(DetailFrame),
    /// Heartbeat.
    Heartbeat(HeartbeatFrame),
    /// Challenge.
    Challenge(ChallengeFrame),
    /// Identity.
    Identity(IdentityFrame),
    /// Version.
    Version(VersionFrame),
    /// Sensitivity.
    Sensitivity(SensitivityFrame),
    /// Command.
    Command(CommandFrame),
}

impl Message {
    /// Which frame this is.
    pub const fn kind(&self) -> MessageKind {
        match self {
            Self::Alarm(_) => MessageKind::Alarm,
            Self::Status(_) => MessageKind::Status,
            Self::Detail(_) => MessageKind::Detail,
            Self::Heartbeat(_) => MessageKind::Heartbeat,
            Self::Challenge(_) => MessageKind::Challenge,
            Self::Identity(_) => MessageKind::Identity,
            Self::Version(_) => MessageKind::Version,
            Self::Sensitivity(_) => MessageKind::Sensitivity,
            Self::Command(_) => MessageKind::Command,
        }
    }

    /// Every signal of the message (the DBC's names, physical values).
    pub fn signals(&self) -> Signals {
        match self {
            Self::Alarm(m) => m.signals(),
            Self::Status(m) => m.signals(),
            Self::Detail(m) => m.signals(),
            Self::Heartbeat(m) => m.signals(),
            Self::Challenge(m) => m.signals(),
            Self::Identity(m) => m.signals(),
            Self::Version(m) => m.signals(),
            Self::Sensitivity(m) => m.signals(),
            Self::Command(m) => m.signals(),
        }
    }

    fn write(&self, d: &mut [u8; FRAME_LEN]) {
        match self {
            Self::Alarm(m) => m.write(d),
            Self::Status(m) => m.write(d),
            Self::Detail(m) => m.write(d),
            Self::Heartbeat(m) => m.write(d),
            Self::Challenge(m) => m.write(d),
            Self::Identity(m) => m.write(d),
            Self::Version(m) => m.write(d),
            Self::Sensitivity(m) => m.write(d),
            Self::Command(m) => m.write(d),
        }
    }

    fn read(kind: MessageKind, d: &[u8; FRAME_LEN]) -> Result<Self, FieldError> {
        Ok(match kind {
            MessageKind::Alarm => Self::Alarm(AlarmFrame::read(d)?),
            MessageKind::Status => Self::Status(StatusFrame::read(d)?),
            MessageKind::Detail => Self::Detail(DetailFrame::read(d)?),
            MessageKind::Heartbeat => Self::Heartbeat(HeartbeatFrame::read(d)?),
            MessageKind::Challenge => Self::Challenge(ChallengeFrame::read(d)?),
            MessageKind::Identity => Self::Identity(IdentityFrame::read(d)?),
            MessageKind::Version => Self::Version(VersionFrame::read(d)?),
            MessageKind::Sensitivity => Self::Sensitivity(SensitivityFrame::read(d)?),
            MessageKind::Command => Self::Command(CommandFrame::read(d)?),
        })
    }
}

/// A field whose raw value has no meaning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FieldError {
    /// Signal name (as in the DBC).
    pub field: &'static str,
    /// The raw value found.
    pub raw: u32,
}

/// Why a received frame was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// Extended identifier or remote frame: not ours.
    NotADataFrame,
    /// A standard identifier that is not in the protocol.
    UnknownId(u16),
    /// Wrong number of data bytes.
    Length {
        /// The frame.
        kind: MessageKind,
        /// Bytes received.
        len: u8,
    },
    /// CRC or counter invalid.
    E2e {
        /// The frame.
        kind: MessageKind,
        /// What is wrong.
        error: E2eError,
    },
    /// A field holds an undefined value.
    Field {
        /// The frame.
        kind: MessageKind,
        /// The field.
        error: FieldError,
    },
}

/// Builds protected frames: one rolling counter per frame kind.
#[derive(Clone, Debug, Default)]
pub struct Encoder {
    node: Node,
    counters: [e2e::Counter; MessageKind::COUNT],
}

impl Encoder {
    /// An encoder for node 0 whose counters all start at 0.
    pub const fn new() -> Self {
        Self::for_node(Node::DEFAULT)
    }

    /// An encoder for `node`'s identifiers whose counters all start at 0.
    pub const fn for_node(node: Node) -> Self {
        Self {
            node,
            counters: [e2e::Counter::new(); MessageKind::COUNT],
        }
    }

    /// The protected frame for `msg`, with the next counter of its kind.
    pub fn encode(&mut self, msg: &Message) -> CanFrame {
        let kind = msg.kind();
        let mut data = [0u8; FRAME_LEN];
        msg.write(&mut data);
        let counter = self.counters[kind as usize].next_value();
        let id = kind.id_at(self.node);
        e2e::protect(id, &mut data, counter);
        CanFrame {
            id,
            len: FRAME_LEN as u8,
            data,
        }
    }
}

/// A frame that passed the checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Received {
    /// The message.
    pub message: Message,
    /// Its E2E counter.
    pub counter: u8,
    /// How the counter follows the previous frame of the same kind.
    pub sequence: Sequence,
}

/// Checks and decodes received frames of one node; tracks one counter per
/// kind.
#[derive(Clone, Debug, Default)]
pub struct Decoder {
    node: Node,
    checks: [e2e::CounterCheck; MessageKind::COUNT],
}

impl Decoder {
    /// A decoder for node 0 that has seen no frame yet.
    pub const fn new() -> Self {
        Self::for_node(Node::DEFAULT)
    }

    /// A decoder for `node`'s frames (others are [`DecodeError::UnknownId`])
    /// that has seen no frame yet.
    pub const fn for_node(node: Node) -> Self {
        Self {
            node,
            checks: [e2e::CounterCheck::new(); MessageKind::COUNT],
        }
    }

    /// Check (identifier, length, CRC, counter range, fields) and decode
    /// `frame`. Only a frame that passed every check advances the counter
    /// check: a bad CRC or an undefined field leaves it as it was. (The
    /// command frame's tag is not checked here: [`CommandReceiver`].)
    pub fn decode(&mut self, frame: &impl embedded_can::Frame) -> Result<Received, DecodeError> {
        let id = match frame.id() {
            embedded_can::Id::Standard(s) if !frame.is_remote_frame() => s.as_raw(),
            _ => return Err(DecodeError::NotADataFrame),
        };
        let kind = match MessageKind::locate(id) {
            Some((kind, node)) if node == self.node => kind,
            _ => return Err(DecodeError::UnknownId(id)),
        };
        let data: &[u8; FRAME_LEN] = frame.data().try_into().map_err(|_| DecodeError::Length {
            kind,
            len: frame.data().len() as u8,
        })?;
        let counter = e2e::check(id, data).map_err(|error| DecodeError::E2e { kind, error })?;
        let message =
            Message::read(kind, data).map_err(|error| DecodeError::Field { kind, error })?;
        let sequence = self.checks[kind as usize].check(counter);
        Ok(Received {
            message,
            counter,
            sequence,
        })
    }
}

/// Little-endian field access on a frame's bytes.
pub(crate) mod bytes {
    /// u16 at byte `at`.
    pub fn get_u16(d: &[u8; 8], at: usize) -> u16 {
        u16::from_le_bytes([d[at], d[at + 1]])
    }

    /// Write u16 at byte `at`.
    pub fn put_u16(d: &mut [u8; 8], at: usize, v: u16) {
        d[at..at + 2].copy_from_slice(&v.to_le_bytes());
    }

    /// The i16 code that means "not available".
    pub const I16_NOT_AVAILABLE: i16 = i16::MIN;

    /// Optional i16 at byte `at` (`I16_NOT_AVAILABLE` is `None`).
    pub fn get_opt_i16(d: &[u8; 8], at: usize) -> Option<i16> {
        match get_u16(d, at) as i16 {
            I16_NOT_AVAILABLE => None,
            v => Some(v),
        }
    }

    /// Write an optional i16 at byte `at` (`None` as `I16_NOT_AVAILABLE`).
    pub fn put_opt_i16(d: &mut [u8; 8], at: usize, v: Option<i16>) {
        put_u16(d, at, v.unwrap_or(I16_NOT_AVAILABLE) as u16);
    }

    /// u32 at byte `at`.
    pub fn get_u32(d: &[u8; 8], at: usize) -> u32 {
        u32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
    }

    /// Write u32 at byte `at`.
    pub fn put_u32(d: &mut [u8; 8], at: usize, v: u32) {
        d[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
}

/// Rounding conversions from the monitor's floating-point values to wire
/// integers.
pub(crate) mod quantize {
    /// `v` in thousandths as an i16 (l/min → ml/min, relative → ‰),
    /// rounded and saturated to ±`i16::MAX` (`i16::MIN` is reserved for
    /// "not available").
    pub fn milli_i16(v: Option<f32>) -> Option<i16> {
        to_i32(v, 1e-3, -(i16::MAX as i32), i16::MAX as i32).map(|v| v as i16)
    }

    /// `v / step` rounded to the nearest integer and saturated to
    /// `[lo, hi]`; `None` for NaN or a missing value.
    pub fn to_i32(v: Option<f32>, step: f32, lo: i32, hi: i32) -> Option<i32> {
        let v = v?;
        if v.is_nan() {
            return None;
        }
        let q = libm::roundf(v / step);
        Some(if q <= lo as f32 {
            lo
        } else if q >= hi as f32 {
            hi
        } else {
            q as i32
        })
    }
}

#[cfg(test)]
mod tests;
