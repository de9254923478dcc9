//! FNV-1a, 64 bit: a tiny, portable, deterministic hash (integer
//! arithmetic only, so host and target agree by construction).

/// A running FNV-1a 64-bit hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv64(u64);

const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const PRIME: u64 = 0x0000_0100_0000_01b3;

impl Default for Fnv64 {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv64 {
    /// The empty hash.
    pub const fn new() -> Self {
        Self(OFFSET)
    }

    /// Feed bytes.
    #[inline]
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ x as u64).wrapping_mul(PRIME);
        }
    }

    /// Feed one byte.
    #[inline]
    pub fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }

    /// Feed a `u16`, little-endian.
    #[inline]
    pub fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }

    /// Feed a `u32`, little-endian.
    #[inline]
    pub fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }

    /// Feed a `u64`, little-endian.
    #[inline]
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }

    /// Feed an `f32` as its bit pattern (distinguishes −0 from +0 and every
    /// NaN payload: bit identity, not numeric equality).
    #[inline]
    pub fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }

    /// Feed an `f64` as its bit pattern.
    #[inline]
    pub fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }

    /// The hash so far.
    pub const fn value(&self) -> u64 {
        self.0
    }

    /// The hash so far folded to 16 bits (XOR of its four 16-bit words).
    pub const fn fold16(&self) -> u16 {
        let v = self.0;
        (v ^ (v >> 16) ^ (v >> 32) ^ (v >> 48)) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_vectors() {
        // Reference values of FNV-1a 64.
        assert_eq!(Fnv64::new().value(), 0xcbf2_9ce4_8422_2325);
        let mut h = Fnv64::new();
        h.bytes(b"a");
        assert_eq!(h.value(), 0xaf63_dc4c_8601_ec8c);
        let mut h = Fnv64::new();
        h.bytes(b"foobar");
        assert_eq!(h.value(), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn bit_patterns_not_values() {
        let mut a = Fnv64::new();
        a.f32(0.0);
        let mut b = Fnv64::new();
        b.f32(-0.0);
        assert_ne!(a, b);
    }
}
