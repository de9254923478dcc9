//! Canonical byte streams of the monitor's inputs and outputs, fed to a
//! hash. Every field is visited by exhaustive destructuring: adding a field
//! to `Sample` or `Status` is a compile error here until it is hashed.

use crate::fnv::Fnv64;
use monitor::status::Evidence;
use monitor::{Channel, Event, FilterState, Hypothesis, Monitor, Sample, Status, Verdict};

fn opt_f32(h: &mut Fnv64, v: Option<f32>) {
    match v {
        None => h.u8(0),
        Some(v) => {
            h.u8(1);
            h.f32(v);
        }
    }
}

/// Hash one input sample (time and every channel, `None` distinct from
/// any value).
pub fn sample(h: &mut Fnv64, s: &Sample) {
    let Sample {
        t_s,
        p_supply_bar,
        p_piston_bar,
        p_rod_bar,
        p_tank_bar,
        x_piston_m,
        u_valve,
        temp_oil_c,
    } = *s;
    h.f64(t_s);
    for v in [
        p_supply_bar,
        p_piston_bar,
        p_rod_bar,
        p_tank_bar,
        x_piston_m,
        u_valve,
        temp_oil_c,
    ] {
        opt_f32(h, v);
    }
}

/// Hash every field of a status.
pub fn status(h: &mut Fnv64, s: &Status) {
    let Status {
        t_s,
        verdict,
        // Not hashed (added after the goldens): the verdict and the
        // ALARM_LATCHED flag carry it, except under a sensor fault.
        latched: _,
        leading,
        leak_internal_lpm,
        leak_external_lpm,
        leak_internal_sd_lpm,
        leak_external_sd_lpm,
        detect_internal_lpm,
        detect_external_lpm,
        alarm_level_lpm,
        valve_gain_deviation,
        evidence_weight,
        evidence,
        faulted_channels,
        health,
        events,
        noise_sigma,
    } = s;
    h.f64(*t_s);
    h.u8(*verdict as u8);
    h.u8(*leading as u8);
    for v in [
        *leak_internal_lpm,
        *leak_external_lpm,
        *leak_internal_sd_lpm,
        *leak_external_sd_lpm,
        *detect_internal_lpm,
        *detect_external_lpm,
    ] {
        opt_f32(h, v);
    }
    h.f32(alarm_level_lpm[0]);
    h.f32(alarm_level_lpm[1]);
    h.f32(valve_gain_deviation[0]);
    h.f32(valve_gain_deviation[1]);
    h.f32(*evidence_weight);
    for e in evidence {
        let Evidence {
            probability,
            log_likelihood,
            mean_nis,
        } = *e;
        h.f32(probability);
        h.f32(log_likelihood);
        h.f32(mean_nis);
    }
    h.u8(*faulted_channels);
    h.u16(*health);
    h.u8(events.len() as u8);
    for e in events {
        h.u16(event_code(e));
    }
    for v in noise_sigma {
        h.f32(*v);
    }
}

fn filter(h: &mut Fnv64, f: &FilterState<'_, f32>) {
    for v in f.x.iter().chain(f.p) {
        h.f32(*v);
    }
}

/// Hash the filter bank's complete state: every filter's state estimate
/// and covariance (all entries, column-major), or a marker when the bank
/// is not running.
pub fn bank(h: &mut Fnv64, m: &Monitor<f32>) {
    match m.filter_states() {
        None => h.u8(0),
        Some(filters) => {
            h.u8(1);
            for f in &filters {
                filter(h, f);
            }
        }
    }
}

/// A compact code for an event: kind in the high byte, argument in the
/// low byte.
pub fn event_code(e: &Event) -> u16 {
    let (kind, arg) = match *e {
        Event::AlarmRaised(v) => (1u8, v as u8),
        Event::AlarmCleared => (2, 0),
        Event::SensorFault(c) => (3, c as u8),
        Event::SensorRecovered(c) => (4, c as u8),
        Event::DataGap => (5, 0),
        Event::FilterReset(h) => (6, h as u8),
    };
    u16::from_be_bytes([kind, arg])
}

/// The event of a code from [`event_code`], if valid.
pub fn event_from_code(code: u16) -> Option<Event> {
    let [kind, arg] = code.to_be_bytes();
    let verdict = |a: u8| {
        [
            Verdict::Healthy,
            Verdict::Internal,
            Verdict::External,
            Verdict::Both,
            Verdict::SensorFault,
        ]
        .get(a as usize)
        .copied()
    };
    let channel = |a: u8| Channel::ALL.get(a as usize).copied();
    let hypothesis = |a: u8| Hypothesis::ALL.get(a as usize).copied();
    Some(match kind {
        1 => Event::AlarmRaised(verdict(arg)?),
        2 if arg == 0 => Event::AlarmCleared,
        3 => Event::SensorFault(channel(arg)?),
        4 => Event::SensorRecovered(channel(arg)?),
        5 if arg == 0 => Event::DataGap,
        6 => Event::FilterReset(hypothesis(arg)?),
        _ => return None,
    })
}

/// The verdict of a `Verdict as u8` code.
pub fn verdict_from_code(code: u8) -> Option<Verdict> {
    [
        Verdict::Healthy,
        Verdict::Internal,
        Verdict::External,
        Verdict::Both,
        Verdict::SensorFault,
    ]
    .get(code as usize)
    .copied()
}

#[cfg(test)]
mod tests {
    use super::*;
    use monitor::status::Events;

    fn base() -> Status {
        let mut events = Events::new();
        events.push(Event::DataGap).unwrap();
        Status {
            t_s: 1.5,
            verdict: Verdict::Healthy,
            latched: monitor::LeakSet::NONE,
            leading: Hypothesis::Healthy,
            leak_internal_lpm: Some(0.1),
            leak_external_lpm: Some(0.2),
            leak_internal_sd_lpm: Some(0.3),
            leak_external_sd_lpm: Some(0.4),
            detect_internal_lpm: Some(0.5),
            detect_external_lpm: Some(0.6),
            alarm_level_lpm: [0.08, 0.69],
            valve_gain_deviation: [0.7, 0.8],
            evidence_weight: 0.9,
            evidence: [Evidence {
                probability: 0.25,
                log_likelihood: -1.0,
                mean_nis: 3.0,
            }; 4],
            faulted_channels: 0,
            health: 0,
            events,
            noise_sigma: [1e-5, 0.1, 0.2],
        }
    }

    fn hash(s: &Status) -> u64 {
        let mut h = Fnv64::new();
        status(&mut h, s);
        h.value()
    }

    #[test]
    fn every_status_field_changes_the_hash() {
        let b = hash(&base());
        let nudge = |v: f32| f32::from_bits(v.to_bits() ^ 1);
        let mutations: [&dyn Fn(&mut Status); 22] = [
            &|s| s.noise_sigma[2] = nudge(s.noise_sigma[2]),
            &|s| s.t_s = f64::from_bits(s.t_s.to_bits() ^ 1),
            &|s| s.verdict = Verdict::Both,
            &|s| s.leading = Hypothesis::External,
            &|s| s.leak_internal_lpm = s.leak_internal_lpm.map(nudge),
            &|s| s.leak_external_lpm = None,
            &|s| s.leak_internal_sd_lpm = s.leak_internal_sd_lpm.map(nudge),
            &|s| s.leak_external_sd_lpm = s.leak_external_sd_lpm.map(nudge),
            &|s| s.detect_internal_lpm = s.detect_internal_lpm.map(nudge),
            &|s| s.detect_external_lpm = s.detect_external_lpm.map(nudge),
            &|s| s.alarm_level_lpm[0] = nudge(s.alarm_level_lpm[0]),
            &|s| s.alarm_level_lpm[1] = nudge(s.alarm_level_lpm[1]),
            &|s| s.valve_gain_deviation[0] = nudge(s.valve_gain_deviation[0]),
            &|s| s.valve_gain_deviation[1] = nudge(s.valve_gain_deviation[1]),
            &|s| s.evidence_weight = nudge(s.evidence_weight),
            &|s| s.evidence[3].probability = nudge(s.evidence[3].probability),
            &|s| s.evidence[2].log_likelihood = nudge(s.evidence[2].log_likelihood),
            &|s| s.evidence[0].mean_nis = nudge(s.evidence[0].mean_nis),
            &|s| s.faulted_channels = 4,
            &|s| s.health = 1 << 8,
            &|s| s.events[0] = Event::AlarmCleared,
            &|s| s.events.clear(),
        ];
        for (i, m) in mutations.iter().enumerate() {
            let mut s = base();
            m(&mut s);
            assert_ne!(hash(&s), b, "mutation {i} is not hashed");
        }
    }

    #[test]
    fn every_sample_field_changes_the_hash() {
        let s0 = Sample {
            t_s: 0.25,
            p_supply_bar: Some(50.0),
            p_piston_bar: Some(27.0),
            p_rod_bar: Some(25.0),
            p_tank_bar: Some(0.6),
            x_piston_m: Some(0.04),
            u_valve: Some(0.01),
            temp_oil_c: None,
        };
        let h = |s: &Sample| {
            let mut h = Fnv64::new();
            sample(&mut h, s);
            h.value()
        };
        let b = h(&s0);
        let mut s = s0;
        s.t_s = 0.2500000001;
        assert_ne!(h(&s), b);
        for ch in Channel::ALL {
            let mut s = s0;
            let v = match ch {
                Channel::PSupply => &mut s.p_supply_bar,
                Channel::PPiston => &mut s.p_piston_bar,
                Channel::PRod => &mut s.p_rod_bar,
                Channel::PTank => &mut s.p_tank_bar,
                Channel::XPiston => &mut s.x_piston_m,
                Channel::UValve => &mut s.u_valve,
                Channel::TempOil => &mut s.temp_oil_c,
            };
            *v = match *v {
                Some(x) => Some(f32::from_bits(x.to_bits() ^ 1)),
                None => Some(0.0),
            };
            assert_ne!(h(&s), b, "{ch:?} is not hashed");
        }
    }

    #[test]
    fn event_codes_round_trip() {
        let mut all = heapless::Vec::<Event, 32>::new();
        for v in [
            Verdict::Healthy,
            Verdict::Internal,
            Verdict::External,
            Verdict::Both,
            Verdict::SensorFault,
        ] {
            all.push(Event::AlarmRaised(v)).unwrap();
        }
        all.push(Event::AlarmCleared).unwrap();
        all.push(Event::DataGap).unwrap();
        for c in Channel::ALL {
            all.push(Event::SensorFault(c)).unwrap();
            all.push(Event::SensorRecovered(c)).unwrap();
        }
        for h in Hypothesis::ALL {
            all.push(Event::FilterReset(h)).unwrap();
        }
        for e in &all {
            assert_eq!(event_from_code(event_code(e)), Some(*e));
        }
        assert_eq!(event_from_code(0x0900), None);
        assert_eq!(verdict_from_code(3), Some(Verdict::Both));
        assert_eq!(verdict_from_code(5), None);
    }

    #[test]
    fn the_bank_is_hashed_and_moves() {
        let params = monitor::Params::nominal();
        let mut m = Monitor::<f32>::new(&params).unwrap();
        let h = |m: &Monitor<f32>| {
            let mut h = Fnv64::new();
            bank(&mut h, m);
            h.value()
        };
        let none = h(&m);
        let mut s = Sample {
            t_s: 0.0,
            p_supply_bar: Some(50.0),
            p_piston_bar: Some(27.0),
            p_rod_bar: Some(25.0),
            p_tank_bar: Some(0.6),
            x_piston_m: Some(0.04),
            u_valve: Some(0.01),
            temp_oil_c: None,
        };
        m.step(&s);
        let started = h(&m);
        assert_ne!(started, none);
        s.t_s = 0.001;
        m.step(&s);
        assert_ne!(h(&m), started);
    }
}
