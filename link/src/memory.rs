//! What the event memory keeps of the monitor's events: the translation
//! from `monitor::Event` (and the acknowledge outcome) to the stored
//! [`EventKind`]. Filter resets and data gaps are not kept (they show as
//! `inconclusive` on CAN and in recordings); alarms, sensor faults and
//! acknowledges are.

use crate::message::{EventKind, Leak};
use monitor::{Event, Status, Verdict};

/// The stored form of `event`, with the monitor's leak flows of the same
/// sample (`Status::leak_internal_lpm`, `leak_external_lpm`, l/min; NaN
/// when there is no estimate); `None` for events the memory does not keep.
pub fn event_kind(event: &Event, status: &Status) -> Option<EventKind> {
    flows_event(event, [status.leak_internal_lpm, status.leak_external_lpm])
}

fn flows_event(event: &Event, [internal, external]: [Option<f32>; 2]) -> Option<EventKind> {
    let internal_lpm = internal.unwrap_or(f32::NAN);
    let external_lpm = external.unwrap_or(f32::NAN);
    match *event {
        Event::AlarmRaised(verdict) => Some(EventKind::AlarmRaised {
            leak: leak(verdict)?,
            internal_lpm,
            external_lpm,
        }),
        Event::AlarmCleared => Some(EventKind::AlarmCleared {
            internal_lpm,
            external_lpm,
        }),
        Event::SensorFault(ch) => Some(EventKind::SensorFault { channels: ch.bit() }),
        Event::SensorRecovered(ch) => Some(EventKind::SensorRecovered { channels: ch.bit() }),
        Event::DataGap | Event::FilterReset(_) => None,
    }
}

fn leak(verdict: Verdict) -> Option<Leak> {
    match verdict {
        Verdict::Internal => Some(Leak::Internal),
        Verdict::External => Some(Leak::External),
        Verdict::Both => Some(Leak::Both),
        Verdict::Healthy | Verdict::SensorFault | Verdict::Inconclusive => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use monitor::Channel;

    fn kind(event: &Event, flows: [Option<f32>; 2]) -> Option<EventKind> {
        flows_event(event, flows)
    }

    fn status(internal: Option<f32>, external: Option<f32>) -> [Option<f32>; 2] {
        [internal, external]
    }

    #[test]
    fn alarms_keep_the_leak_and_its_flows() {
        let s = status(Some(0.4), Some(0.0));
        assert_eq!(
            kind(&Event::AlarmRaised(Verdict::Internal), s),
            Some(EventKind::AlarmRaised {
                leak: Leak::Internal,
                internal_lpm: 0.4,
                external_lpm: 0.0
            })
        );
        assert_eq!(
            kind(&Event::AlarmCleared, s),
            Some(EventKind::AlarmCleared {
                internal_lpm: 0.4,
                external_lpm: 0.0
            })
        );
    }

    #[test]
    fn a_flow_without_an_estimate_is_nan_not_zero() {
        let Some(EventKind::AlarmCleared { internal_lpm, .. }) =
            kind(&Event::AlarmCleared, status(None, Some(0.1)))
        else {
            panic!("an alarm clear is kept");
        };
        assert!(internal_lpm.is_nan());
    }

    #[test]
    fn sensor_faults_carry_the_channel_bit() {
        let s = status(None, None);
        assert_eq!(
            kind(&Event::SensorFault(Channel::PRod), s),
            Some(EventKind::SensorFault {
                channels: Channel::PRod.bit()
            })
        );
        assert_eq!(
            kind(&Event::SensorRecovered(Channel::PRod), s),
            Some(EventKind::SensorRecovered {
                channels: Channel::PRod.bit()
            })
        );
    }

    #[test]
    fn gaps_resets_and_non_leak_verdicts_are_not_kept() {
        let s = status(None, None);
        assert_eq!(kind(&Event::DataGap, s), None);
        assert_eq!(kind(&Event::AlarmRaised(Verdict::Healthy), s), None);
        assert_eq!(kind(&Event::AlarmRaised(Verdict::Inconclusive), s), None);
    }
}
