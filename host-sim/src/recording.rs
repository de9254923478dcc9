//! Recordings in the CSV format of `docs/recording-format.md`: a streaming
//! reader (constant memory, any length up to [`MAX_TOTAL_BYTES`], lines up
//! to [`MAX_LINE_BYTES`]) with errors that name the file, line and column,
//! and a writer. Gzip-compressed recordings (`.csv.gz`, recognised by their
//! magic bytes) are read and written transparently: an hour at 1 kHz is
//! 200 MB of text. The path `-` reads standard input.

pub(crate) mod bounded;
mod top;
mod write;

use bounded::{Bounded, Exceeded, RecordMark};
pub use bounded::{Limits, MAX_LINE_BYTES, MAX_TOTAL_BYTES};
use top::{columns, read_top};
pub use write::{FileSink, RecordingWriter};

use monitor::{Channel, Sample};
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

/// Format tag written to new recordings.
pub const FORMAT: &str = "leak-recording/1";

/// A recording that cannot be read, and exactly where.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be opened or read (the cause is in the message,
    /// not repeated as a source).
    #[error("{file}: cannot read: {cause}")]
    Io {
        /// File name.
        file: String,
        /// Cause.
        cause: io::Error,
    },
    /// A line is longer than the reader's limit.
    #[error("{file}:{line}: line longer than {limit} bytes (not a recording, or no line ends)")]
    LineTooLong {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// The limit, bytes.
        limit: u64,
    },
    /// A CSV record (lines joined by an open `"`) is longer than the limit.
    #[error("{file}:{line}: record longer than {limit} bytes (an unclosed `\"`?)")]
    RecordTooLong {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// The limit, bytes.
        limit: u64,
    },
    /// More text than the reader's limit (after decompression).
    #[error("{file}:{line}: more than {limit} bytes of text (decompressed): larger than any recording host-sim reads")]
    TooLarge {
        /// File name.
        file: String,
        /// Line number where the limit was reached.
        line: u64,
        /// The limit, bytes.
        limit: u64,
    },
    /// `# sample_rate_hz=` is not a plausible rate.
    #[error("{file}:{line}: `sample_rate_hz={value}` is not a plausible sample rate (a number of Hz within {MIN_SAMPLE_RATE_HZ}..{MAX_SAMPLE_RATE_HZ})")]
    BadSampleRate {
        /// File name.
        file: String,
        /// Metadata line number.
        line: u64,
        /// The value as found.
        value: String,
    },
    /// More `# key=value` lines than the reader keeps.
    #[error("{file}:{line}: more than {limit} metadata lines (`# key=value`) before the header")]
    TooMuchMetadata {
        /// File name.
        file: String,
        /// Line number.
        line: u64,
        /// The limit.
        limit: usize,
    },
    /// The header is not followed by any sample.
    #[error("{file}:{line}: no samples after the header (a recording needs at least one row)")]
    NoSamples {
        /// File name.
        file: String,
        /// Header line number.
        line: u64,
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
    /// A reading beyond the range of the monitor's `f32` inputs.
    #[error(
        "{file}:{line}: column {index} `{column}`: `{value}` is out of range (beyond ±3.4e38)"
    )]
    OutOfRange {
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

/// Most `# key=value` lines a recording may have.
pub const MAX_METADATA: usize = 1024;

/// Lowest plausible `# sample_rate_hz=`, Hz.
pub const MIN_SAMPLE_RATE_HZ: f64 = 10.0;
/// Highest plausible `# sample_rate_hz=`, Hz.
pub const MAX_SAMPLE_RATE_HZ: f64 = 100_000.0;

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
    csv: csv::Reader<Bounded<R>>,
    mark: RecordMark,
    header_line: u64,
    record: csv::StringRecord,
    previous_t: Option<f64>,
    rows: u64,
    failed: bool,
    extra: Vec<(String, usize)>,
}

/// A file (or standard input), plain or gzip-compressed.
pub type FileSource = BufReader<Box<dyn Read + Send>>;

impl RecordingReader<FileSource> {
    /// Open `path` (plain CSV, or gzip-compressed CSV; `-` is standard
    /// input) with the default [`Limits`].
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        Self::open_with_limits(path, Limits::default())
    }

    /// [`open`](Self::open) with other limits.
    pub fn open_with_limits(path: &Path, limits: Limits) -> Result<Self, RecordingError> {
        let stdin = path.as_os_str() == "-";
        let file = if stdin {
            "<stdin>".to_string()
        } else {
            path.display().to_string()
        };
        let io = |cause| RecordingError::Io {
            file: file.clone(),
            cause,
        };
        let raw: Box<dyn Read + Send> = if stdin {
            Box::new(io::stdin())
        } else {
            Box::new(File::open(path).map_err(io)?)
        };
        let mut f = BufReader::with_capacity(1 << 16, raw);
        let gz = f.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
        let inner: Box<dyn Read + Send> = if gz {
            Box::new(flate2::bufread::MultiGzDecoder::new(f))
        } else {
            Box::new(f)
        };
        Self::with_limits(BufReader::with_capacity(1 << 16, inner), &file, limits)
    }
}

impl<R: BufRead> RecordingReader<R> {
    /// Read from `reader`; `file` names the source in errors.
    pub fn new(reader: R, file: &str) -> Result<Self, RecordingError> {
        Self::with_limits(reader, file, Limits::default())
    }

    /// [`new`](Self::new) with other limits.
    pub fn with_limits(mut reader: R, file: &str, limits: Limits) -> Result<Self, RecordingError> {
        let file = file.to_string();
        let top = read_top(&mut reader, &file, limits)?;
        let (cols, extra) = columns(&top, &file)?;
        let (bounded, mark) = Bounded::new(reader, limits, top.line + 1, top.bytes);
        let csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(bounded);
        Ok(Self {
            file,
            metadata: top.metadata,
            cols,
            csv,
            mark,
            header_line: top.line,
            record: csv::StringRecord::new(),
            previous_t: None,
            rows: 0,
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

    /// The recording has a column for `channel`.
    pub fn has_channel(&self, channel: Channel) -> bool {
        self.cols.channels[channel as usize].is_some()
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
                    let message = e.to_string();
                    return Some(Err(match e.into_kind() {
                        csv::ErrorKind::Io(cause) => io_error(&self.file, cause),
                        _ => RecordingError::Csv {
                            file: self.file.clone(),
                            line,
                            message,
                        },
                    }));
                }
            }
            self.mark.reset();
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
                values[ch as usize] = field(i)?.map(|v| self.to_f32(v, line, i)).transpose()?;
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

    /// A reading as the monitor's `f32`: beyond its range is an error,
    /// never an infinity.
    fn to_f32(&self, v: f64, line: u64, i: usize) -> Result<f32, RecordingError> {
        let x = v as f32;
        if x.is_finite() {
            return Ok(x);
        }
        Err(RecordingError::OutOfRange {
            file: self.file.clone(),
            line,
            index: i + 1,
            column: self.cols.names[i].clone(),
            value: self.record[i].trim().to_string(),
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

/// An I/O error of `file`, or the limit it carries.
fn io_error(file: &str, cause: io::Error) -> RecordingError {
    let file = file.to_string();
    match Exceeded::of(&cause) {
        Some(Exceeded::Line { line, limit }) => RecordingError::LineTooLong { file, line, limit },
        Some(Exceeded::Record { line, limit }) => {
            RecordingError::RecordTooLong { file, line, limit }
        }
        Some(Exceeded::Total { line, limit }) => RecordingError::TooLarge { file, line, limit },
        None => RecordingError::Io { file, cause },
    }
}

impl<R: BufRead> Iterator for RecordingReader<R> {
    type Item = Result<Sample, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let s = match self.next_sample() {
            Some(Ok(s)) => s,
            Some(Err(e)) => return Some(Err(e)),
            None if self.rows == 0 && !self.failed => {
                // A header alone is no recording (and no evidence).
                self.failed = true;
                return Some(Err(RecordingError::NoSamples {
                    file: self.file.clone(),
                    line: self.header_line,
                }));
            }
            None => return None,
        };
        self.rows += 1;
        if let Err(e) = self.check_time(&s) {
            self.failed = true;
            return Some(Err(e));
        }
        Some(Ok(s))
    }
}

#[cfg(test)]
mod tests;
