//! Reading text with limits: a line-length limit, a limit on the bytes of
//! one CSV record (an open quote can join lines) and a total-size limit
//! (decompressed), so that a hostile or broken input (a gzip bomb, a file
//! without line ends) fails fast in constant memory.

use std::io::{self, BufRead, Read};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Input limits of the recording reader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Longest line, bytes (header and data lines alike).
    pub max_line_bytes: u64,
    /// Most text, bytes (after decompression).
    pub max_total_bytes: u64,
}

/// Longest line a recording may have: 64 KiB (a row of the format is about
/// 60 bytes; a header of hundreds of note columns still fits).
pub const MAX_LINE_BYTES: u64 = 64 * 1024;

/// Most text a recording may hold, decompressed: 16 GiB, about 80 hours at
/// 1 kHz with the format's columns.
pub const MAX_TOTAL_BYTES: u64 = 16 << 30;

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_line_bytes: MAX_LINE_BYTES,
            max_total_bytes: MAX_TOTAL_BYTES,
        }
    }
}

/// Which limit was exceeded, at which line (1-based). Travels inside an
/// `io::Error` through the CSV parser.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Exceeded {
    /// A line is longer than the limit.
    #[error("line {line} is longer than {limit} bytes")]
    Line {
        /// Line number.
        line: u64,
        /// The limit.
        limit: u64,
    },
    /// A CSV record (an open `"` joins lines) is longer than the limit.
    #[error("the record at line {line} is longer than {limit} bytes")]
    Record {
        /// Line number.
        line: u64,
        /// The limit.
        limit: u64,
    },
    /// More text than the limit.
    #[error("more than {limit} bytes at line {line}")]
    Total {
        /// Line number.
        line: u64,
        /// The limit.
        limit: u64,
    },
}

impl Exceeded {
    /// The limit carried by an I/O error, if that is what it is.
    pub fn of(e: &io::Error) -> Option<Self> {
        e.get_ref()?.downcast_ref::<Self>().copied()
    }

    fn into_io(self) -> io::Error {
        io::Error::new(io::ErrorKind::InvalidData, self)
    }
}

/// A reader that counts lines and bytes and fails when a limit is passed.
pub struct Bounded<R> {
    inner: R,
    limits: Limits,
    /// Line being read (1-based).
    line: u64,
    /// Bytes of that line so far.
    column: u64,
    /// Bytes read in total.
    total: u64,
    /// Bytes read since the consumer last called [`RecordMark::reset`].
    since_record: Arc<AtomicU64>,
}

/// Lets the CSV consumer say "a record ended here".
#[derive(Clone, Debug, Default)]
pub struct RecordMark(Arc<AtomicU64>);

impl RecordMark {
    /// A record was complete: start counting the next one.
    pub fn reset(&self) {
        self.0.store(0, Ordering::Relaxed);
    }
}

impl<R> Bounded<R> {
    /// Wrap `inner`, which starts at line `line` after `total` bytes.
    pub fn new(inner: R, limits: Limits, line: u64, total: u64) -> (Self, RecordMark) {
        let mark = RecordMark::default();
        let r = Self {
            inner,
            limits,
            line,
            column: 0,
            total,
            since_record: mark.0.clone(),
        };
        (r, mark)
    }

    /// Account for `data` just read.
    fn account(&mut self, data: &[u8]) -> Result<(), Exceeded> {
        self.total += data.len() as u64;
        if self.total > self.limits.max_total_bytes {
            return Err(Exceeded::Total {
                line: self.line,
                limit: self.limits.max_total_bytes,
            });
        }
        for (k, segment) in data.split(|&b| b == b'\n').enumerate() {
            if k > 0 {
                self.line += 1;
                self.column = 0;
            }
            self.column += segment.len() as u64;
            if self.column > self.limits.max_line_bytes {
                return Err(Exceeded::Line {
                    line: self.line,
                    limit: self.limits.max_line_bytes,
                });
            }
        }
        // The CSV parser reads ahead by at most its buffer (8 KiB).
        let record_limit = self.limits.max_line_bytes + (64 << 10);
        let since = self
            .since_record
            .fetch_add(data.len() as u64, Ordering::Relaxed);
        if since + data.len() as u64 > record_limit {
            return Err(Exceeded::Record {
                line: self.line,
                limit: self.limits.max_line_bytes,
            });
        }
        Ok(())
    }
}

impl<R: Read> Read for Bounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.account(&buf[..n]).map_err(Exceeded::into_io)?;
        Ok(n)
    }
}

/// Read one line (up to and including `\n`) into `line`, at most `limit`
/// bytes before the line end; `Ok(0)` at the end of the input.
pub fn read_line(
    reader: &mut impl BufRead,
    line: &mut Vec<u8>,
    limit: u64,
    line_no: u64,
) -> io::Result<usize> {
    line.clear();
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            return Ok(line.len());
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(p) => (p + 1, true),
            None => (buf.len(), false),
        };
        line.extend_from_slice(&buf[..take]);
        reader.consume(take);
        let body = line.len() as u64 - u64::from(done);
        if body > limit {
            return Err(Exceeded::Line {
                line: line_no,
                limit,
            }
            .into_io());
        }
        if done {
            return Ok(line.len());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(line: u64, total: u64) -> Limits {
        Limits {
            max_line_bytes: line,
            max_total_bytes: total,
        }
    }

    #[test]
    fn counts_lines_and_stops_at_a_long_one() {
        let text = b"ab\ncd\nefghij\n";
        let (mut r, _) = Bounded::new(&text[..], limits(4, 100), 1, 0);
        let mut out = Vec::new();
        let e = r.read_to_end(&mut out).unwrap_err();
        assert_eq!(Exceeded::of(&e), Some(Exceeded::Line { line: 3, limit: 4 }));
    }

    #[test]
    fn stops_at_the_total() {
        let text = b"ab\ncd\nef\n";
        let (mut r, _) = Bounded::new(&text[..], limits(4, 5), 1, 0);
        let e = r.read_to_end(&mut Vec::new()).unwrap_err();
        assert!(matches!(Exceeded::of(&e), Some(Exceeded::Total { .. })));
    }

    #[test]
    fn header_line_is_bounded() {
        let mut text = &b"# 0123456789\nt\n"[..];
        let mut line = Vec::new();
        let e = read_line(&mut text, &mut line, 8, 1).unwrap_err();
        assert_eq!(Exceeded::of(&e), Some(Exceeded::Line { line: 1, limit: 8 }));
        let mut text = &b"t,x\r\n"[..];
        assert_eq!(read_line(&mut text, &mut line, 8, 1).unwrap(), 5);
        assert_eq!(read_line(&mut text, &mut line, 8, 2).unwrap(), 0);
    }
}
