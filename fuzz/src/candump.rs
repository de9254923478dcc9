//! The candump decoder (`host_sim::decode`) on an arbitrary byte stream.
//!
//! Properties: no panic; an error names the input and the line
//! (`fuzz.log:N: …`); the text and the JSON output decode the same way
//! (same summary, or the same error); one output line per frame, each
//! JSON line an object; the summary adds up (every frame is decoded, bad
//! CRC, malformed or foreign; jumps and repeats are decoded frames); in
//! strict mode every skipped line is reported once.

use host_sim::decode::{decode_stream, Summary};

const NAME: &str = "fuzz.log";

fn decode(data: &[u8], json: bool) -> (Result<Summary, String>, Vec<u8>, Vec<u8>) {
    let mut out = Vec::new();
    let mut strict = Vec::new();
    let r = decode_stream(data, NAME, json, &mut out, Some(&mut strict), None).map_err(|e| {
        let msg = format!("{e:#}");
        let rest = msg
            .strip_prefix(NAME)
            .and_then(|m| m.strip_prefix(':'))
            .unwrap_or_else(|| panic!("error without the input's name: {msg}"));
        let line = rest.split(':').next().unwrap_or("");
        assert!(
            line.parse::<u64>().is_ok_and(|n| n >= 1),
            "error without a line number: {msg}"
        );
        msg
    });
    (r, out, strict)
}

fn lines(b: &[u8]) -> usize {
    b.iter().filter(|&&c| c == b'\n').count()
}

pub fn run(data: &[u8]) {
    let (text, text_out, text_strict) = decode(data, false);
    let (json, json_out, json_strict) = decode(data, true);
    assert_eq!(text, json, "text and JSON output decode differently");
    assert_eq!(text_strict, json_strict);
    assert_eq!(lines(&text_out), lines(&json_out));
    for line in json_out.split(|&c| c == b'\n').filter(|l| !l.is_empty()) {
        let v: serde_json::Value = serde_json::from_slice(line).expect("JSON output parses");
        assert!(v.is_object());
    }
    let Ok(s) = text else {
        return;
    };
    assert_eq!(lines(&text_out) as u64, s.frames, "one line per frame");
    assert_eq!(
        s.frames,
        s.decoded + s.bad_crc + s.malformed + s.foreign,
        "{s:?}"
    );
    assert!(s.counter_jumps + s.repeated <= s.decoded, "{s:?}");
    assert!(s.frames_lost >= s.counter_jumps && s.frames_lost <= 13 * s.counter_jumps);
    assert_eq!(lines(&text_strict) as u64, s.skipped(), "{s:?}");
    assert_eq!(
        s.has_errors(),
        s.bad_crc + s.malformed + s.counter_jumps + s.repeated + s.skipped() > 0
    );
}
