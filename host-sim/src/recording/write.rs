//! Writing recordings, plain or gzip-compressed.

use super::FORMAT;
use monitor::Sample;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Writes recordings.
pub struct RecordingWriter<W: Write> {
    w: BufWriter<W>,
    temperature: bool,
    extra: usize,
}

/// A file being written, plain or gzip-compressed.
pub enum FileSink {
    /// Plain text.
    Plain(File),
    /// Gzip stream.
    Gzip(flate2::write::GzEncoder<File>),
}

impl Write for FileSink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Self::Plain(f) => f.write(buf),
            Self::Gzip(g) => g.write(buf),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match self {
            Self::Plain(f) => f.flush(),
            Self::Gzip(g) => g.flush(),
        }
    }
}

impl FileSink {
    fn close(self) -> io::Result<()> {
        match self {
            Self::Plain(mut f) => f.flush(),
            Self::Gzip(g) => g.finish().map(drop),
        }
    }
}

impl RecordingWriter<FileSink> {
    /// Create `path`; gzip-compressed if it ends in `.gz`.
    pub fn create(
        path: &Path,
        metadata: &[(&str, String)],
        temperature: bool,
        extra: &[&str],
    ) -> io::Result<Self> {
        let f = File::create(path)?;
        let w = if path.extension().is_some_and(|e| e == "gz") {
            FileSink::Gzip(flate2::write::GzEncoder::new(
                f,
                flate2::Compression::best(),
            ))
        } else {
            FileSink::Plain(f)
        };
        Self::new(w, metadata, temperature, extra)
    }

    /// Flush and close the file (finishing the gzip stream).
    pub fn close(self) -> io::Result<()> {
        self.w.into_inner().map_err(|e| e.into_error())?.close()
    }
}

impl<W: Write> RecordingWriter<W> {
    /// Start a recording on `w` with `# key=value` metadata, optionally the
    /// `temp_oil` column, and extra columns (e.g. simulator truth).
    pub fn new(
        w: W,
        metadata: &[(&str, String)],
        temperature: bool,
        extra: &[&str],
    ) -> io::Result<Self> {
        let mut w = BufWriter::with_capacity(1 << 16, w);
        writeln!(w, "# format={FORMAT}")?;
        for (k, v) in metadata {
            // Keep metadata on one line.
            writeln!(w, "# {k}={}", v.replace(['\n', '\r'], " "))?;
        }
        write!(w, "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve")?;
        if temperature {
            write!(w, ",temp_oil")?;
        }
        for e in extra {
            write!(w, ",{e}")?;
        }
        writeln!(w)?;
        Ok(Self {
            w,
            temperature,
            extra: extra.len(),
        })
    }

    /// Write one row; `extra` must match the extra columns.
    pub fn write(&mut self, s: &Sample, extra: &[f64]) -> io::Result<()> {
        debug_assert_eq!(extra.len(), self.extra);
        let w = &mut self.w;
        write!(w, "{:.4}", s.t_s)?;
        for (v, prec) in [
            (s.p_supply_bar, 3),
            (s.p_piston_bar, 3),
            (s.p_rod_bar, 3),
            (s.p_tank_bar, 3),
            (s.x_piston_m, 6),
            (s.u_valve, 5),
        ] {
            match v {
                Some(v) => write!(w, ",{v:.prec$}")?,
                None => write!(w, ",")?,
            }
        }
        if self.temperature {
            match s.temp_oil_c {
                Some(v) => write!(w, ",{v:.2}")?,
                None => write!(w, ",")?,
            }
        }
        for e in extra {
            write!(w, ",{e:.5}")?;
        }
        writeln!(w)
    }

    /// Flush to the underlying writer.
    pub fn finish(mut self) -> io::Result<()> {
        self.w.flush()
    }
}
