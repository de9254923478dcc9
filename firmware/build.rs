//! Build-time setup of the firmware image.
//!
//! - Link scripts: `memory.x` (workspace root) is copied to OUT_DIR so
//!   editing it relinks, and defmt's script is added. `link.x` comes from
//!   `.cargo/config.toml` (see `../shared/notes/embedded-toolchain-facts.md`).
//!   `image.x` limits the image to flash sectors 0–5: the link's
//!   parameter and event storage is above (`memory.x` keeps the whole
//!   flash for the QEMU test images, which are larger).
//! - Installation parameters: if `LEAK_MONITOR_PARAMS` names a TOML file
//!   (e.g. written by `host-sim calibrate`; relative paths are taken from
//!   the workspace root), it is validated with the monitor's own rules and
//!   compiled in as `INSTALLATION`; otherwise the reference rig's nominal
//!   parameters are, as a provisional set (`Params::PROVISIONAL`: never
//!   `healthy`, gross leaks only, until an installation set is uploaded).
//!   A bad file fails the build, naming file and field.
//! - Acknowledge key: `LEAK_MONITOR_ACK_KEY` (32 hexadecimal digits, the
//!   installation's 128-bit key, see `docs/acknowledge.md`) is compiled in
//!   as `ACK_KEY`. Without it the public development key is, with a build
//!   warning; the firmware then reports "development key" in every
//!   challenge frame (`AckKey`), so no one can mistake such a unit for a
//!   protected one. A malformed or trivial key fails the build.
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
    std::fs::copy(root.join("memory.x"), out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // The image's room in flash (sectors 0–5; the link's storage above).
    let here = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    std::fs::copy(here.join("image.x"), out.join("image.x")).unwrap();
    println!("cargo:rerun-if-changed=image.x");
    println!("cargo:rustc-link-arg-bins=-Timage.x");

    println!("cargo:rerun-if-env-changed=LEAK_MONITOR_PARAMS");
    let (params, mut code) = match std::env::var_os("LEAK_MONITOR_PARAMS").filter(|v| !v.is_empty())
    {
        None => (
            monitor::Params::provisional(),
            "/// The reference rig's parameters as a provisional set (no\n\
             /// `LEAK_MONITOR_PARAMS` given): never `healthy`, gross leaks only,\n\
             /// until an installation set is uploaded.\n\
             pub const INSTALLATION: Params = Params::PROVISIONAL;\n\
             /// Where the parameters came from.\n\
             pub const INSTALLATION_SOURCE: &str = \"provisional\";\n"
                .to_string(),
        ),
        Some(path) => {
            let mut path = PathBuf::from(path);
            if path.is_relative() {
                path = root.join(path);
            }
            println!("cargo:rerun-if-changed={}", path.display());
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| fail(&format!("LEAK_MONITOR_PARAMS {}: {e}", path.display())));
            let params: monitor::Params = toml::from_str(&text)
                .unwrap_or_else(|e| fail(&format!("LEAK_MONITOR_PARAMS {}: {e}", path.display())));
            if let Err(e) = params.validate() {
                fail(&format!("LEAK_MONITOR_PARAMS {}: {e}", path.display()));
            }
            // `Debug` of the (all-finite, validated) parameter structs is a
            // Rust struct expression, and f64's Debug round-trips exactly.
            let code = format!(
                "/// Parameters compiled in from `{}`.\n\
                 pub const INSTALLATION: Params = {params:?};\n\
                 /// Where the parameters came from.\n\
                 pub const INSTALLATION_SOURCE: &str = {:?};\n",
                path.display(),
                path.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            );
            (params, code)
        }
    };
    // The identity the commissioning link reports for this set (version 0:
    // compiled in), sent on CAN in `LM_Identity`.
    let id = link::storage::params_identity(&params, 0)
        .unwrap_or_else(|| fail("the parameter set does not fit the link's encoding buffer"));
    code += &format!(
        "/// CRC-32 of the compiled-in set's canonical encoding (its identity).\n\
         pub const INSTALLATION_CRC: u32 = {:#010x};\n",
        id.crc
    );
    std::fs::write(out.join("installation.rs"), code).unwrap();

    // What `LM_Version` says: this crate's version (Cargo's numeric parts)
    // and the commissioning link's protocol version.
    let part = |name: &str| -> u8 {
        let v = std::env::var(name).unwrap();
        v.parse()
            .unwrap_or_else(|_| fail(&format!("{name} = {v} does not fit LM_Version's byte")))
    };
    let version = format!(
        "/// The firmware's `LM_Version` frame.\n\
         pub const FRAME: VersionFrame = VersionFrame {{ firmware: [{}, {}, {}], link_protocol: {} }};\n",
        part("CARGO_PKG_VERSION_MAJOR"),
        part("CARGO_PKG_VERSION_MINOR"),
        part("CARGO_PKG_VERSION_PATCH"),
        link::message::PROTOCOL_VERSION
    );
    std::fs::write(out.join("version.rs"), version).unwrap();

    println!("cargo:rerun-if-env-changed=LEAK_MONITOR_ACK_KEY");
    let key = match std::env::var("LEAK_MONITOR_ACK_KEY")
        .ok()
        .filter(|v| !v.trim().is_empty())
    {
        None => {
            println!(
                "cargo:warning=LEAK_MONITOR_ACK_KEY is not set: this firmware authenticates \
                 CAN acknowledges with the PUBLIC development key (anyone on the bus can \
                 acknowledge; the challenge frame says `development`). Set the \
                 installation's 128-bit key (32 hex digits) for a unit in service."
            );
            "/// No `LEAK_MONITOR_ACK_KEY` at build time: the public development key.\n\
             pub const ACK_KEY: AckKey = AckKey::development();\n"
                .to_string()
        }
        Some(hex) => {
            let bytes = monitor::protocol::auth::AckKey::parse_hex(&hex)
                .unwrap_or_else(|e| fail(&format!("LEAK_MONITOR_ACK_KEY: {e}")));
            if monitor::protocol::auth::AckKey::installation(bytes).kind()
                != monitor::protocol::auth::KeyKind::Installation
            {
                println!("cargo:warning=LEAK_MONITOR_ACK_KEY is the public development key");
            }
            format!(
                "/// The installation's key (`LEAK_MONITOR_ACK_KEY` at build time).\n\
                 pub const ACK_KEY: AckKey = AckKey::installation({bytes:?});\n"
            )
        }
    };
    std::fs::write(out.join("ack_key.rs"), key).unwrap();
}

fn fail(msg: &str) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1);
}
