//! The step parser on any step file: `read_text` drops a byte-order mark
//! and refuses only what is not UTF-8; `parse_steps` never panics and every
//! step it gives is one trimmed, non-empty line; `bound_steps` leaves at
//! most `MAX_STEPS` steps of at most `MAX_STEP_CHARS` characters, and says
//! so exactly when it changed something.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use mapvlm::dataset::read_text;
use mapvlm::plan::{bound_steps, parse_steps, MAX_STEPS, MAX_STEP_CHARS};

const BOM: &[u8] = "\u{feff}".as_bytes();

fn folder() -> &'static tempfile::TempDir {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap_or_else(|e| panic!("{e}")))
}

fuzz_target!(|bytes: &[u8]| {
    let path = folder().path().join("steps.txt");
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    let text = match read_text(&path) {
        Ok(text) => text,
        Err(_) => {
            assert!(std::str::from_utf8(bytes).is_err(), "UTF-8 refused");
            return;
        }
    };
    assert_eq!(text.as_bytes(), bytes.strip_prefix(BOM).unwrap_or(bytes));
    let mut steps = parse_steps(&text);
    for step in &steps {
        assert!(!step.is_empty(), "an empty step from {text:?}");
        assert_eq!(step.trim(), step, "an untrimmed step from {text:?}");
        assert!(!step.contains('\n'), "a step of two lines from {text:?}");
    }
    assert!(steps.len() <= text.lines().count());
    let parsed = steps.clone();
    let note = bound_steps(&mut steps);
    assert!(steps.len() <= MAX_STEPS);
    assert!(steps.iter().all(|s| s.chars().count() <= MAX_STEP_CHARS));
    assert_eq!(note.is_some(), steps != parsed, "{note:?}");
});
