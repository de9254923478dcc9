//! The recording reader (`host_sim::recording`) on arbitrary bytes, plain
//! or gzip-compressed, read as `RecordingReader::open` reads a file (gzip
//! recognised by its magic bytes, then `MultiGzDecoder`).
//!
//! Properties: no panic; after an error the iterator ends; every sample
//! has a finite, strictly increasing time and finite readings; a reader
//! that yields no sample has reported an error (a header alone is no
//! recording); a `sample_rate_hz` it accepted is within the plausible
//! range; every error names the file; and plain text read directly or
//! through gzip gives the same samples and the same error (unless an input
//! limit was hit, whose position depends on the read-ahead: then both
//! fail).

use host_sim::recording::{
    Limits, RecordingError, RecordingReader, MAX_SAMPLE_RATE_HZ, MIN_SAMPLE_RATE_HZ,
};
use monitor::Sample;
use std::io::{BufRead, BufReader, Read, Write};

/// Small limits, so that a gzip bomb or a long line fails in a few ms.
const LIMITS: Limits = Limits {
    max_line_bytes: 4096,
    max_total_bytes: 1 << 20,
};

const FILE: &str = "fuzz.csv";

/// What reading a whole recording gave.
#[derive(Debug, PartialEq)]
struct Outcome {
    samples: Vec<Sample>,
    /// The error that ended it (its message), if any.
    error: Option<String>,
    /// Was it an input limit?
    limit: bool,
}

fn is_limit(e: &RecordingError) -> bool {
    matches!(
        e,
        RecordingError::LineTooLong { .. }
            | RecordingError::RecordTooLong { .. }
            | RecordingError::TooLarge { .. }
    )
}

fn check_error(e: &RecordingError) -> String {
    let msg = e.to_string();
    assert!(msg.starts_with(FILE), "error does not name the file: {msg}");
    msg
}

fn read(source: impl BufRead) -> Outcome {
    let mut r = match RecordingReader::with_limits(source, FILE, LIMITS) {
        Ok(r) => r,
        Err(e) => {
            return Outcome {
                samples: Vec::new(),
                limit: is_limit(&e),
                error: Some(check_error(&e)),
            }
        }
    };
    if let Some(rate) = r.meta("sample_rate_hz") {
        let hz: f64 = rate.trim().parse().expect("accepted sample_rate_hz parses");
        assert!((MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&hz));
    }
    let mut samples: Vec<Sample> = Vec::new();
    let mut error = None;
    let mut limit = false;
    for item in r.by_ref() {
        match item {
            Ok(s) => {
                assert!(error.is_none(), "a sample after an error");
                assert!(s.t_s.is_finite(), "time {}", s.t_s);
                if let Some(prev) = samples.last() {
                    assert!(s.t_s > prev.t_s, "time {} after {}", s.t_s, prev.t_s);
                }
                for v in s.readings().into_iter().flatten() {
                    assert!(v.is_finite(), "reading {v}");
                }
                samples.push(s);
            }
            Err(e) => {
                assert!(error.is_none(), "a second error: {e}");
                limit = is_limit(&e);
                error = Some(check_error(&e));
            }
        }
    }
    assert!(r.next().is_none(), "the reader goes on after its end");
    assert!(
        !samples.is_empty() || error.is_some(),
        "no samples and no error"
    );
    Outcome {
        samples,
        error,
        limit,
    }
}

/// As `RecordingReader::open_with_limits` layers a file.
fn read_bytes(data: &[u8]) -> Outcome {
    let mut f = BufReader::with_capacity(1 << 16, data);
    let gz = f.fill_buf().expect("in memory").starts_with(&[0x1f, 0x8b]);
    let inner: Box<dyn Read + Send + '_> = if gz {
        Box::new(flate2::bufread::MultiGzDecoder::new(f))
    } else {
        Box::new(f)
    };
    read(BufReader::with_capacity(1 << 16, inner))
}

pub fn run(data: &[u8]) {
    let direct = read_bytes(data);
    if data.starts_with(&[0x1f, 0x8b]) {
        return;
    }
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(data).expect("in memory");
    let compressed = gz.finish().expect("in memory");
    let via_gzip = read_bytes(&compressed);
    if direct.limit || via_gzip.limit {
        assert!(
            direct.error.is_some() && via_gzip.error.is_some(),
            "a limit hit one way only: {direct:?} vs {via_gzip:?}"
        );
    } else {
        assert_eq!(direct, via_gzip, "plain and gzip differ");
    }
}
