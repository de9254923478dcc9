//! The bodies of the fuzz targets, one module each, as plain functions of
//! the input bytes: `fuzz_targets/*.rs` hand them to libFuzzer (nightly,
//! `cargo fuzz run`), `tests/corpus.rs` replays `corpus/<target>/*`
//! through them on stable. Each panics when a property the code promises
//! does not hold.

pub mod candump;
pub mod command_gate;
pub mod params;
pub mod protocol_decoder;
pub mod recording;

/// A target's body.
pub type Target = fn(&[u8]);

/// Every target by its name (the directory of its corpus).
pub const TARGETS: [(&str, Target); 5] = [
    ("recording", recording::run),
    ("params", params::run),
    ("candump", candump::run),
    ("protocol_decoder", protocol_decoder::run),
    ("command_gate", command_gate::run),
];

/// Reads fixed-size values off the input; zeros once it is used up.
pub(crate) struct Cursor<'a>(&'a [u8]);

impl<'a> Cursor<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Self(data)
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn bytes<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        let n = N.min(self.0.len());
        out[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        out
    }

    pub fn u8(&mut self) -> u8 {
        self.bytes::<1>()[0]
    }

    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.bytes())
    }

    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.bytes())
    }

    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.bytes())
    }
}

/// A CAN frame of any kind (extended, remote, any length up to 8), for
/// the receivers' `impl embedded_can::Frame` inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct AnyFrame {
    pub id: embedded_can::Id,
    pub remote: bool,
    pub len: u8,
    pub data: [u8; 8],
}

impl AnyFrame {
    /// Layout: flags (bit 0 extended, bit 1 remote), id (u32, masked to
    /// 11 or 29 bits), length (mod 9), 8 data bytes.
    pub fn read(c: &mut Cursor) -> Self {
        let flags = c.u8();
        let raw = c.u32();
        let id = if flags & 1 != 0 {
            embedded_can::Id::Extended(
                embedded_can::ExtendedId::new(raw & 0x1FFF_FFFF).expect("29 bits"),
            )
        } else {
            embedded_can::Id::Standard(
                embedded_can::StandardId::new((raw & 0x7FF) as u16).expect("11 bits"),
            )
        };
        let len = c.u8() % 9;
        Self {
            id,
            remote: flags & 2 != 0,
            len,
            data: c.bytes(),
        }
    }

    pub fn standard_id(&self) -> Option<u16> {
        match self.id {
            embedded_can::Id::Standard(s) => Some(s.as_raw()),
            embedded_can::Id::Extended(_) => None,
        }
    }
}

impl embedded_can::Frame for AnyFrame {
    fn new(id: impl Into<embedded_can::Id>, data: &[u8]) -> Option<Self> {
        let mut d = [0u8; 8];
        d.get_mut(..data.len())?.copy_from_slice(data);
        Some(Self {
            id: id.into(),
            remote: false,
            len: data.len() as u8,
            data: d,
        })
    }

    fn new_remote(id: impl Into<embedded_can::Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| Self {
            id: id.into(),
            remote: true,
            len: dlc as u8,
            data: [0; 8],
        })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, embedded_can::Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> embedded_can::Id {
        self.id
    }

    fn dlc(&self) -> usize {
        self.len as usize
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            &self.data[..self.len as usize]
        }
    }
}
