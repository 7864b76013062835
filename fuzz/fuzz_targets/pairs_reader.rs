//! The pairs reader on any file: it never panics, yields one item per
//! non-blank line at most, each error names a line that exists, and the
//! bounded line reader under it keeps no line longer than its limit, in
//! both its skipping and its cutting modes. The first byte picks a small
//! limit so that long lines are common.
#![no_main]

use std::io::BufReader;
use std::path::PathBuf;

use libfuzzer_sys::fuzz_target;
use mapvlm::dataset::lines::{BoundedLines, LineProblem};
use mapvlm::dataset::PairsReader;

fuzz_target!(|input: &[u8]| {
    let Some((&first, bytes)) = input.split_first() else {
        return;
    };
    let limit = usize::from(first % 64) + 1;
    let lines = bytes.split(|&b| b == b'\n').count();
    for cutting in [false, true] {
        let reader = BufReader::with_capacity(7, bytes);
        let read = if cutting {
            BoundedLines::cutting(reader, limit)
        } else {
            BoundedLines::new(reader, limit)
        };
        let mut expected = 1;
        for line in read {
            let (n, text) = line.unwrap_or_else(|e| panic!("reading memory: {e}"));
            assert_eq!(n, expected, "line numbers run on");
            expected += 1;
            match text {
                Ok(text) => assert!(text.len() <= limit, "{} bytes kept", text.len()),
                Err(LineProblem::TooLong { bytes, .. }) => {
                    assert!(!cutting, "a cutting reader skipped a line");
                    assert!(bytes > limit);
                }
                Err(LineProblem::NotUtf8 { .. }) => {}
            }
        }
        assert!(expected - 1 <= lines);
    }
    let source = Box::new(BufReader::new(std::io::Cursor::new(bytes.to_vec())));
    let reader = PairsReader::new(source, PathBuf::from("fuzz.jsonl"));
    for item in reader {
        if let Err(error) = item {
            assert!(error.line <= lines, "line {} of {lines}", error.line);
            assert!(error.to_string().starts_with("fuzz.jsonl:"), "{error}");
        }
    }
});
