//! `host-sim golden`: golden cases for the on-target tests in QEMU.
//!
//! A case is the first `samples` rows of a recording, stored as the exact
//! bit patterns this reader produced (`NAME.input.bin`), and the hash
//! chains of what the monitor returned for them (`NAME.expected.bin`); the
//! formats are in the `golden` crate. The run is cross-checked against
//! [`replay`], so a golden is what `host-sim replay` computes.

use crate::recording::RecordingReader;
use crate::replay::{replay, sample_period, Observer};
use anyhow::{bail, ensure, Context, Result};
use golden::expected::{Expected, Writer};
use golden::fnv::Fnv64;
use golden::input::{self, Input};
use golden::params::golden_params;
use golden::{canon, describe};
use monitor::{Monitor, Sample, Status, Verdict};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What a case is cut from.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseSpec {
    /// The recording, relative to the repository root (stored in the file).
    pub source: String,
    /// Number of samples from the start.
    pub samples: u32,
    /// Filter warm-up, s (the only tuning value that differs from nominal).
    pub warm_up_s: f64,
}

/// A generated case.
#[derive(Clone, Debug)]
pub struct Case {
    /// Contents of `NAME.input.bin`.
    pub input: Vec<u8>,
    /// Contents of `NAME.expected.bin`.
    pub expected: Vec<u8>,
    /// Final verdict.
    pub verdict: Verdict,
    /// Events as (time s, description).
    pub events: Vec<(f64, String)>,
}

/// Hashes the first `n` statuses of a replay.
struct StatusChain {
    n: u32,
    seen: u32,
    hash: Fnv64,
}

impl Observer for StatusChain {
    fn observe(&mut self, _: &Sample, status: &Status) -> std::io::Result<()> {
        if self.seen < self.n {
            canon::status(&mut self.hash, status);
            self.seen += 1;
        }
        Ok(())
    }
}

/// Generate the case `spec`, reading its recording under `root`.
pub fn generate(root: &Path, spec: &CaseSpec) -> Result<Case> {
    ensure!(spec.samples >= 2, "a golden case needs at least 2 samples");
    let path = root.join(&spec.source);
    let mut reader = RecordingReader::open(&path)?;
    let rate = reader.meta("sample_rate_hz").map(str::to_string);
    let samples: Vec<Sample> = reader
        .by_ref()
        .take(spec.samples as usize)
        .collect::<Result<_, _>>()?;
    ensure!(
        samples.len() == spec.samples as usize,
        "{}: has only {} samples, {} wanted",
        path.display(),
        samples.len(),
        spec.samples
    );
    let period = samples
        .first()
        .and_then(|first| sample_period(rate.as_deref(), first, samples.get(1)))
        .with_context(|| format!("{}: no sample period", path.display()))?;
    let params = golden_params(period, spec.warm_up_s);

    let mut monitor = Monitor::<f32>::new(&params)
        .map_err(|e| anyhow::anyhow!("invalid golden parameters: {}", e.field))?;
    let mut writer = Writer::new();
    let mut status_chain = Fnv64::new();
    let mut verdict = Verdict::Healthy;
    let mut events = Vec::new();
    for s in &samples {
        let status = monitor.step(s);
        writer.push(&status, &monitor);
        canon::status(&mut status_chain, &status);
        verdict = status.verdict;
        for e in &status.events {
            events.push((s.t_s, format!("{e:?}")));
        }
    }

    // The same statuses as `host-sim replay` with these parameters?
    let mut replayed = StatusChain {
        n: spec.samples,
        seen: 0,
        hash: Fnv64::new(),
    };
    replay::<f32, _>(
        RecordingReader::open(&path)?,
        &spec.source,
        &params,
        &mut replayed,
    )?;
    ensure!(
        replayed.seen == spec.samples && replayed.hash == status_chain,
        "{}: the golden run differs from `host-sim replay` (sample period or \
         parameters are derived differently)",
        path.display()
    );

    let input = input::encode(&samples, period, spec.warm_up_s, &spec.source);
    let decoded = Input::parse(&input).context("encoding golden input")?;
    decoded
        .verify()
        .map_err(|e| anyhow::anyhow!("golden input does not round-trip: {e}"))?;
    let expected = writer.finish(decoded.input_hash);
    Ok(Case {
        input,
        expected,
        verdict,
        events,
    })
}

/// `PREFIX.input.bin` and `PREFIX.expected.bin`.
pub fn files(prefix: &Path) -> (PathBuf, PathBuf) {
    let name = prefix.file_name().map(|n| n.to_string_lossy().into_owned());
    let name = name.unwrap_or_default();
    (
        prefix.with_file_name(format!("{name}.input.bin")),
        prefix.with_file_name(format!("{name}.expected.bin")),
    )
}

/// Write a case next to `prefix`.
pub fn write(prefix: &Path, case: &Case) -> Result<()> {
    let (i, e) = files(prefix);
    std::fs::write(&i, &case.input).with_context(|| format!("{}: cannot write", i.display()))?;
    std::fs::write(&e, &case.expected).with_context(|| format!("{}: cannot write", e.display()))?;
    Ok(())
}

/// One line about a case.
pub fn summary(name: &str, spec: &CaseSpec, case: &Case) -> String {
    let mut s = format!(
        "{name}: {} samples of {} (warm-up {} s): verdict {}",
        spec.samples,
        spec.source,
        spec.warm_up_s,
        case.verdict.name()
    );
    for (t, e) in &case.events {
        let _ = write!(s, ", {e} at {t:.3} s");
    }
    let _ = write!(s, "; {} + {} bytes", case.input.len(), case.expected.len());
    s
}

/// The cases in `dir` (`*.input.bin`), sorted by name, as prefixes.
pub fn cases(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for entry in
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot read", dir.display()))?
    {
        let path = entry?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        if let Some(stem) = name.as_deref().and_then(|n| n.strip_suffix(".input.bin")) {
            out.push(dir.join(stem));
        }
    }
    out.sort();
    Ok(out)
}

/// The spec recorded in a case's input file.
pub fn spec_of(prefix: &Path) -> Result<CaseSpec> {
    let (i, _) = files(prefix);
    let bytes = std::fs::read(&i).with_context(|| format!("{}: cannot read", i.display()))?;
    let input = Input::parse(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", i.display()))?;
    Ok(CaseSpec {
        source: input.source.to_string(),
        samples: input.samples,
        warm_up_s: input.warm_up_s,
    })
}

/// Regenerate every case in `dir` from its recorded source under `root`
/// and compare with the files. Returns one message per stale file.
pub fn check(dir: &Path, root: &Path) -> Result<Vec<String>> {
    let mut stale = Vec::new();
    let prefixes = cases(dir)?;
    if prefixes.is_empty() {
        bail!("{}: no golden cases (*.input.bin)", dir.display());
    }
    for prefix in prefixes {
        let spec = spec_of(&prefix)?;
        let case = generate(root, &spec)?;
        let (i, e) = files(&prefix);
        for (path, want) in [(&i, &case.input), (&e, &case.expected)] {
            let have = std::fs::read(path).unwrap_or_default();
            if &have != want {
                stale.push(format!(
                    "{} is not what the current code generates from {}",
                    path.display(),
                    spec.source
                ));
            }
        }
    }
    Ok(stale)
}

/// The host's status and filter states at sample `k` of the case at
/// `prefix` (to diff with what a failing QEMU test printed).
pub fn show(prefix: &Path, k: u32) -> Result<String> {
    let (i, e) = files(prefix);
    let in_bytes = std::fs::read(&i).with_context(|| format!("{}: cannot read", i.display()))?;
    let input = Input::parse(&in_bytes).map_err(|e| anyhow::anyhow!("{}: {e}", i.display()))?;
    ensure!(
        k < input.samples,
        "sample {k} is past the end ({} samples)",
        input.samples
    );
    let mut monitor = Monitor::<f32>::new(&golden_params(input.sample_period_s, input.warm_up_s))
        .map_err(|e| anyhow::anyhow!("invalid golden parameters: {}", e.field))?;
    let mut out = String::new();
    for (idx, s) in input.iter().enumerate() {
        let s = s.map_err(|e| anyhow::anyhow!("{}: {e}", i.display()))?;
        let status = monitor.step(&s);
        if idx as u32 == k {
            writeln!(out, "sample {k} of {}", i.display())?;
            describe::status(&mut out, &status)?;
            describe::bank(&mut out, &monitor)?;
            break;
        }
    }
    if let Ok(exp) = std::fs::read(&e) {
        if let Ok(x) = Expected::parse(&exp) {
            if let Some(f) = x.fold(k) {
                writeln!(
                    out,
                    "expected folds: status {:04x} bank {:04x}",
                    f.status, f.bank
                )?;
            }
        }
    }
    Ok(out)
}
