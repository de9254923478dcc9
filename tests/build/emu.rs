//! Build-time (host) half of the emulated-board tests (`qemu/firmware_*.rs`):
//! a golden recording turned into the ADC codes the emulated board feeds
//! the firmware, and the host's answer for those codes.
//!
//! For every golden case this writes to `OUT_DIR`:
//!
//! - `NAME.codes.bin`: per sample, for each channel in `Channel::ALL`
//!   order, the sum of the [`SCANS`] ADC codes of that 1 ms block (u16,
//!   little-endian). The value is the recorded reading through the
//!   inverse of the firmware's analogue front end (`firmware::board_map::
//!   FRONTEND`), rounded to a quarter code: the resolution of 4× averaged
//!   12-bit conversions. The board splits it into 4 codes that differ by
//!   at most 1. A missing reading becomes 0 (a dead loop).
//! - `NAME.samples.csv`: the samples the host's pipeline stepped for
//!   those codes, as recording columns: what the commissioning link must
//!   stream (`scripts/qemu-link-e2e.sh` compares `host-sim record`'s
//!   capture with it);
//! - `NAME.reference.bin`: per sample, what the host computes from those
//!   codes through the firmware's own pipeline, `monitor::device::
//!   Estimator::on_block` (with the acknowledge command at the sample the
//!   test sends it): the status, detail, alarm and sensitivity frames it
//!   gives (8 bytes each, E2E-protected with counter 0), 32 bytes per
//!   sample.
//!
//! and a Rust source with one `EmuCase` per golden case (the list of
//! alarm changes, the monitor's events, the sample at which the test
//! sends the acknowledge command, and the golden's own expected events,
//! computed from the unquantised readings).

use std::fmt::Write as _;
use std::path::Path;

use golden::canon::event_code;
use golden::expected::Expected;
use golden::input::Input;
use golden::params::golden_params;
use monitor::device::estimator::{Estimator, Inputs};
use monitor::protocol::{AlarmFrame, Command, Encoder, Message};
use monitor::signal::frontend::{FrontendConfig, Input as FrontInput};
use monitor::{Channel, Sample};

/// Scans per 1 ms block, from the board map.
pub const SCANS: u16 = boards::selected::SCANS_PER_SAMPLE as u16;
/// Sample period, µs, from the board map.
pub const SAMPLE_PERIOD_US: u32 = boards::selected::SAMPLE_PERIOD_US;
/// Bytes per sample in `NAME.reference.bin`.
pub const REFERENCE_RECORD: usize = 32;
/// The acknowledge command is applied this long after the last alarm
/// change of the run without it, ms.
const ACK_AFTER_MS: u32 = 200;
/// … if at least this much of the recording is left after it, ms.
const ACK_MIN_LEFT_MS: u32 = 100;

/// The sum of [`SCANS`] codes of one channel for `value` (engineering
/// units), or 0 for a missing value or an input that is not fitted.
fn code_sum(cfg: &FrontendConfig, channel: usize, value: Option<f32>) -> u16 {
    let adc = cfg.adc;
    let counts = match (cfg.inputs[channel], value) {
        (FrontInput::Loop(l), Some(v)) => adc.counts(l.volts_for(l.milliamps_for(v))),
        (FrontInput::Divider(d), Some(v)) => {
            adc.counts(d.pin_volts(v / d.units_per_volt, adc.vref_v))
        }
        _ => return 0,
    };
    let max = adc.full_scale_counts * SCANS as f32;
    (counts * SCANS as f32).round().clamp(0.0, max) as u16
}

/// The block of [`SCANS`] interleaved scans whose per-channel sums are
/// `sums` (the same split as the emulated board's).
fn block(sums: &[u16; 7]) -> Vec<u16> {
    let mut raw = Vec::with_capacity(7 * SCANS as usize);
    for scan in 0..SCANS {
        for &s in sums {
            raw.push(s / SCANS + u16::from(scan < s % SCANS));
        }
    }
    raw
}

fn protect(msg: Message) -> [u8; 8] {
    let frame = Encoder::new().encode(&msg);
    frame.data().try_into().expect("8-byte frame")
}

/// One run of the host's estimator sequence over the codes.
struct Run {
    reference: Vec<u8>,
    /// (sample, alarm frame) at sample 0 and at every change.
    alarms: Vec<(u32, AlarmFrame)>,
    /// (sample, event code).
    events: Vec<(u32, u16)>,
    /// Samples at which an alarm was raised (each renews the firmware's
    /// acknowledge challenge).
    raised: Vec<u32>,
    /// The samples the monitor stepped (what the link streams).
    samples: Vec<Sample>,
}

fn run(input: &Input<'_>, codes: &[[u16; 7]], frontend: FrontendConfig, ack: Option<u32>) -> Run {
    let params = golden_params(input.sample_period_s, input.warm_up_s);
    // The cycle budget only matters for the load report, not sent here.
    let mut estimator =
        Estimator::<f32>::new(&params, frontend, SAMPLE_PERIOD_US, SAMPLE_PERIOD_US * 1000)
            .expect("golden parameters");
    let mut out = Run {
        reference: Vec::with_capacity(codes.len() * REFERENCE_RECORD),
        alarms: Vec::new(),
        events: Vec::new(),
        raised: Vec::new(),
        samples: Vec::with_capacity(codes.len()),
    };
    for (k, sums) in codes.iter().enumerate() {
        let k = k as u32;
        let inputs = Inputs {
            command: (ack == Some(k)).then_some(Command::AcknowledgeAlarm),
            ..Inputs::default()
        };
        let o = estimator.on_block(&block(sums), &inputs);
        out.samples.push(o.sample);
        for e in &o.status.events {
            out.events.push((k, event_code(e)));
            if let monitor::Event::AlarmRaised(_) = e {
                out.raised.push(k);
            }
        }
        if o.alarm_changed || o.first {
            out.alarms.push((k, o.alarm_frame));
        }
        out.reference
            .extend(protect(Message::Status(o.status_frame())));
        out.reference
            .extend(protect(Message::Detail(o.detail_frame())));
        out.reference.extend(protect(Message::Alarm(o.alarm_frame)));
        out.reference
            .extend(protect(Message::Sensitivity(o.sensitivity_frame())));
    }
    out
}

fn sample_codes(cfg: &FrontendConfig, s: &Sample) -> [u16; 7] {
    core::array::from_fn(|i| code_sum(cfg, i, s.get(Channel::ALL[i])))
}

/// The samples as the columns of a recording (`recording-csv.md`), each
/// value the f32 the monitor stepped in its shortest exact decimal form
/// (an empty field for a reading the front end marked invalid), `t` from
/// the first sample: what `host-sim record` must capture from the
/// firmware's stream, up to the recording's printed precision
/// (`scripts/compare-recording.py`).
fn samples_csv(samples: &[Sample]) -> String {
    let temp = samples.iter().any(|s| s.temp_oil_c.is_some());
    let mut csv = String::from("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve");
    csv.push_str(if temp { ",temp_oil\n" } else { "\n" });
    for (k, s) in samples.iter().enumerate() {
        write!(csv, "{}", k as f64 * f64::from(SAMPLE_PERIOD_US) * 1e-6).unwrap();
        let channels = if temp { 7 } else { 6 };
        for &ch in &Channel::ALL[..channels] {
            match s.get(ch).filter(|v| v.is_finite()) {
                Some(v) => write!(csv, ",{v:?}").unwrap(),
                None => csv.push(','),
            }
        }
        csv.push('\n');
    }
    csv
}

/// Write the files of the case `name` and return its `EmuCase` source.
pub fn case(
    name: &str,
    input: &[u8],
    expected: &[u8],
    frontend: FrontendConfig,
    out: &Path,
) -> String {
    let input = Input::parse(input).unwrap_or_else(|e| panic!("{name}: {e}"));
    let expected = Expected::parse(expected).unwrap_or_else(|e| panic!("{name}: {e}"));
    let codes: Vec<[u16; 7]> = input
        .iter()
        .map(|s| sample_codes(&frontend, &s.unwrap_or_else(|e| panic!("{name}: {e}"))))
        .collect();
    let n = codes.len() as u32;

    // A latched leak is acknowledged a little after the last alarm change.
    let plain = run(&input, &codes, frontend, None);
    let last = plain.alarms.last().expect("sample 0");
    let ack = (!last.1.latched.is_empty())
        .then_some(last.0 + ACK_AFTER_MS)
        .filter(|&k| k + ACK_MIN_LEFT_MS <= n);
    let r = if ack.is_some() {
        run(&input, &codes, frontend, ack)
    } else {
        plain
    };

    let codes_path = out.join(format!("{name}.codes.bin"));
    let bytes: Vec<u8> = codes
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    std::fs::write(&codes_path, bytes).unwrap();
    let reference_path = out.join(format!("{name}.reference.bin"));
    std::fs::write(&reference_path, &r.reference).unwrap();
    std::fs::write(
        out.join(format!("{name}.samples.csv")),
        samples_csv(&r.samples),
    )
    .unwrap();

    let mut src = String::new();
    let upper = name.to_uppercase().replace(['-', '.'], "_");
    writeln!(src, "/// Golden case `{name}` on the emulated board.").unwrap();
    writeln!(
        src,
        "#[allow(dead_code)] // each test binary replays one case"
    )
    .unwrap();
    writeln!(src, "pub static {upper}: EmuCase = EmuCase {{").unwrap();
    writeln!(src, "    name: {name:?},").unwrap();
    writeln!(src, "    source: {:?},", input.source).unwrap();
    writeln!(src, "    samples: {n},").unwrap();
    writeln!(
        src,
        "    sample_period_s: f64::from_bits({:#x}),",
        input.sample_period_s.to_bits()
    )
    .unwrap();
    writeln!(
        src,
        "    warm_up_s: f64::from_bits({:#x}),",
        input.warm_up_s.to_bits()
    )
    .unwrap();
    writeln!(src, "    sample_period_us: {SAMPLE_PERIOD_US},").unwrap();
    writeln!(src, "    scans: {SCANS},").unwrap();
    writeln!(
        src,
        "    codes: include_bytes!({:?}),",
        codes_path.display().to_string()
    )
    .unwrap();
    writeln!(
        src,
        "    reference: include_bytes!({:?}),",
        reference_path.display().to_string()
    )
    .unwrap();
    writeln!(src, "    ack_sample: {ack:?},").unwrap();
    let rotations = ack.map_or(0, |a| r.raised.iter().filter(|&&k| k < a).count());
    writeln!(src, "    ack_rotations: {rotations},").unwrap();
    let list = |v: &[(u32, u16)]| {
        v.iter()
            .map(|(k, c)| format!("({k}, {c:#06x})"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    writeln!(src, "    events: &[{}],", list(&r.events)).unwrap();
    let golden_events: Vec<(u32, u16)> = expected.events().collect();
    writeln!(src, "    golden_events: &[{}],", list(&golden_events)).unwrap();
    writeln!(src, "    golden_verdict: {},", expected.final_verdict).unwrap();
    let alarms = r
        .alarms
        .iter()
        .map(|(k, a)| format!("({k}, {:?})", protect(Message::Alarm(*a))))
        .collect::<Vec<_>>()
        .join(", ");
    writeln!(src, "    alarm_changes: &[{alarms}],").unwrap();
    writeln!(src, "}};").unwrap();
    src
}
