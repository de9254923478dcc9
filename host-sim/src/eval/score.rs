//! What each run should have given (the product's targets) and whether it
//! did. Verdicts are compared as names, so a verdict this code does not know
//! (e.g. `inconclusive`, added to the monitor later) is still counted.

use super::exec::{Alarm, RunResult};
use super::Category;

/// Name of the sensor-fault verdict.
pub const SENSOR_FAULT: &str = "sensor_fault";
/// Name of the verdict for "not enough valid evidence to say".
pub const INCONCLUSIVE: &str = "inconclusive";
/// Name of the healthy verdict.
pub const HEALTHY: &str = "healthy";

/// Is this verdict name a leak?
pub fn is_leak(verdict: &str) -> bool {
    matches!(verdict, "internal" | "external" | "both")
}

impl RunResult {
    /// Leak onset, s (∞ without a leak).
    pub fn onset_s(&self) -> f64 {
        if self.spec.has_leak() {
            self.spec.leak.onset_s
        } else {
            f64::INFINITY
        }
    }

    /// Every alarm naming a leak.
    pub fn leak_alarms(&self) -> impl Iterator<Item = &Alarm> {
        self.alarms.iter().filter(|a| is_leak(&a.what))
    }

    /// A false alarm: on a healthy run any alarm; on a fault run a leak
    /// alarm; on a leak run an alarm before the onset.
    pub fn false_alarm(&self) -> bool {
        match self.spec.category {
            Category::Fault => self.leak_alarms().next().is_some(),
            c if c.is_healthy() || c == Category::Calibration => !self.alarms.is_empty(),
            _ => self.alarms.iter().any(|a| a.t_s < self.onset_s()),
        }
    }

    /// The first leak alarm at or after the onset.
    pub fn detection(&self) -> Option<&Alarm> {
        if !self.spec.has_leak() {
            return None;
        }
        let onset = self.onset_s();
        self.leak_alarms().find(|a| a.t_s >= onset)
    }

    /// A leak alarm at or after the onset.
    pub fn detected(&self) -> bool {
        self.detection().is_some()
    }

    /// Detected, and the final (latched) verdict names exactly the true
    /// leaks.
    pub fn isolated(&self) -> bool {
        self.detected() && self.verdict == self.spec.leak_kind()
    }

    /// Seconds from the onset to the detection (mid-run onsets only: a leak
    /// present from the start is limited by the warm-up).
    pub fn latency_s(&self) -> Option<f64> {
        let onset = self.onset_s();
        if onset > 0.0 {
            self.detection().map(|a| a.t_s - onset)
        } else {
            None
        }
    }

    /// Seconds from the leak's true flow first reaching the alarm level to
    /// the detection (mid-run onsets; 0 if the alarm came first).
    pub fn latency_flowing_s(&self) -> Option<f64> {
        if self.onset_s() > 0.0 {
            match (self.detection(), self.truth.flowing_s) {
                (Some(a), Some(f)) => Some((a.t_s - f).max(0.0)),
                _ => None,
            }
        } else {
            None
        }
    }

    /// |reported − true| / true of each present leak, the true flow being
    /// averaged as the monitor averages its size ([`TruthSummary::size_lpm`];
    /// a missing estimate counts as 0).
    pub fn size_errors(&self) -> Vec<f64> {
        let present = [self.spec.internal(), self.spec.external()];
        let truth = self.truth.size_lpm;
        (0..2)
            .filter(|&k| present[k] && truth[k] > 1e-6)
            .map(|k| {
                let est = self.est_lpm[k].unwrap_or(0.0);
                (est - truth[k]).abs() / truth[k]
            })
            .collect()
    }

    /// The verdict is `inconclusive`.
    pub fn inconclusive(&self) -> bool {
        self.verdict == INCONCLUSIVE
    }

    /// Largest detection average before any leak, l/min.
    pub fn largest_reading_lpm(&self) -> f64 {
        self.peak_detect_lpm[0].max(self.peak_detect_lpm[1])
    }

    /// When the run's fault starts, s.
    pub fn fault_start_s(&self) -> Option<f64> {
        super::plan::fault_window(&self.spec.faults).map(|w| w.0)
    }

    /// Leak alarms from the start of the fault on (earlier ones are false
    /// alarms of the healthy plant, counted as such but not against the
    /// fault's expectation).
    pub fn fault_leak_alarms(&self) -> impl Iterator<Item = &Alarm> {
        let from = self.fault_start_s().unwrap_or(f64::INFINITY);
        self.leak_alarms().filter(move |a| a.t_s >= from)
    }

    /// A fault run: while its fault was active the verdict was never
    /// `healthy` nor a leak (and it was active at all).
    pub fn fault_never_healthy(&self) -> bool {
        !self.fault_verdicts.is_empty()
            && self
                .fault_verdicts
                .keys()
                .all(|v| v != HEALTHY && !is_leak(v))
    }

    /// What the run should give, in words.
    pub fn expectation(&self) -> &'static str {
        match self.spec.category {
            Category::Calibration => "(calibration)",
            Category::HealthyClosedLoop | Category::HealthyLongHold | Category::HealthyStep => {
                "no alarm, healthy"
            }
            Category::Leak | Category::LeakAfterHold => "detected and isolated",
            Category::StepLeak => "detected",
            Category::Fault => match self.spec.fault {
                Some(f) if f.expects_sensor_fault() => {
                    "sensor_fault, no leak alarm after the fault"
                }
                _ => "never healthy nor a leak while active",
            },
        }
    }

    /// Did the run give what it should?
    pub fn passes(&self) -> bool {
        match self.spec.category {
            Category::Calibration => true,
            Category::HealthyClosedLoop | Category::HealthyLongHold | Category::HealthyStep => {
                self.alarms.is_empty() && self.verdict == HEALTHY
            }
            Category::Leak | Category::LeakAfterHold => !self.false_alarm() && self.isolated(),
            Category::StepLeak => !self.false_alarm() && self.detected(),
            Category::Fault => {
                let no_leak = self.fault_leak_alarms().next().is_none();
                match self.spec.fault {
                    Some(f) if f.expects_sensor_fault() => no_leak && self.verdict == SENSOR_FAULT,
                    _ => no_leak && self.fault_never_healthy(),
                }
            }
        }
    }
}

/// Median (`None` if empty).
pub fn median(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    })
}

/// Largest (`None` if empty).
pub fn max(v: &[f64]) -> Option<f64> {
    v.iter().copied().reduce(f64::max)
}
