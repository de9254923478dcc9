//! Debounce of input faults (NE43 loop limits, saturated voltages).
//!
//! A fault must persist for `fault_samples` consecutive samples before the
//! channel is declared faulted; meanwhile the last valid value is held, so
//! a short spike (a contact bounce, EMC) is ridden through. A faulted
//! channel must then read valid for `recover_samples` consecutive samples
//! before it is trusted again. A channel that has never read a valid value
//! has nothing to hold: its fault counts at once.

use super::current_loop::InputFault;

/// Debounce times, in samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DebounceConfig {
    /// Consecutive faulty samples that fault the channel (≥ 1).
    pub fault_samples: u16,
    /// Consecutive valid samples that recover it (≥ 1).
    pub recover_samples: u16,
}

impl DebounceConfig {
    /// At 1 kHz: faulted after 5 ms, recovered after 100 ms.
    pub const DEFAULT: Self = Self {
        fault_samples: 5,
        recover_samples: 100,
    };
}

/// A debounced reading.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Debounced {
    /// A valid reading.
    Valid(f32),
    /// A fault not yet confirmed: the last valid reading, held.
    Held(f32),
    /// The channel is faulted.
    Faulted(InputFault),
}

impl Debounced {
    /// The value to use, if any.
    pub fn value(self) -> Option<f32> {
        match self {
            Self::Valid(v) | Self::Held(v) => Some(v),
            Self::Faulted(_) => None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Trusted { last: Option<f32>, bad: u16 },
    Faulted { fault: InputFault, good: u16 },
}

/// Debounce state of one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Debouncer {
    state: State,
}

impl Default for Debouncer {
    fn default() -> Self {
        Self::new()
    }
}

impl Debouncer {
    /// A channel that has not read anything yet.
    pub const fn new() -> Self {
        Self {
            state: State::Trusted { last: None, bad: 0 },
        }
    }

    /// Take one raw reading.
    pub fn update(&mut self, cfg: &DebounceConfig, reading: Result<f32, InputFault>) -> Debounced {
        let (state, out) = match (self.state, reading) {
            (State::Trusted { .. }, Ok(v)) => (
                State::Trusted {
                    last: Some(v),
                    bad: 0,
                },
                Debounced::Valid(v),
            ),
            (State::Trusted { last, bad }, Err(fault)) => {
                let bad = bad.saturating_add(1);
                match last {
                    Some(v) if bad < cfg.fault_samples => {
                        (State::Trusted { last, bad }, Debounced::Held(v))
                    }
                    _ => (State::Faulted { fault, good: 0 }, Debounced::Faulted(fault)),
                }
            }
            (State::Faulted { .. }, Err(fault)) => {
                (State::Faulted { fault, good: 0 }, Debounced::Faulted(fault))
            }
            (State::Faulted { fault, good }, Ok(v)) => {
                let good = good.saturating_add(1);
                if good >= cfg.recover_samples {
                    (
                        State::Trusted {
                            last: Some(v),
                            bad: 0,
                        },
                        Debounced::Valid(v),
                    )
                } else {
                    (State::Faulted { fault, good }, Debounced::Faulted(fault))
                }
            }
        };
        self.state = state;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: DebounceConfig = DebounceConfig {
        fault_samples: 5,
        recover_samples: 100,
    };

    #[test]
    fn a_short_spike_is_held_over() {
        let mut d = Debouncer::new();
        assert_eq!(d.update(&CFG, Ok(50.0)), Debounced::Valid(50.0));
        for _ in 0..4 {
            assert_eq!(
                d.update(&CFG, Err(InputFault::LoopLow)),
                Debounced::Held(50.0)
            );
        }
        assert_eq!(d.update(&CFG, Ok(51.0)), Debounced::Valid(51.0));
        // The count restarts after a valid reading.
        for _ in 0..4 {
            assert_eq!(
                d.update(&CFG, Err(InputFault::LoopHigh)),
                Debounced::Held(51.0)
            );
        }
    }

    #[test]
    fn a_lasting_fault_faults_after_the_debounce_and_recovers_slowly() {
        let mut d = Debouncer::new();
        d.update(&CFG, Ok(50.0));
        for _ in 0..4 {
            assert!(matches!(
                d.update(&CFG, Err(InputFault::LoopLow)),
                Debounced::Held(_)
            ));
        }
        assert_eq!(
            d.update(&CFG, Err(InputFault::LoopLow)),
            Debounced::Faulted(InputFault::LoopLow)
        );
        // 99 valid samples are not enough, and a fault restarts the count.
        for _ in 0..99 {
            assert_eq!(
                d.update(&CFG, Ok(50.0)),
                Debounced::Faulted(InputFault::LoopLow)
            );
        }
        assert_eq!(
            d.update(&CFG, Err(InputFault::LoopHigh)),
            Debounced::Faulted(InputFault::LoopHigh)
        );
        for _ in 0..99 {
            assert!(d.update(&CFG, Ok(50.0)).value().is_none());
        }
        assert_eq!(d.update(&CFG, Ok(50.5)), Debounced::Valid(50.5));
    }

    #[test]
    fn nothing_to_hold_faults_at_once() {
        let mut d = Debouncer::new();
        assert_eq!(
            d.update(&CFG, Err(InputFault::LoopLow)),
            Debounced::Faulted(InputFault::LoopLow)
        );
    }

    #[test]
    fn one_sample_debounce_faults_at_once() {
        let cfg = DebounceConfig {
            fault_samples: 1,
            recover_samples: 1,
        };
        let mut d = Debouncer::new();
        d.update(&cfg, Ok(1.0));
        assert!(d.update(&cfg, Err(InputFault::Saturated)).value().is_none());
        assert_eq!(d.update(&cfg, Ok(2.0)), Debounced::Valid(2.0));
    }
}
