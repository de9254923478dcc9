//! What runs on the device, on the bus: the identity frame `LM_Identity`
//! (0x305, every second) names the active parameter set and the node, the
//! version frame `LM_Version` (0x306, every second) the firmware. A
//! controller or `host-sim decode` compares them with the set it uploaded
//! (`host-sim params show` prints the same identity).
//!
//! `LM_Identity`:
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 1 | 4–7 | Node | the sender's node number, 0..=7 ([`Node`]) |
//! | 2–5 | | ParamsCrc | u32, CRC-32 (ISO-HDLC) of the active parameter set's canonical encoding |
//! | 6–7 | | ParamsVersion | u16, its version counter (0: compiled in; +1 per stored upload, wrapping) |
//!
//! `LM_Version`:
//!
//! | byte | bits | signal | unit |
//! |---|---|---|---|
//! | 0 | 0–7 | CRC | E2E P01 |
//! | 1 | 0–3 | Counter | 0..=14 |
//! | 2, 3, 4 | | FirmwareMajor, FirmwareMinor, FirmwarePatch | the firmware's version |
//! | 5 | | LinkProtocol | version of the commissioning link's protocol |
//! | 6–7 | | reserved | 0 |

use super::bytes::{get_u16, put_u16};
use super::signal::SignalList;
use super::{FieldError, Node, Signals};

/// The active parameter set and the node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentityFrame {
    /// The sender's node number.
    pub node: Node,
    /// CRC-32 of the active parameter set's canonical encoding.
    pub params_crc: u32,
    /// Version counter of the active set (low 16 bits; 0: compiled in).
    pub params_version: u16,
}

impl IdentityFrame {
    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[1] = self.node.number() << 4;
        put_u16(d, 2, self.params_crc as u16);
        put_u16(d, 4, (self.params_crc >> 16) as u16);
        put_u16(d, 6, self.params_version);
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        let raw = d[1] >> 4;
        let node = Node::new(raw.into()).ok_or(FieldError {
            field: "Node",
            raw: raw.into(),
        })?;
        Ok(Self {
            node,
            params_crc: u32::from(get_u16(d, 2)) | u32::from(get_u16(d, 4)) << 16,
            params_version: get_u16(d, 6),
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.integer("Node", self.node.number(), "");
        s.checksum("ParamsCrc", self.params_crc);
        s.integer("ParamsVersion", self.params_version, "");
        s.done()
    }
}

/// The firmware's version.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VersionFrame {
    /// Major, minor, patch (semantic version of the firmware crate).
    pub firmware: [u8; 3],
    /// The commissioning link's protocol version.
    pub link_protocol: u8,
}

impl VersionFrame {
    pub(crate) fn write(&self, d: &mut [u8; 8]) {
        d[2..5].copy_from_slice(&self.firmware);
        d[5] = self.link_protocol;
    }

    pub(crate) fn read(d: &[u8; 8]) -> Result<Self, FieldError> {
        Ok(Self {
            firmware: [d[2], d[3], d[4]],
            link_protocol: d[5],
        })
    }

    /// The signals, as in the DBC.
    pub fn signals(&self) -> Signals {
        let mut s = SignalList::new();
        s.integer("FirmwareMajor", self.firmware[0], "");
        s.integer("FirmwareMinor", self.firmware[1], "");
        s.integer("FirmwarePatch", self.firmware[2], "");
        s.integer("LinkProtocol", self.link_protocol, "");
        s.done()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_round_trip_and_layout() {
        let f = IdentityFrame {
            node: Node::new(5).unwrap(),
            params_crc: 0xA1B2_C3D4,
            params_version: 0x1234,
        };
        let mut d = [0u8; 8];
        f.write(&mut d);
        assert_eq!(d[1], 0x50);
        assert_eq!(d[2..8], [0xD4, 0xC3, 0xB2, 0xA1, 0x34, 0x12]);
        assert_eq!(IdentityFrame::read(&d), Ok(f));
        d[1] = 0x80;
        assert_eq!(IdentityFrame::read(&d).unwrap_err().field, "Node");
    }

    #[test]
    fn version_round_trip_and_layout() {
        let f = VersionFrame {
            firmware: [2, 3, 4],
            link_protocol: 9,
        };
        let mut d = [0u8; 8];
        f.write(&mut d);
        assert_eq!(d[2..8], [2, 3, 4, 9, 0, 0]);
        assert_eq!(VersionFrame::read(&d), Ok(f));
    }
}
