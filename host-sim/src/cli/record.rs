//! `host-sim record`: capture what the monitor sees from a device.

use anyhow::{bail, Context, Result};
use host_sim::port::{connect, link_err};
use host_sim::recording::RecordingWriter;
use link::message::SAMPLES_PER_BLOCK;
use link::{Accept, BlockTracker, StreamClock};
use monitor::Channel;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the device (`/dev/ttyACM0`, `COM3`),
    /// `tcp:HOST:PORT` for a serial port served over TCP (the emulated
    /// board in QEMU, e.g. `tcp:127.0.0.1:4567`), or
    /// `sim:[RECORDING.csv][?state=FILE&drop=N&corrupt=N]` for the
    /// simulated device.
    port: String,
    /// Output recording (`recording-csv.md`; gzip-compressed if it ends in
    /// `.gz`).
    #[arg(short, long)]
    output: PathBuf,
    /// Length of the recording, s of samples (default: until Ctrl-C).
    #[arg(long)]
    duration: Option<f64>,
    /// Free-text note stored in the recording (`# note=…`).
    #[arg(long)]
    note: Option<String>,
}

/// No block for this long: the stream has stopped.
const IDLE: Duration = Duration::from_secs(3);

pub fn run(a: Args) -> Result<ExitCode> {
    if let Some(d) = a.duration {
        if !(d.is_finite() && d > 0.0) {
            bail!("--duration must be a number of seconds > 0, not {d}");
        }
    }
    let err = link_err(&a.port);
    let mut c = connect(&a.port)?;
    let id = c.identity().map_err(&err)?;
    let period = f64::from(id.period_us) * 1e-6;
    let mut meta = vec![
        ("sample_rate_hz", format!("{}", 1.0 / period)),
        (
            "source",
            format!("firmware {} serial {}", id.firmware, id.serial),
        ),
        (
            "params",
            format!("version {} crc {:08x}", id.params.version, id.params.crc),
        ),
    ];
    if let Some(n) = &a.note {
        meta.push(("note", n.clone()));
    }
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second Ctrl-C while stopping ends the program the hard way.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let bar = match a.duration {
        Some(d) => {
            let b = indicatif::ProgressBar::new((d / period).ceil() as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} {bar:40} {pos}/{len} samples {msg}",
                )
                .expect("template"),
            );
            b
        }
        None => indicatif::ProgressBar::new_spinner(),
    };
    bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());

    c.start_stream().map_err(&err)?;
    let mut writer: Option<RecordingWriter<_>> = None;
    let mut tracker = BlockTracker::default();
    let mut clock = StreamClock::default();
    let mut samples = 0u64;
    let mut idle = false;
    'stream: while !stop.load(Ordering::SeqCst) {
        let Some(b) = c.next_block(IDLE).map_err(&err)? else {
            idle = true;
            break;
        };
        let Accept::New { lost } = tracker.accept(b.seq) else {
            continue;
        };
        if lost > 0 {
            bar.set_message(format!("{} lost blocks", tracker.lost));
        }
        // Time from the stream's first sample (block 0, even if lost), by
        // the device's sample counter.
        let first = clock.first_index(b.seq, b.first_tick);
        if writer.is_none() {
            // The oil temperature column if the sensor is fitted.
            let temp = b.samples[0].valid & Channel::TempOil.bit() != 0;
            writer = Some(
                RecordingWriter::create(&a.output, &meta, temp, &[])
                    .with_context(|| format!("{}: cannot write", a.output.display()))?,
            );
        }
        let w = writer.as_mut().expect("created above");
        for (i, ws) in b.samples.iter().enumerate() {
            let t = (first + i as u64) as f64 * period;
            if a.duration.is_some_and(|d| t >= d - period / 2.0) {
                break 'stream;
            }
            let mut s = ws.to_sample(t);
            // A faulted reading (a fitted sensor out of range reads NaN)
            // is an empty field, never a number.
            for v in [
                &mut s.p_supply_bar,
                &mut s.p_piston_bar,
                &mut s.p_rod_bar,
                &mut s.p_tank_bar,
                &mut s.x_piston_m,
                &mut s.u_valve,
                &mut s.temp_oil_c,
            ] {
                if v.is_some_and(|x| !x.is_finite()) {
                    *v = None;
                }
            }
            w.write(&s, &[])
                .with_context(|| format!("{}: cannot write", a.output.display()))?;
            samples += 1;
            if a.duration.is_some_and(|d| t + period >= d - period / 2.0) {
                bar.set_position(samples);
                break 'stream;
            }
        }
        bar.set_position(samples);
    }
    let (last, dropped) = c.stop_stream().map_err(&err)?;
    // Blocks still in flight before the stop are not recorded; the device's
    // count covers them, ours must not.
    let end_missing = if a.duration.is_some() || stop.load(Ordering::SeqCst) {
        0
    } else {
        tracker.finish(last)
    };
    bar.finish_and_clear();
    let Some(w) = writer else {
        bail!("{}: the device sent no samples", a.port);
    };
    w.close()
        .with_context(|| format!("{}: cannot write", a.output.display()))?;
    let stats = c.stats();
    eprintln!(
        "{}: {samples} samples ({:.3} s) from firmware {} serial {}",
        a.output.display(),
        samples as f64 * period,
        id.firmware,
        id.serial
    );
    eprintln!(
        "lost blocks: {} of {} ({} dropped by the device, {} damaged frames on the link{})",
        tracker.lost,
        tracker.received + tracker.lost,
        dropped,
        stats.dropped(),
        if end_missing > 0 {
            format!(", {end_missing} at the end")
        } else {
            String::new()
        }
    );
    if tracker.lost > 0 {
        eprintln!(
            "warning: {} blocks of {SAMPLES_PER_BLOCK} samples are missing (time gaps in the recording); replay treats them as data gaps",
            tracker.lost,
        );
    }
    if idle {
        bail!(
            "{}: the stream stopped (no samples for {} s); the recording is kept",
            a.port,
            IDLE.as_secs()
        );
    }
    Ok(ExitCode::SUCCESS)
}
