//! `host-sim params`: the device's parameter set, over the physical link
//! only (never over CAN).

use anyhow::{bail, Context, Result};
use host_sim::port::{connect, link_err};
use link::client::DeviceIdentity;
use link::storage::{decode_params, encode_params, PARAMS_MAX};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Subcommand)]
pub enum Action {
    /// Validate a parameter file (the same check as the firmware build),
    /// upload it, let the device validate and store it power-fail safe,
    /// read it back and print the identity now active. The monitor
    /// restarts its filters (warm-up) on the new set.
    Upload(UploadArgs),
    /// Print the device's active parameter set as TOML (loadable with
    /// `replay --params`), its identity in a leading comment.
    Show(ShowArgs),
}

#[derive(clap::Args)]
pub struct UploadArgs {
    /// Serial port of the device, `tcp:HOST:PORT` or `sim:…` (see
    /// `record --help`).
    port: String,
    /// Parameter file (TOML, as written by `calibrate`).
    file: PathBuf,
}

#[derive(clap::Args)]
pub struct ShowArgs {
    /// Serial port of the device, `tcp:HOST:PORT` or `sim:…` (see
    /// `record --help`).
    port: String,
}

pub fn run(a: Action) -> Result<ExitCode> {
    match a {
        Action::Upload(a) => upload(a),
        Action::Show(a) => show(a),
    }
}

fn describe(id: &DeviceIdentity) -> String {
    format!(
        "parameter set version {} crc {:08x} (firmware {}, serial {}, boot {})",
        id.params.version, id.params.crc, id.firmware, id.serial, id.boot
    )
}

fn upload(a: UploadArgs) -> Result<ExitCode> {
    // Refused here, naming the field, before anything is sent.
    let p = host_sim::load_params(&a.file)?;
    let mut buf = [0u8; PARAMS_MAX];
    let enc = encode_params(&p, &mut buf).context("parameter set too large for the device")?;
    let err = link_err(&a.port);
    let mut c = connect(&a.port)?;
    let before = c.identity().map_err(&err)?;
    let id = c.upload_params(enc).map_err(&err)?;
    let back = c.read_params().map_err(&err)?;
    match decode_params(&back) {
        Some(q) if q == p && back == enc => {}
        _ => bail!("{}: the set read back differs from the one sent", a.port),
    }
    let now = c.identity().map_err(&err)?;
    if now.params != id.params {
        bail!("{}: the device reports another set than it stored", a.port);
    }
    eprintln!("was: {}", describe(&before));
    writeln!(super::stdout(), "active: {}", describe(&now))?;
    Ok(ExitCode::SUCCESS)
}

fn show(a: ShowArgs) -> Result<ExitCode> {
    let err = link_err(&a.port);
    let mut c = connect(&a.port)?;
    let id = c.identity().map_err(&err)?;
    let back = c.read_params().map_err(&err)?;
    let Some(p) = decode_params(&back) else {
        bail!(
            "{}: the device's parameter set cannot be decoded by this host-sim (firmware {})",
            a.port,
            id.firmware
        );
    };
    let origin = if id.params.version == 0 {
        "the firmware's compiled-in default"
    } else {
        "uploaded"
    };
    let text = toml::to_string(&p).context("cannot write TOML")?;
    let mut out = super::stdout();
    writeln!(out, "# {} — {origin}", describe(&id))?;
    write!(out, "{text}")?;
    Ok(ExitCode::SUCCESS)
}
