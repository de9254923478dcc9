//! The highest alarm level in use per leak since the last `LM_Sensitivity`
//! frame. The level follows the operating region from one sample to the
//! next, and the frame goes out once a second: a snapshot would show the
//! holding region's low level for a second spent mostly moving at a higher
//! one. The period's highest level is what every sample of that second
//! was at least measured against.

/// The highest published alarm level per leak over a frame period, l/min
/// (internal, external).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelPeak {
    /// Highest level per leak over the samples of the period that had one.
    peak: [Option<f32>; 2],
}

impl LevelPeak {
    /// Take one sample's published levels
    /// ([`Status::published_alarm_levels`](crate::Status::published_alarm_levels))
    /// into the period.
    pub fn observe(&mut self, levels: [Option<f32>; 2]) {
        for (peak, level) in self.peak.iter_mut().zip(levels) {
            if let Some(level) = level {
                *peak = Some(peak.map_or(level, |p| p.max(level)));
            }
        }
    }

    /// The levels to send with the period's last sample, whose own levels
    /// are `now`, and start a new period: per leak the period's highest
    /// level, none where `now` has none (no leak estimate now, as
    /// `LM_Status`' leak sizes).
    pub fn take(&mut self, now: [Option<f32>; 2]) -> [Option<f32>; 2] {
        let peak = core::mem::take(&mut self.peak);
        [now[0].and(peak[0]), now[1].and(peak[1])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sample's published levels: `levels`, or none without estimates.
    fn published(levels: [f32; 2], estimates: bool) -> [Option<f32>; 2] {
        levels.map(|l| estimates.then_some(l))
    }

    #[test]
    fn the_period_sends_its_highest_level_and_starts_afresh() {
        let mut p = LevelPeak::default();
        for levels in [[0.3, 0.2], [0.9, 0.1], [0.3, 0.2]] {
            p.observe(published(levels, true));
        }
        let last = published([0.3, 0.2], true);
        assert_eq!(p.take(last), [Some(0.9), Some(0.2)]);
        // A new period: the earlier peak is gone.
        p.observe(last);
        assert_eq!(p.take(last), [Some(0.3), Some(0.2)]);
    }

    #[test]
    fn no_level_is_sent_while_there_is_no_leak_estimate() {
        let mut p = LevelPeak::default();
        p.observe(published([0.9, 0.9], true));
        let faulted = published([0.2, 0.2], false);
        p.observe(faulted);
        assert_eq!(p.take(faulted), [None, None]);
        // Samples without an estimate do not count towards the peak.
        p.observe(faulted);
        let back = published([0.2, 0.3], true);
        p.observe(back);
        assert_eq!(p.take(back), [Some(0.2), Some(0.3)]);
    }
}
