//! A status written out field by field, values with their bit patterns:
//! printed by the QEMU test at the first differing sample and by
//! `host-sim golden show` for the same sample, so the two can be diffed.

use core::fmt::{self, Write};
use monitor::{Monitor, Status};

struct F32(f32);

impl fmt::Display for F32 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:e} ({:08x})", self.0, self.0.to_bits())
    }
}

struct Opt(Option<f32>);

impl fmt::Display for Opt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(v) => write!(f, "{}", F32(v)),
            None => f.write_str("none"),
        }
    }
}

/// Write every field of `s`, one per line.
pub fn status(w: &mut dyn Write, s: &Status) -> fmt::Result {
    writeln!(w, "t_s {:e} ({:016x})", s.t_s, s.t_s.to_bits())?;
    writeln!(
        w,
        "verdict {} leading {}",
        s.verdict.name(),
        s.leading.name()
    )?;
    writeln!(w, "leak_internal_lpm {}", Opt(s.leak_internal_lpm))?;
    writeln!(w, "leak_external_lpm {}", Opt(s.leak_external_lpm))?;
    writeln!(w, "leak_internal_sd_lpm {}", Opt(s.leak_internal_sd_lpm))?;
    writeln!(w, "leak_external_sd_lpm {}", Opt(s.leak_external_sd_lpm))?;
    writeln!(w, "detect_internal_lpm {}", Opt(s.detect_internal_lpm))?;
    writeln!(w, "detect_external_lpm {}", Opt(s.detect_external_lpm))?;
    writeln!(
        w,
        "valve_gain_deviation {} {}",
        F32(s.valve_gain_deviation[0]),
        F32(s.valve_gain_deviation[1])
    )?;
    writeln!(w, "evidence_weight {}", F32(s.evidence_weight))?;
    for (i, e) in s.evidence.iter().enumerate() {
        writeln!(
            w,
            "evidence[{i}] p {} ll {} nis {}",
            F32(e.probability),
            F32(e.log_likelihood),
            F32(e.mean_nis)
        )?;
    }
    writeln!(
        w,
        "faulted_channels {:#04x} health {:#06x}",
        s.faulted_channels, s.health
    )?;
    for e in &s.events {
        writeln!(w, "event {e:?}")?;
    }
    Ok(())
}

/// Write every filter's state estimate (`x`, not the covariance) with bit
/// patterns, one filter per line group.
pub fn bank(w: &mut dyn Write, m: &Monitor<f32>) -> fmt::Result {
    let Some(filters) = m.filter_states() else {
        return writeln!(w, "bank not running");
    };
    let mut row = |name: &str, x: &[f32]| -> fmt::Result {
        write!(w, "x[{name}]")?;
        for v in x {
            write!(w, " {}", F32(*v))?;
        }
        writeln!(w)
    };
    for f in &filters {
        row(f.hypothesis.name(), f.x)?;
    }
    Ok(())
}
