//! When each frame is due, given the sample clock: status every 100 ms,
//! detail, sensitivity, heartbeat, identity and version every second
//! (staggered so they do not share a millisecond with each other), the
//! alarm frame at once on a change of the alarm output and every second as
//! a refresh for late listeners.

/// Status frame period, ms.
pub const STATUS_PERIOD_MS: u64 = 100;
/// Detail, sensitivity, heartbeat, identity, version and alarm-refresh
/// period, ms.
pub const SLOW_PERIOD_MS: u64 = 1000;
/// Phase of the heartbeat within the second, ms.
pub const HEARTBEAT_PHASE_MS: u64 = 250;
/// Phase of the detail frame within the second, ms.
pub const DETAIL_PHASE_MS: u64 = 550;
/// Phase of the sensitivity frame within the second, ms.
pub const SENSITIVITY_PHASE_MS: u64 = 650;
/// Phase of the alarm refresh within the second, ms.
pub const ALARM_REFRESH_PHASE_MS: u64 = 750;
/// Phase of the identity frame within the second, ms.
pub const IDENTITY_PHASE_MS: u64 = 850;
/// Phase of the version frame within the second, ms.
pub const VERSION_PHASE_MS: u64 = 950;

/// Frames due at one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Due {
    /// Alarm frame.
    pub alarm: bool,
    /// Status frame.
    pub status: bool,
    /// Detail frame.
    pub detail: bool,
    /// Heartbeat frame.
    pub heartbeat: bool,
    /// Identity frame.
    pub identity: bool,
    /// Version frame.
    pub version: bool,
    /// Sensitivity frame.
    pub sensitivity: bool,
}

/// Frame scheduler.
#[derive(Clone, Debug, Default)]
pub struct FrameScheduler {
    last_ms: Option<u64>,
}

/// Did a time `k·period + phase` pass in (last, now]?
fn crossed(last: u64, now: u64, period: u64, phase: u64) -> bool {
    let slot = |t: u64| (t + period - phase) / period;
    slot(now) != slot(last)
}

impl FrameScheduler {
    /// A scheduler that has seen no sample yet.
    pub const fn new() -> Self {
        Self { last_ms: None }
    }

    /// Frames due at the sample at `t_ms` (ms on the sample clock, increasing;
    /// samples may be skipped). The first sample sends every frame.
    pub fn due(&mut self, t_ms: u64, alarm_changed: bool) -> Due {
        let due = match self.last_ms {
            Some(last) if t_ms <= last => Due {
                alarm: alarm_changed,
                ..Due::default()
            },
            Some(last) => Due {
                alarm: alarm_changed || crossed(last, t_ms, SLOW_PERIOD_MS, ALARM_REFRESH_PHASE_MS),
                status: crossed(last, t_ms, STATUS_PERIOD_MS, 0),
                detail: crossed(last, t_ms, SLOW_PERIOD_MS, DETAIL_PHASE_MS),
                heartbeat: crossed(last, t_ms, SLOW_PERIOD_MS, HEARTBEAT_PHASE_MS),
                identity: crossed(last, t_ms, SLOW_PERIOD_MS, IDENTITY_PHASE_MS),
                version: crossed(last, t_ms, SLOW_PERIOD_MS, VERSION_PHASE_MS),
                sensitivity: crossed(last, t_ms, SLOW_PERIOD_MS, SENSITIVITY_PHASE_MS),
            },
            None => Due {
                alarm: true,
                status: true,
                detail: true,
                heartbeat: true,
                identity: true,
                version: true,
                sensitivity: true,
            },
        };
        if self.last_ms.is_none_or(|last| t_ms > last) {
            self.last_ms = Some(t_ms);
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(ms: u64, changes: &[u64]) -> [heapless::Vec<u64, 128>; 7] {
        let mut s = FrameScheduler::new();
        let mut out: [heapless::Vec<u64, 128>; 7] = Default::default();
        for t in 0..ms {
            let d = s.due(t, changes.contains(&t));
            for (i, on) in [
                d.alarm,
                d.status,
                d.detail,
                d.heartbeat,
                d.identity,
                d.version,
                d.sensitivity,
            ]
            .into_iter()
            .enumerate()
            {
                if on {
                    out[i].push(t).unwrap();
                }
            }
        }
        out
    }

    #[test]
    fn periods_and_phases() {
        let [alarm, status, detail, heartbeat, identity, version, sensitivity] = run(3000, &[]);
        assert_eq!(status.len(), 30);
        assert!(status.iter().all(|t| t % 100 == 0));
        assert_eq!(heartbeat.as_slice(), &[0, 250, 1250, 2250]);
        assert_eq!(identity.as_slice(), &[0, 850, 1850, 2850]);
        assert_eq!(version.as_slice(), &[0, 950, 1950, 2950]);
        assert_eq!(detail.as_slice(), &[0, 550, 1550, 2550]);
        assert_eq!(sensitivity.as_slice(), &[0, 650, 1650, 2650]);
        assert_eq!(alarm.as_slice(), &[0, 750, 1750, 2750]);
    }

    #[test]
    fn an_alarm_change_is_sent_in_the_same_millisecond() {
        let [alarm, ..] = run(1000, &[123, 124, 751]);
        assert_eq!(alarm.as_slice(), &[0, 123, 124, 750, 751]);
    }

    #[test]
    fn skipped_samples_do_not_skip_frames() {
        let mut s = FrameScheduler::new();
        s.due(0, false);
        s.due(95, false);
        // 95 → 1305 crosses 100..1300 (status), 250 and 1250 (heartbeat once).
        let d = s.due(1305, false);
        let every = [
            d.status,
            d.heartbeat,
            d.detail,
            d.alarm,
            d.identity,
            d.version,
            d.sensitivity,
        ];
        assert!(every.iter().all(|&due| due), "{d:?}");
        let d = s.due(1306, false);
        assert_eq!(d, Due::default());
        // Time that does not advance sends nothing periodic.
        assert_eq!(
            s.due(1306, true),
            Due {
                alarm: true,
                ..Due::default()
            }
        );
    }
}
