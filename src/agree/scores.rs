//! Reading the scores of `score --pairs --json`: one object a line with the
//! item's `id` and `pg2s`, `s_plan`, `s_goal`, `kas` (a number, or `null`
//! when the metric has no value). Other fields are ignored.

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

use super::{MetricValues, METRICS};
use crate::dataset::{read_text, DatasetError, LineError};

/// The scores of a file by item id (a later line for the same id wins), and
/// the lines that could not be read.
pub fn load_scores(
    path: &Path,
) -> Result<(HashMap<String, MetricValues>, Vec<LineError>), DatasetError> {
    let text = read_text(path)?;
    let mut scores = HashMap::new();
    let mut errors = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match parse_line(line) {
            Ok((id, values)) => {
                scores.insert(id, values);
            }
            Err(message) => errors.push(LineError {
                path: path.to_path_buf(),
                line: n + 1,
                message,
            }),
        }
    }
    Ok((scores, errors))
}

fn parse_line(line: &str) -> Result<(String, MetricValues), String> {
    let value: Value =
        serde_json::from_str(line).map_err(|e| format!("not a JSON object of scores: {e}"))?;
    let id = value
        .get("id")
        .and_then(Value::as_str)
        .ok_or("no string `id`; a scores line is what `mapvlm score --pairs --json` writes")?;
    let mut values = [None; 4];
    for (slot, name) in values.iter_mut().zip(METRICS) {
        *slot = match value.get(name) {
            None | Some(Value::Null) => None,
            Some(Value::Number(x)) => x.as_f64(),
            Some(other) => return Err(format!("`{name}` is {other}, not a number or null")),
        };
    }
    Ok((id.to_string(), values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_read_exactly_and_bad_lines_are_named() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("scores.jsonl");
        let text = concat!(
            r#"{"id": "a", "pg2s": 0.1000000000000000055511151231257827, "s_plan": 1, "kas": null}"#,
            "\n{\"id\": \"b\", \"pg2s\": \"high\"}\n\n",
            r#"{"id": "c", "pg2s": 0.30000000000000004, "s_goal": 2.2250738585072014e-308}"#,
            "\n"
        );
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        let (scores, errors) = load_scores(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scores["a"], [Some(0.1), Some(1.0), None, None]);
        assert_eq!(scores["c"][0], Some(0.1 + 0.2));
        assert_eq!(scores["c"][2], Some(f64::MIN_POSITIVE));
        assert_eq!(errors.len(), 1);
        assert_eq!(errors[0].line, 2);
        assert!(errors[0].message.contains("pg2s"), "{}", errors[0]);
    }
}
