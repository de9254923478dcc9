//! The highest alarm level in use per leak since the last `LM_Sensitivity`
//! frame. The level follows the operating region from one sample to the
//! next, and the frame goes out once a second: a snapshot would show the
//! holding region's low level for a second spent mostly moving at a higher
//! one. The period's highest level is what every sample of that second
//! was at least measured against.

use crate::leak::{Leak, PerLeak};
use crate::status::Status;

/// The highest published alarm level per leak over a frame period, l/min.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelPeak {
    /// Highest level per leak over the samples of the period that had one.
    peak: PerLeak<Option<f32>>,
}

impl LevelPeak {
    /// Take one sample's status into the period.
    pub fn observe(&mut self, status: &Status) {
        let now = status.published_alarm_levels();
        for k in Leak::ALL {
            if let Some(level) = now[k as usize] {
                self.peak[k] = Some(self.peak[k].map_or(level, |p| p.max(level)));
            }
        }
    }

    /// The levels to send with `status` (the period's last sample), which
    /// start a new period: per leak the period's highest level, and none
    /// where `status` publishes none (no leak estimate now, as
    /// `LM_Status`' leak sizes).
    pub fn take(&mut self, status: &Status) -> [Option<f32>; 2] {
        let now = status.published_alarm_levels();
        let peak = core::mem::take(&mut self.peak);
        Leak::ALL.map(|k| now[k as usize].and(peak[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(levels: [f32; 2], estimates: bool) -> Status {
        let mut s = crate::testutil::status();
        s.alarm_level_lpm = levels;
        let estimate = estimates.then_some(0.0);
        s.leak_internal_lpm = estimate;
        s.leak_external_lpm = estimate;
        s
    }

    #[test]
    fn the_period_sends_its_highest_level_and_starts_afresh() {
        let mut p = LevelPeak::default();
        for levels in [[0.3, 0.2], [0.9, 0.1], [0.3, 0.2]] {
            p.observe(&status(levels, true));
        }
        let last = status([0.3, 0.2], true);
        assert_eq!(p.take(&last), [Some(0.9), Some(0.2)]);
        // A new period: the earlier peak is gone.
        p.observe(&last);
        assert_eq!(p.take(&last), [Some(0.3), Some(0.2)]);
    }

    #[test]
    fn no_level_is_sent_while_there_is_no_leak_estimate() {
        let mut p = LevelPeak::default();
        p.observe(&status([0.9, 0.9], true));
        let faulted = status([0.2, 0.2], false);
        p.observe(&faulted);
        assert_eq!(p.take(&faulted), [None, None]);
        // Samples without an estimate do not count towards the peak.
        p.observe(&faulted);
        let back = status([0.2, 0.3], true);
        p.observe(&back);
        assert_eq!(p.take(&back), [Some(0.2), Some(0.3)]);
    }
}
