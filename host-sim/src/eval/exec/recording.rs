//! Recordings: a run's recording text, its reader, and their on-disk cache.

use super::{CACHE_VERSION, TRUTH_COLUMNS};
use crate::eval::{fnv1a64, RunSpec};
use crate::recording::RecordingWriter;
use anyhow::{Context, Result};
use monitor::Sample;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};

/// The monitor's sample of a plant row (`None` stays an empty field, a NaN
/// time stays NaN).
pub fn row_sample(r: &plant::Row) -> Sample {
    let f = |v: Option<f64>| v.map(|v| v as f32);
    Sample {
        t_s: r.t,
        p_supply_bar: f(r.p_supply),
        p_piston_bar: f(r.p_piston),
        p_rod_bar: f(r.p_rod),
        p_tank_bar: f(r.p_tank),
        x_piston_m: f(r.x_piston),
        u_valve: f(r.u_valve),
        temp_oil_c: f(r.temp_oil),
    }
}

/// The recording text of `rows` (format of `recording-csv.md`, plus the
/// truth columns), with the run as metadata.
pub fn recording_text(run: &plant::Run, run_json: &str, rows: &[plant::Row]) -> Result<Vec<u8>> {
    let mut buf = Vec::with_capacity(rows.len() * 80 + 4096);
    let meta = [
        ("sample_rate_hz", format!("{}", run.sample_rate_hz)),
        (
            "source",
            format!("host-sim {} eval, plant", env!("CARGO_PKG_VERSION")),
        ),
        ("eval_run", run_json.to_string()),
    ];
    let mut w = RecordingWriter::new(&mut buf, &meta, run.temp_column, &TRUTH_COLUMNS)?;
    for r in rows {
        w.write(
            &row_sample(r),
            &[r.truth.internal_lpm, r.truth.external_lpm, r.truth.v_m_s],
        )?;
    }
    w.finish()?;
    Ok(buf)
}

/// A recording as this module wrote it, read leniently: a NaN time, a
/// repeated time and empty fields come through as they are.
pub struct TextReader<R: BufRead> {
    r: R,
    meta: Vec<(String, String)>,
    /// Column of t, the seven channels and the truth columns.
    cols: [Option<usize>; 11],
    line: String,
    line_no: u64,
}

impl<R: BufRead> TextReader<R> {
    /// Read the metadata and header.
    pub fn new(mut r: R) -> Result<Self> {
        let mut meta = Vec::new();
        let mut line = String::new();
        let mut line_no = 0;
        let header = loop {
            line.clear();
            if r.read_line(&mut line)? == 0 {
                anyhow::bail!("no header line");
            }
            line_no += 1;
            let text = line.trim_end();
            if let Some(rest) = text.strip_prefix('#') {
                if let Some((k, v)) = rest.trim_start().split_once('=') {
                    meta.push((k.to_string(), v.to_string()));
                }
                continue;
            }
            break text.to_string();
        };
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let wanted = [
            "t",
            "p_supply",
            "p_piston",
            "p_rod",
            "p_tank",
            "x_piston",
            "u_valve",
            "temp_oil",
            TRUTH_COLUMNS[0],
            TRUTH_COLUMNS[1],
            TRUTH_COLUMNS[2],
        ];
        let mut cols = [None; 11];
        for (c, w) in cols.iter_mut().zip(wanted) {
            *c = names.iter().position(|n| *n == w);
        }
        anyhow::ensure!(
            cols[..7].iter().all(Option::is_some),
            "header `{header}` lacks a required column"
        );
        Ok(Self {
            r,
            meta,
            cols,
            line,
            line_no,
        })
    }

    /// A metadata value.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.meta
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The next row: the sample and the truth (internal, external flow,
    /// velocity; 0 where absent).
    pub fn next_row(&mut self) -> Result<Option<(Sample, [f64; 3])>> {
        loop {
            self.line.clear();
            if self.r.read_line(&mut self.line)? == 0 {
                return Ok(None);
            }
            self.line_no += 1;
            if !self.line.trim().is_empty() {
                break;
            }
        }
        let mut fields = [""; 16];
        let mut n = 0;
        for f in self.line.trim_end().split(',') {
            anyhow::ensure!(n < fields.len(), "line {}: too many fields", self.line_no);
            fields[n] = f;
            n += 1;
        }
        let line_no = self.line_no;
        let get = |c: Option<usize>| -> Result<Option<f64>> {
            match c {
                Some(i) if i < n && !fields[i].is_empty() => fields[i]
                    .parse::<f64>()
                    .map(Some)
                    .with_context(|| format!("line {line_no}: `{}`", fields[i])),
                Some(i) if i >= n => anyhow::bail!("line {line_no}: too few fields"),
                _ => Ok(None),
            }
        };
        let c = self.cols;
        let ch = |i: usize| -> Result<Option<f32>> { Ok(get(c[i])?.map(|v| v as f32)) };
        let sample = Sample {
            t_s: get(c[0])?.unwrap_or(f64::NAN),
            p_supply_bar: ch(1)?,
            p_piston_bar: ch(2)?,
            p_rod_bar: ch(3)?,
            p_tank_bar: ch(4)?,
            x_piston_m: ch(5)?,
            u_valve: ch(6)?,
            temp_oil_c: ch(7)?,
        };
        let truth = [
            get(c[8])?.unwrap_or(0.0),
            get(c[9])?.unwrap_or(0.0),
            get(c[10])?.unwrap_or(0.0),
        ];
        Ok(Some((sample, truth)))
    }
}

/// The cache key of a run: its plant `Run` as JSON (which holds the whole
/// drawn rig, so a change of the rig draws is a new key).
pub fn cache_key(run_json: &str) -> u64 {
    fnv1a64(format!("eval-cache/{CACHE_VERSION}\n{run_json}").as_bytes())
}

/// Where a run's recording is cached.
pub fn cache_path(dir: &Path, run_json: &str) -> PathBuf {
    dir.join(format!("run-{:016x}.csv.gz", cache_key(run_json)))
}

fn read_cached(path: &Path, run_json: &str) -> Result<Option<Vec<u8>>> {
    let f = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("{}", path.display())),
    };
    let mut text = Vec::new();
    flate2::read::MultiGzDecoder::new(std::io::BufReader::new(f))
        .read_to_end(&mut text)
        .with_context(|| format!("{}: delete it to simulate again", path.display()))?;
    let r = TextReader::new(&text[..])
        .with_context(|| format!("{}: delete it to simulate again", path.display()))?;
    // A different run under the same key (or another plant version's file).
    if r.meta("eval_run") != Some(run_json) {
        return Ok(None);
    }
    Ok(Some(text))
}

fn write_cached(path: &Path, text: &[u8]) -> Result<()> {
    // Written under a temporary name and renamed: an interrupted run never
    // leaves a truncated recording.
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(
        ".{name}.{}.part",
        std::process::id() as u64 * 1000 + thread_tag()
    ));
    let f = std::fs::File::create(&tmp).with_context(|| format!("{}", tmp.display()))?;
    // The fastest level: the default one costs about 0.2 s per minute of
    // recording (a quarter of the plant's time) for files ~40 % smaller.
    let mut gz =
        flate2::write::GzEncoder::new(std::io::BufWriter::new(f), flate2::Compression::fast());
    gz.write_all(text)?;
    gz.finish()?.flush()?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}", path.display()))?;
    Ok(())
}

fn thread_tag() -> u64 {
    fnv1a64(format!("{:?}", std::thread::current().id()).as_bytes()) % 1000
}

/// The recording text of `spec`: from the cache, or simulated on the plant
/// (and cached). Second: whether it came from the cache.
pub fn recording_for(spec: &RunSpec, cache: Option<&Path>) -> Result<(Vec<u8>, bool)> {
    recording_reusing(spec, cache, &mut None)
}

/// [`recording_for`], taking the plant's motion from `last` when the run
/// moves as `last`'s did (a fault run on its healthy twin's plant: only
/// the readings differ) and leaving this run's there (see
/// [`plant::simulate_reusing`]). The recording is the same either way.
pub fn recording_reusing(
    spec: &RunSpec,
    cache: Option<&Path>,
    last: &mut Option<plant::Motion>,
) -> Result<(Vec<u8>, bool)> {
    let run = spec.run();
    let json = serde_json::to_string(&run)?;
    let path = cache.map(|d| cache_path(d, &json));
    if let Some(p) = &path {
        if let Some(text) = read_cached(p, &json)? {
            return Ok((text, true));
        }
    }
    let rows = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        plant::simulate_reusing(&run, last)
    }))
    .map_err(|e| {
        let msg = e
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        anyhow::anyhow!("the plant panicked: {msg}")
    })
    .with_context(|| format!("simulating {}", spec.id))?;
    anyhow::ensure!(!rows.is_empty(), "{}: the plant gave no rows", spec.id);
    let text = recording_text(&run, &json, &rows)?;
    drop(rows);
    if let Some(p) = &path {
        write_cached(p, &text)?;
    }
    Ok((text, false))
}

/// Every sample of a recording text.
pub fn samples_of(text: &[u8]) -> Result<Vec<Sample>> {
    let mut r = TextReader::new(text)?;
    let mut v = Vec::new();
    while let Some((s, _)) = r.next_row()? {
        v.push(s);
    }
    Ok(v)
}
