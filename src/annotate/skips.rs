//! The items an annotator skipped, kept across sittings, so that reopening
//! the screen still leaves them for last (`annotate.md` §3: "skip").
//!
//! They live in a file of their own beside the annotations file
//! (`items.annotations.jsonl` → `items.annotations.skips.jsonl`), one line
//! `{item | pair, annotator, skipped, at}` a skip (or a `skipped: false`
//! when a skipped item is judged after all), the later line winning. The
//! annotations file that `agree` reads keeps exactly the lines §3 defines.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::judgements::Subject;
use crate::dataset::{read_text, DatasetError, LineError};

/// One line of a skips file.
#[derive(Debug, Default, Deserialize, Serialize)]
struct SkipLine {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    item: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pair: Option<[String; 2]>,
    annotator: String,
    skipped: bool,
    #[serde(default)]
    at: u64,
}

/// The skips file that goes with an annotations file.
pub fn skips_path(annotations: &Path) -> PathBuf {
    let name = annotations
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name.strip_suffix(".jsonl").unwrap_or(&name);
    annotations.with_file_name(format!("{stem}.skips.jsonl"))
}

/// The line that records `subject` as skipped (or no longer) by
/// `annotator` at `at`, without the newline.
pub fn skip_line(subject: &Subject, annotator: &str, skipped: bool, at: u64) -> String {
    let (item, pair) = match subject {
        Subject::Item(id) => (Some(id.clone()), None),
        Subject::Pair(l, r) => (None, Some([l.clone(), r.clone()])),
    };
    let line = SkipLine {
        item,
        pair,
        annotator: annotator.to_string(),
        skipped,
        at,
    };
    // Strings, a bool and a number always serialise.
    serde_json::to_string(&line).unwrap_or_default()
}

/// What `annotator` has skipped, as the skips file at `path` says (none
/// when it does not exist yet); unreadable lines are returned with file
/// and line, and the rest read.
pub fn load_skips(
    path: &Path,
    annotator: &str,
) -> Result<(HashSet<Subject>, Vec<LineError>), DatasetError> {
    let mut skipped = HashSet::new();
    let mut errors = Vec::new();
    if !path.exists() {
        return Ok((skipped, errors));
    }
    for (n, text) in read_text(path)?.lines().enumerate() {
        if text.trim().is_empty() {
            continue;
        }
        let parsed = serde_json::from_str::<SkipLine>(text)
            .map_err(|e| format!("not a skip line: {e}"))
            .and_then(|l| {
                let subject = match (l.item, l.pair) {
                    (Some(item), None) => Subject::Item(item),
                    (None, Some([a, b])) => Subject::Pair(a, b),
                    _ => return Err("names neither one `item` nor one `pair`".to_string()),
                };
                Ok((subject, l.annotator, l.skipped))
            });
        match parsed {
            Ok((subject, who, on)) if who == annotator => {
                if on {
                    skipped.insert(subject);
                } else {
                    skipped.remove(&subject);
                }
            }
            Ok(_) => {}
            Err(message) => errors.push(LineError {
                path: path.to_path_buf(),
                line: n + 1,
                message,
                id: None,
            }),
        }
    }
    Ok((skipped, errors))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skips_are_read_back_per_annotator_the_later_line_winning() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let ann = dir.path().join("items.annotations.jsonl");
        let path = skips_path(&ann);
        assert_eq!(path, dir.path().join("items.annotations.skips.jsonl"));
        let a = Subject::Item("a".into());
        let pair = Subject::Pair("b".into(), "c".into());
        let text = [
            skip_line(&a, "ana", true, 1),
            skip_line(&pair, "ana", true, 2),
            skip_line(&Subject::Item("d".into()), "bo", true, 3),
            "{broken".to_string(),
            skip_line(&a, "ana", false, 4),
        ]
        .join("\n");
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        let (skipped, errors) = load_skips(&path, "ana").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(skipped, HashSet::from([pair]));
        assert_eq!(errors.len(), 1);
        assert_eq!(errors[0].line, 4);
        let (none, _) =
            load_skips(&dir.path().join("nothing.jsonl"), "ana").unwrap_or_else(|e| panic!("{e}"));
        assert!(none.is_empty());
    }
}
