//! `host-sim events`: the device's event memory.

use anyhow::Result;
use host_sim::port::{connect, link_err};
use link::{EventKind, EventRecord, Leak, ResetCause};
use monitor::Channel;
use serde_json::{json, Value};
use std::io::Write;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the device, `tcp:HOST:PORT` or `sim:…` (see
    /// `record --help`).
    port: String,
    /// One JSON object on stdout instead of a table.
    #[arg(long)]
    json: bool,
}

fn channels(mask: u8) -> Vec<&'static str> {
    Channel::ALL
        .iter()
        .filter(|c| mask & c.bit() != 0)
        .map(|c| c.name())
        .collect()
}

fn cause_name(c: ResetCause) -> &'static str {
    match c {
        ResetCause::PowerOn => "power_on",
        ResetCause::BrownOut => "brown_out",
        ResetCause::Watchdog => "watchdog",
        ResetCause::Software => "software",
        ResetCause::Pin => "pin",
        ResetCause::Unknown => "unknown",
    }
}

fn leak_name(l: Leak) -> &'static str {
    match l {
        Leak::Internal => "internal",
        Leak::External => "external",
        Leak::Both => "both",
    }
}

fn to_json(e: &EventRecord) -> Value {
    let mut v = json!({"boot": e.boot, "uptime_s": f64::from(e.uptime_ms) / 1e3});
    let fields = match e.kind {
        EventKind::AlarmRaised {
            leak,
            internal_lpm,
            external_lpm,
        } => json!({"kind": "alarm_raised", "leak": leak_name(leak),
            "leak_internal_lpm": internal_lpm, "leak_external_lpm": external_lpm}),
        EventKind::AlarmCleared {
            internal_lpm,
            external_lpm,
        } => json!({"kind": "alarm_cleared",
            "leak_internal_lpm": internal_lpm, "leak_external_lpm": external_lpm}),
        EventKind::SensorFault { channels: m } => {
            json!({"kind": "sensor_fault", "sensors": channels(m)})
        }
        EventKind::SensorRecovered { channels: m } => {
            json!({"kind": "sensor_recovered", "sensors": channels(m)})
        }
        EventKind::Acknowledged => json!({"kind": "acknowledged"}),
        EventKind::Reset { cause } => {
            json!({"kind": "reset", "cause": cause_name(cause)})
        }
        EventKind::ParamsChanged { params } => json!({"kind": "params_changed",
            "params_version": params.version, "params_crc": format!("{:08x}", params.crc)}),
    };
    if let (Value::Object(a), Value::Object(b)) = (&mut v, fields) {
        a.extend(b);
    }
    v
}

fn describe(e: &EventRecord) -> String {
    match e.kind {
        EventKind::AlarmRaised {
            leak,
            internal_lpm,
            external_lpm,
        } => format!(
            "alarm raised: {} leak (internal {internal_lpm:.3} l/min, external {external_lpm:.3} l/min)",
            leak_name(leak)
        ),
        EventKind::AlarmCleared {
            internal_lpm,
            external_lpm,
        } => format!(
            "alarm cleared (internal {internal_lpm:.3} l/min, external {external_lpm:.3} l/min)"
        ),
        EventKind::SensorFault { channels: m } => {
            format!("sensor fault: {}", channels(m).join(", "))
        }
        EventKind::SensorRecovered { channels: m } => {
            format!("sensor recovered: {}", channels(m).join(", "))
        }
        EventKind::Acknowledged => "alarm acknowledged".into(),
        EventKind::Reset { cause } => format!("reset ({})", cause_name(cause)),
        EventKind::ParamsChanged { params } => format!(
            "parameters changed: version {} crc {:08x}",
            params.version, params.crc
        ),
    }
}

pub fn run(a: Args) -> Result<ExitCode> {
    let err = link_err(&a.port);
    let mut c = connect(&a.port)?;
    let id = c.identity().map_err(&err)?;
    let events = c.read_events().map_err(&err)?;
    let mut out = super::stdout();
    if a.json {
        let v = json!({
            "firmware": id.firmware,
            "serial": id.serial,
            "boot": id.boot,
            "params_version": id.params.version,
            "params_crc": format!("{:08x}", id.params.crc),
            "events": events.iter().map(to_json).collect::<Vec<_>>(),
        });
        serde_json::to_writer(&mut out, &v)?;
        writeln!(out)?;
    } else {
        writeln!(
            out,
            "firmware {} serial {}, boot {}, {} events (oldest first)",
            id.firmware,
            id.serial,
            id.boot,
            events.len()
        )?;
        writeln!(out, "{:>6} {:>12}  event", "boot", "uptime s")?;
        for e in &events {
            writeln!(
                out,
                "{:>6} {:>12.3}  {}",
                e.boot,
                f64::from(e.uptime_ms) / 1e3,
                describe(e)
            )?;
        }
    }
    Ok(ExitCode::SUCCESS)
}
