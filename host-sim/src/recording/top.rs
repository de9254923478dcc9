//! The top of a recording: `#` metadata lines and the header.

use super::bounded::{self, Limits};
use super::{
    io_error, Columns, RecordingError, MAX_METADATA, MAX_SAMPLE_RATE_HZ, MIN_SAMPLE_RATE_HZ,
};
use monitor::Channel;
use std::io::BufRead;

/// The metadata and header lines at the top of a recording.
pub(super) struct Top {
    pub metadata: Vec<(String, String)>,
    pub header: String,
    pub line: u64,
    pub bytes: u64,
}

/// Read the `#` lines and the header (each line bounded).
pub(super) fn read_top(
    reader: &mut impl BufRead,
    file: &str,
    limits: Limits,
) -> Result<Top, RecordingError> {
    let mut metadata = Vec::new();
    let (mut line_no, mut bytes) = (0u64, 0u64);
    let mut raw = Vec::new();
    loop {
        let n = bounded::read_line(reader, &mut raw, limits.max_line_bytes, line_no + 1)
            .map_err(|e| io_error(file, e))?;
        if n == 0 {
            return Err(RecordingError::NoHeader { file: file.into() });
        }
        line_no += 1;
        bytes += n as u64;
        if bytes > limits.max_total_bytes {
            return Err(RecordingError::TooLarge {
                file: file.into(),
                line: line_no,
                limit: limits.max_total_bytes,
            });
        }
        let text = std::str::from_utf8(&raw).map_err(|e| RecordingError::Csv {
            file: file.into(),
            line: line_no,
            message: format!("invalid UTF-8: {e}"),
        })?;
        // A byte-order mark (some Windows tools write one) is not text.
        let text = if line_no == 1 {
            text.strip_prefix('\u{feff}').unwrap_or(text)
        } else {
            text
        };
        let text = text.trim_end_matches(['\n', '\r']);
        if let Some(rest) = text.strip_prefix('#') {
            if let Some((k, v)) = rest.trim_start().split_once('=') {
                if !k.contains(' ') {
                    if metadata.len() == MAX_METADATA {
                        return Err(RecordingError::TooMuchMetadata {
                            file: file.into(),
                            line: line_no,
                            limit: MAX_METADATA,
                        });
                    }
                    check_metadata(file, line_no, k, v)?;
                    metadata.push((k.to_string(), v.to_string()));
                }
            }
            continue;
        }
        if text.trim().is_empty() {
            continue;
        }
        return Ok(Top {
            metadata,
            header: text.to_string(),
            line: line_no,
            bytes,
        });
    }
}

/// Refuse metadata the reader would act on wrongly.
fn check_metadata(file: &str, line: u64, key: &str, value: &str) -> Result<(), RecordingError> {
    if key == "sample_rate_hz" {
        let ok = value
            .trim()
            .parse::<f64>()
            .is_ok_and(|r| (MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&r));
        if !ok {
            return Err(RecordingError::BadSampleRate {
                file: file.into(),
                line,
                value: value.into(),
            });
        }
    }
    Ok(())
}

/// The channels' columns and the extra columns of the header.
pub(super) fn columns(
    top: &Top,
    file: &str,
) -> Result<(Columns, Vec<(String, usize)>), RecordingError> {
    let header = &top.header;
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(RecordingError::DuplicateColumn {
                file: file.into(),
                line: top.line,
                column: n.clone(),
            });
        }
    }
    let find = |name: &str| names.iter().position(|n| n == name);
    let missing = |column: &'static str| RecordingError::MissingColumn {
        file: file.into(),
        line: top.line,
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
    Ok((Columns { t, channels, names }, extra))
}
