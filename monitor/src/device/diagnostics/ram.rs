//! The start-up RAM test: March C− over the statics, before they are
//! initialised. March C− finds every stuck-at, transition and address
//! decoder fault and the usual coupling faults between cells (IEC 61508-2
//! Table A.6, "RAM test March").
//!
//! The march runs over a [`WordMemory`], so the firmware passes the real
//! RAM (volatile accesses) and the tests pass a memory with injected
//! faults.

/// Memory the march can read and write, a 32-bit word at a time.
pub trait WordMemory {
    /// Number of words.
    fn words(&self) -> usize;
    /// Read word `i`.
    fn read(&self, i: usize) -> u32;
    /// Write word `i`.
    fn write(&mut self, i: usize, v: u32);
}

impl WordMemory for [u32] {
    fn words(&self) -> usize {
        self.len()
    }
    fn read(&self, i: usize) -> u32 {
        self[i]
    }
    fn write(&mut self, i: usize, v: u32) {
        self[i] = v;
    }
}

/// A cell that did not hold what was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RamFault {
    /// Word index from the start of the tested region.
    pub word: usize,
    /// What the march expected.
    pub expected: u32,
    /// What it read.
    pub found: u32,
}

/// The two backgrounds: all zeros, then all ones, in every bit.
const ZERO: u32 = 0;
const ONE: u32 = u32::MAX;

/// March C−: ⇕(w0); ⇑(r0,w1); ⇑(r1,w0); ⇓(r0,w1); ⇓(r1,w0); ⇕(r0).
/// Leaves the memory all zeros (the state `.bss` expects anyway).
pub fn march_c_minus<M: WordMemory + ?Sized>(m: &mut M) -> Result<(), RamFault> {
    let n = m.words();
    for i in 0..n {
        m.write(i, ZERO);
    }
    for i in 0..n {
        element(m, i, ZERO, ONE)?;
    }
    for i in 0..n {
        element(m, i, ONE, ZERO)?;
    }
    for i in (0..n).rev() {
        element(m, i, ZERO, ONE)?;
    }
    for i in (0..n).rev() {
        element(m, i, ONE, ZERO)?;
    }
    for i in 0..n {
        expect(m, i, ZERO)?;
    }
    Ok(())
}

fn element<M: WordMemory + ?Sized>(
    m: &mut M,
    i: usize,
    read: u32,
    write: u32,
) -> Result<(), RamFault> {
    expect(m, i, read)?;
    m.write(i, write);
    Ok(())
}

fn expect<M: WordMemory + ?Sized>(m: &M, i: usize, expected: u32) -> Result<(), RamFault> {
    let found = m.read(i);
    if found == expected {
        Ok(())
    } else {
        Err(RamFault {
            word: i,
            expected,
            found,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Memory with one injected fault.
    struct Faulty {
        cells: [u32; 64],
        fault: Fault,
    }

    #[derive(Clone, Copy)]
    enum Fault {
        /// Bit `bit` of word `word` always reads `value`.
        StuckAt { word: usize, bit: u32, value: bool },
        /// Writing word `a` also writes word `b` (address decoder).
        Alias { a: usize, b: usize },
        /// A rising transition of bit 0 in word `a` inverts bit 0 of `b`.
        Coupling { a: usize, b: usize },
    }

    impl WordMemory for Faulty {
        fn words(&self) -> usize {
            self.cells.len()
        }
        fn read(&self, i: usize) -> u32 {
            match self.fault {
                Fault::StuckAt { word, bit, value } if word == i => {
                    (self.cells[i] & !(1 << bit)) | ((value as u32) << bit)
                }
                _ => self.cells[i],
            }
        }
        fn write(&mut self, i: usize, v: u32) {
            let old = self.cells[i];
            self.cells[i] = v;
            match self.fault {
                Fault::Alias { a, b } if a == i => self.cells[b] = v,
                Fault::Coupling { a, b } if a == i && old & 1 == 0 && v & 1 == 1 => {
                    self.cells[b] ^= 1
                }
                _ => {}
            }
        }
    }

    #[test]
    fn good_memory_passes_and_is_left_zeroed() {
        let mut m = [0xDEAD_BEEFu32; 256];
        assert_eq!(march_c_minus(&mut m[..]), Ok(()));
        assert!(m.iter().all(|&w| w == 0));
    }

    #[test]
    fn every_injected_fault_is_found_at_its_cell() {
        for word in [0, 17, 63] {
            for bit in [0, 13, 31] {
                for value in [false, true] {
                    let mut m = Faulty {
                        cells: [0; 64],
                        fault: Fault::StuckAt { word, bit, value },
                    };
                    let e = march_c_minus(&mut m).expect_err("stuck-at found");
                    assert_eq!(e.word, word, "stuck-at {value} at word {word} bit {bit}");
                }
            }
        }
        for (a, b) in [(3, 40), (40, 3), (0, 63)] {
            let mut m = Faulty {
                cells: [0; 64],
                fault: Fault::Alias { a, b },
            };
            assert!(march_c_minus(&mut m).is_err(), "alias {a}→{b}");
            let mut m = Faulty {
                cells: [0; 64],
                fault: Fault::Coupling { a, b },
            };
            assert!(march_c_minus(&mut m).is_err(), "coupling {a}→{b}");
        }
    }
}
