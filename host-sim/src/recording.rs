//! Recordings in the CSV format of `../shared/spec/recording-csv.md`:
//! a streaming reader (constant memory, any length) with errors that name
//! the file, line and column, and a writer. Gzip-compressed recordings
//! (`.csv.gz`, recognised by their magic bytes) are read and written
//! transparently: an hour at 1 kHz is 200 MB of text.

use monitor::{Channel, Sample};
use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Read, Write};
use std::path::Path;

/// Format tag written to new recordings.
pub const FORMAT: &str = "leak-recording/1";

/// A recording that cannot be read, and exactly where.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// File name.
        file: String,
        /// Cause.
        source: io::Error,
    },
    /// No header line before the end of the file.
    #[error("{file}: no header line (only `#` lines or an empty file)")]
    NoHeader {
        /// File name.
        file: String,
    },
    /// A required column is missing from the header.
    #[error("{file}:{line}: missing required column `{column}` (the header has: {header})")]
    MissingColumn {
        /// File name.
        file: String,
        /// Header line number.
        line: u64,
        /// The missing column.
        column: &'static str,
        /// The header as found.
        header: String,
    },
    /// A column name appears twice.
    #[error("{file}:{line}: column `{column}` appears twice in the header")]
    DuplicateColumn {
        /// File name.
        file: String,
        /// Header line number.
        line: u64,
        /// The column.
        column: String,
    },
    /// A row has the wrong number of fields.
    #[error("{file}:{line}: expected {expected} fields as in the header, found {found}")]
    FieldCount {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// Fields in the header.
        expected: usize,
        /// Fields in the row.
        found: usize,
    },
    /// A field is not a number.
    #[error("{file}:{line}: column {index} `{column}`: `{value}` is not a number")]
    BadNumber {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// 1-based column number.
        index: usize,
        /// Column name.
        column: String,
        /// The field as found.
        value: String,
    },
    /// A field is NaN or infinite.
    #[error("{file}:{line}: column {index} `{column}`: `{value}` is not a finite number")]
    NotFinite {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// 1-based column number.
        index: usize,
        /// Column name.
        column: String,
        /// The field as found.
        value: String,
    },
    /// The time column is empty.
    #[error("{file}:{line}: column {index} `t` is empty (time is required on every row)")]
    MissingTime {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// 1-based column number.
        index: usize,
    },
    /// Time does not strictly increase.
    #[error("{file}:{line}: column {index} `t`: {t} does not increase (previous row: {previous})")]
    TimeNotIncreasing {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// 1-based column number.
        index: usize,
        /// This row's time.
        t: f64,
        /// The previous row's time.
        previous: f64,
    },
    /// A `#` line after the header.
    #[error("{file}:{line}: `#` line after the header (metadata and comments belong before it)")]
    CommentAfterHeader {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
    },
    /// The CSV layer failed (e.g. invalid UTF-8).
    #[error("{file}:{line}: {message}")]
    Csv {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// What the CSV parser said.
        message: String,
    },
}

/// Column positions of the channels.
#[derive(Clone, Debug)]
struct Columns {
    t: usize,
    channels: [Option<usize>; 7],
    names: Vec<String>,
}

/// A streaming recording reader: an iterator of samples.
pub struct RecordingReader<R: Read> {
    file: String,
    metadata: Vec<(String, String)>,
    cols: Columns,
    csv: csv::Reader<R>,
    header_line: u64,
    record: csv::StringRecord,
    previous_t: Option<f64>,
    failed: bool,
    extra: Vec<(String, usize)>,
}

/// A file, plain or gzip-compressed.
pub type FileSource = BufReader<Box<dyn Read + Send>>;

impl RecordingReader<FileSource> {
    /// Open `path` (plain CSV, or gzip-compressed CSV).
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        let file = path.display().to_string();
        let io = |source| RecordingError::Io {
            file: file.clone(),
            source,
        };
        let mut f = BufReader::with_capacity(1 << 16, File::open(path).map_err(io)?);
        let gz = f.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
        let inner: Box<dyn Read + Send> = if gz {
            Box::new(flate2::bufread::MultiGzDecoder::new(f))
        } else {
            Box::new(f)
        };
        Self::new(BufReader::with_capacity(1 << 16, inner), &file)
    }
}

impl<R: BufRead> RecordingReader<R> {
    /// Read from `reader`; `file` names the source in errors.
    pub fn new(mut reader: R, file: &str) -> Result<Self, RecordingError> {
        let file = file.to_string();
        let io = |source| RecordingError::Io {
            file: file.clone(),
            source,
        };
        let mut metadata = Vec::new();
        let mut line_no = 0u64;
        let mut line = String::new();
        let header = loop {
            line.clear();
            if reader.read_line(&mut line).map_err(io)? == 0 {
                return Err(RecordingError::NoHeader { file });
            }
            line_no += 1;
            let text = line.trim_end_matches(['\n', '\r']);
            if let Some(rest) = text.strip_prefix('#') {
                if let Some((k, v)) = rest.trim_start().split_once('=') {
                    if !k.contains(' ') {
                        metadata.push((k.to_string(), v.to_string()));
                    }
                }
                continue;
            }
            if text.trim().is_empty() {
                continue;
            }
            break text.to_string();
        };
        let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
        for (i, n) in names.iter().enumerate() {
            if names[..i].contains(n) {
                return Err(RecordingError::DuplicateColumn {
                    file,
                    line: line_no,
                    column: n.clone(),
                });
            }
        }
        let find = |name: &str| names.iter().position(|n| n == name);
        let missing = |column: &'static str| RecordingError::MissingColumn {
            file: file.clone(),
            line: line_no,
            column,
            header: header.clone(),
        };
        let t = find("t").ok_or_else(|| missing("t"))?;
        let mut channels = [None; 7];
        for ch in Channel::ALL {
            channels[ch as usize] = find(ch.name());
            if ch != Channel::TempOil && channels[ch as usize].is_none() {
                return Err(missing(ch.name()));
            }
        }
        let known: Vec<&str> = std::iter::once("t")
            .chain(Channel::ALL.iter().map(|c| c.name()))
            .collect();
        let extra = names
            .iter()
            .enumerate()
            .filter(|(_, n)| !known.contains(&n.as_str()))
            .map(|(i, n)| (n.clone(), i))
            .collect();
        let csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(reader);
        Ok(Self {
            file,
            metadata,
            cols: Columns { t, channels, names },
            csv,
            header_line: line_no,
            record: csv::StringRecord::new(),
            previous_t: None,
            failed: false,
            extra,
        })
    }

    /// A metadata value.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Columns beyond the format's (name, position), e.g. simulator truth.
    pub fn extra_columns(&self) -> &[(String, usize)] {
        &self.extra
    }

    /// The raw field at `index` of the last row read.
    pub fn last_field(&self, index: usize) -> Option<&str> {
        self.record.get(index)
    }

    /// Read the next sample (the iterator adds the time-order check).
    fn next_sample(&mut self) -> Option<Result<Sample, RecordingError>> {
        if self.failed {
            return None;
        }
        let r = self.read_row();
        if matches!(r, Some(Err(_))) {
            self.failed = true;
        }
        r
    }

    fn read_row(&mut self) -> Option<Result<Sample, RecordingError>> {
        loop {
            match self.csv.read_record(&mut self.record) {
                Ok(false) => return None,
                Ok(true) => {}
                Err(e) => {
                    let line = e.position().map_or(0, |p| p.line()) + self.header_line;
                    return Some(Err(RecordingError::Csv {
                        file: self.file.clone(),
                        line,
                        message: e.to_string(),
                    }));
                }
            }
            let line = self.record.position().map_or(0, |p| p.line()) + self.header_line;
            // Blank lines (a trailing newline pair) are not rows.
            if self.record.len() == 1 && self.record[0].trim().is_empty() {
                continue;
            }
            if self.record.get(0).is_some_and(|f| f.starts_with('#')) {
                return Some(Err(RecordingError::CommentAfterHeader {
                    file: self.file.clone(),
                    line,
                }));
            }
            return Some(self.parse(line));
        }
    }

    fn parse(&self, line: u64) -> Result<Sample, RecordingError> {
        let expected = self.cols.names.len();
        if self.record.len() != expected {
            return Err(RecordingError::FieldCount {
                file: self.file.clone(),
                line,
                expected,
                found: self.record.len(),
            });
        }
        let field = |i: usize| -> Result<Option<f64>, RecordingError> {
            let raw = self.record[i].trim();
            if raw.is_empty() {
                return Ok(None);
            }
            let v: f64 = raw.parse().map_err(|_| RecordingError::BadNumber {
                file: self.file.clone(),
                line,
                index: i + 1,
                column: self.cols.names[i].clone(),
                value: raw.to_string(),
            })?;
            if !v.is_finite() {
                return Err(RecordingError::NotFinite {
                    file: self.file.clone(),
                    line,
                    index: i + 1,
                    column: self.cols.names[i].clone(),
                    value: raw.to_string(),
                });
            }
            Ok(Some(v))
        };
        let t = field(self.cols.t)?.ok_or(RecordingError::MissingTime {
            file: self.file.clone(),
            line,
            index: self.cols.t + 1,
        })?;
        let mut values = [None; 7];
        for ch in Channel::ALL {
            if let Some(i) = self.cols.channels[ch as usize] {
                values[ch as usize] = field(i)?.map(|v| v as f32);
            }
        }
        Ok(Sample {
            t_s: t,
            p_supply_bar: values[0],
            p_piston_bar: values[1],
            p_rod_bar: values[2],
            p_tank_bar: values[3],
            x_piston_m: values[4],
            u_valve: values[5],
            temp_oil_c: values[6],
        })
    }

    /// Check time order (done by the iterator; separate so the checks stay
    /// in one place for line numbers).
    fn check_time(&mut self, s: &Sample) -> Result<(), RecordingError> {
        if let Some(prev) = self.previous_t {
            if s.t_s <= prev {
                let line = self.record.position().map_or(0, |p| p.line()) + self.header_line;
                return Err(RecordingError::TimeNotIncreasing {
                    file: self.file.clone(),
                    line,
                    index: self.cols.t + 1,
                    t: s.t_s,
                    previous: prev,
                });
            }
        }
        self.previous_t = Some(s.t_s);
        Ok(())
    }
}

impl<R: BufRead> Iterator for RecordingReader<R> {
    type Item = Result<Sample, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let s = match self.next_sample()? {
            Ok(s) => s,
            Err(e) => return Some(Err(e)),
        };
        if let Err(e) = self.check_time(&s) {
            self.failed = true;
            return Some(Err(e));
        }
        Some(Ok(s))
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    fn read_all(text: &str) -> Result<Vec<Sample>, RecordingError> {
        RecordingReader::new(text.as_bytes(), "test.csv")?.collect()
    }

    const GOOD: &str = "# format=leak-recording/1\n# sample_rate_hz=1000\n\
        t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve,temp_oil\n\
        0.000,50.12,21.40,12.95,0.80,0.0412,0.000,25.1\n\
        0.001,50.10,21.43,12.93,0.81,0.0412,0.000,25.1\n";

    #[test]
    fn reads_the_spec_example() {
        let r = RecordingReader::new(GOOD.as_bytes(), "x.csv").unwrap();
        assert_eq!(r.meta("sample_rate_hz"), Some("1000"));
        let s: Vec<Sample> = r.collect::<Result<_, _>>().unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].t_s, 0.001);
        assert_eq!(s[0].p_rod_bar, Some(12.95));
        assert_eq!(s[0].temp_oil_c, Some(25.1));
    }

    #[test]
    fn column_order_is_free_unknown_columns_ignored_crlf_ok() {
        let text = "u_valve,t,note,x_piston,p_tank,p_rod,p_piston,p_supply\r\n0.1,0.5,hello,0.05,1,13,21,50\r\n";
        let s = read_all(text).unwrap();
        assert_eq!(s[0].t_s, 0.5);
        assert_eq!(s[0].u_valve, Some(0.1));
        assert_eq!(s[0].p_supply_bar, Some(50.0));
        assert_eq!(s[0].temp_oil_c, None);
    }

    #[test]
    fn empty_field_is_a_missing_reading_not_zero() {
        let text = "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,,13,1,0.05,0\n";
        let s = read_all(text).unwrap();
        assert_eq!(s[0].p_piston_bar, None);
    }

    fn err(text: &str) -> String {
        read_all(text).unwrap_err().to_string()
    }

    #[test]
    fn missing_column_is_named() {
        let e = err("t,p_supply,p_piston,p_tank,x_piston,u_valve\n0,1,2,3,4,5\n");
        assert!(e.contains("test.csv:1") && e.contains("`p_rod`"), "{e}");
    }

    #[test]
    fn bad_number_names_line_and_column() {
        let e = err("# c\nt,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n0.001,50,2l.5,13,1,0.05,0\n");
        assert!(
            e.contains("test.csv:4") && e.contains("column 3 `p_piston`") && e.contains("2l.5"),
            "{e}"
        );
    }

    #[test]
    fn nan_and_infinity_are_rejected() {
        for bad in ["NaN", "nan", "inf", "-Infinity"] {
            let e = err(&format!(
                "t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,{bad},1,0.05,0\n"
            ));
            assert!(
                e.contains("test.csv:2") && e.contains("`p_rod`") && e.contains("finite"),
                "{e}"
            );
        }
    }

    #[test]
    fn time_must_strictly_increase() {
        let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n0.002,50,21,13,1,0.05,0\n0.002,50,21,13,1,0.05,0\n");
        assert!(
            e.contains("test.csv:4") && e.contains("`t`") && e.contains("does not increase"),
            "{e}"
        );
        let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n,50,21,13,1,0.05,0\n");
        assert!(
            e.contains("test.csv:3") && e.contains("`t` is empty"),
            "{e}"
        );
    }

    #[test]
    fn structural_errors() {
        assert!(err("# only comments\n").contains("no header"));
        let e = err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05\n");
        assert!(
            e.contains("test.csv:2") && e.contains("expected 7 fields"),
            "{e}"
        );
        let e =
            err("t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n0,50,21,13,1,0.05,0\n# late\n");
        assert!(
            e.contains("test.csv:3") && e.contains("after the header"),
            "{e}"
        );
        let e = err("t,t,p_supply,p_piston,p_rod,p_tank,x_piston,u_valve\n");
        assert!(e.contains("appears twice"), "{e}");
    }

    #[test]
    fn write_then_read_round_trips() {
        let mut buf = Vec::new();
        let mut w = RecordingWriter::new(
            &mut buf,
            &[("note", "a\nb".into())],
            true,
            &["q_internal_lpm"],
        )
        .unwrap();
        let s = Sample {
            t_s: 0.123,
            p_supply_bar: Some(50.125),
            p_piston_bar: None,
            p_rod_bar: Some(12.5),
            p_tank_bar: Some(0.75),
            x_piston_m: Some(0.041_234),
            u_valve: Some(-0.125),
            temp_oil_c: Some(40.0),
        };
        w.write(&s, &[0.4]).unwrap();
        w.finish().unwrap();
        let text = String::from_utf8(buf).unwrap();
        let r = RecordingReader::new(text.as_bytes(), "rt.csv").unwrap();
        assert_eq!(r.meta("note"), Some("a b"));
        assert_eq!(r.extra_columns(), &[("q_internal_lpm".to_string(), 8)]);
        let back: Vec<Sample> = r.collect::<Result<_, _>>().unwrap();
        assert_eq!(back[0], s);
    }
}
