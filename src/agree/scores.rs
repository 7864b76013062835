//! Reading the scores of `score --pairs --json`: one object a line with the
//! item's `id` and `pg2s`, `s_plan`, `s_goal`, `kas` (a number, or `null`
//! when the metric has no value), and the PG2S settings that made them
//! (`pg2s_settings`, which `agree` checks against its own). Other fields
//! are ignored.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize as _;
use serde_json::Value;

use super::{MetricValues, METRICS};
use crate::dataset::{read_text, DatasetError, LineError};
use crate::metrics::pg2s::Pg2sSettings;

/// The scores of a file and what it records of how they were made.
#[derive(Debug, Default)]
pub struct LoadedScores {
    /// The metric values by item id (a later line for the same id wins).
    pub values: HashMap<String, MetricValues>,
    /// The lines that could not be read.
    pub errors: Vec<LineError>,
    /// Each distinct PG2S settings the lines record (`pg2s_settings`, as
    /// `score --json` writes it), with the first line that records it.
    pub settings: Vec<(usize, Pg2sSettings)>,
    /// The first line with a PG2S value that records no settings (a file
    /// written before mapvlm recorded them), if any.
    pub unrecorded: Option<usize>,
}

/// Scores made with other PG2S settings than those asked for, so that
/// comparing them with people would judge a metric nobody asked about.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsMismatch {
    /// A line records settings that differ.
    #[error(
        "{}:{line}: these scores were computed with the PG2S {recorded}, not the {wanted} asked for: \
         give the same --sentence-threshold, --word-threshold and --alpha as `score`, or score the items again",
        path.display()
    )]
    Differ {
        /// The scores file.
        path: PathBuf,
        /// The first line with the settings.
        line: usize,
        /// What the line records.
        recorded: Pg2sSettings,
        /// What was asked for.
        wanted: Pg2sSettings,
    },
    /// Settings other than the defaults were asked for, and a line does
    /// not say which settings made it.
    #[error(
        "{}:{line}: these scores do not record their PG2S settings, so they cannot be checked against the {wanted} asked for: \
         score the items again (`mapvlm score --pairs ITEMS --json` with the same flags), which records them",
        path.display()
    )]
    Unrecorded {
        /// The scores file.
        path: PathBuf,
        /// The first line without settings.
        line: usize,
        /// What was asked for.
        wanted: Pg2sSettings,
    },
}

impl LoadedScores {
    /// Checks that the scores of `path` were computed with `wanted`: every
    /// line that records settings must record these; lines that record
    /// none are taken as the defaults' (what mapvlm used before it recorded
    /// them), so they pass only when `wanted` is the default.
    pub fn check_settings(
        &self,
        path: &Path,
        wanted: Pg2sSettings,
    ) -> Result<(), SettingsMismatch> {
        if let Some(&(line, recorded)) = self.settings.iter().find(|(_, s)| *s != wanted) {
            return Err(SettingsMismatch::Differ {
                path: path.to_path_buf(),
                line,
                recorded,
                wanted,
            });
        }
        match self.unrecorded {
            Some(line) if wanted != Pg2sSettings::default() => Err(SettingsMismatch::Unrecorded {
                path: path.to_path_buf(),
                line,
                wanted,
            }),
            _ => Ok(()),
        }
    }
}

/// The scores of a file, the lines that could not be read, and the PG2S
/// settings the lines record.
pub fn load_scores(path: &Path) -> Result<LoadedScores, DatasetError> {
    let text = read_text(path)?;
    let mut loaded = LoadedScores::default();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match parse_line(line) {
            Ok((id, values, settings)) => {
                match settings {
                    Some(s) if !loaded.settings.iter().any(|(_, k)| *k == s) => {
                        loaded.settings.push((n + 1, s));
                    }
                    None if values[..3].iter().any(Option::is_some) => {
                        loaded.unrecorded.get_or_insert(n + 1);
                    }
                    _ => {}
                }
                loaded.values.insert(id, values);
            }
            Err(message) => loaded.errors.push(LineError {
                path: path.to_path_buf(),
                line: n + 1,
                message,
                id: None,
            }),
        }
    }
    Ok(loaded)
}

/// The id, the metric values and the recorded PG2S settings of one line,
/// or what is wrong with it.
fn parse_line(line: &str) -> Result<(String, MetricValues, Option<Pg2sSettings>), String> {
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
    let settings = match value.get("pg2s_settings") {
        None | Some(Value::Null) => None,
        Some(raw) => {
            let settings = Pg2sSettings::deserialize(raw)
                .map_err(|e| format!("`pg2s_settings` is not PG2S settings ({e})"))?;
            settings
                .validate()
                .map_err(|e| format!("`pg2s_settings`: {e}"))?;
            Some(settings)
        }
    };
    Ok((id.to_string(), values, settings))
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
        let LoadedScores {
            values: scores,
            errors,
            ..
        } = load_scores(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scores["a"], [Some(0.1), Some(1.0), None, None]);
        assert_eq!(scores["c"][0], Some(0.1 + 0.2));
        assert_eq!(scores["c"][2], Some(f64::MIN_POSITIVE));
        assert_eq!(errors.len(), 1);
        assert_eq!(errors[0].line, 2);
        assert!(errors[0].message.contains("pg2s"), "{}", errors[0]);
    }

    #[test]
    fn recorded_settings_must_be_the_ones_asked_for() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("scores.jsonl");
        let seven = r#""pg2s_settings": {"sentence_threshold": 0.7, "word_threshold": 0.708, "alpha": 0.5}"#;
        let text = format!(
            "{{\"id\": \"a\", \"pg2s\": 0.5, {seven}}}\n{{\"id\": \"b\", \"pg2s\": 0.4, {seven}}}\n\
             {{\"id\": \"c\", \"kas\": 0.5}}\n{{\"id\": \"d\", \"pg2s\": 1, \"pg2s_settings\": {{\"alpha\": 0.5}}}}\n"
        );
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        let loaded = load_scores(&path).unwrap_or_else(|e| panic!("{e}"));
        let asked = Pg2sSettings {
            sentence_threshold: 0.7,
            ..Pg2sSettings::default()
        };
        assert_eq!(loaded.settings, [(1, asked)]);
        assert_eq!(loaded.unrecorded, None, "a KAS-only line needs no settings");
        assert_eq!(
            loaded.errors.len(),
            1,
            "settings missing a field are refused"
        );
        assert_eq!(loaded.check_settings(&path, asked), Ok(()));
        let refused = loaded
            .check_settings(&path, Pg2sSettings::default())
            .unwrap_err();
        assert!(
            matches!(refused, SettingsMismatch::Differ { line: 1, .. }),
            "{refused}"
        );
        assert!(
            refused.to_string().contains("sentence threshold 0.7"),
            "{refused}"
        );

        std::fs::write(&path, "{\"id\": \"a\", \"pg2s\": 0.5}\n").unwrap_or_else(|e| panic!("{e}"));
        let old = load_scores(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(old.check_settings(&path, Pg2sSettings::default()), Ok(()));
        assert!(matches!(
            old.check_settings(&path, asked),
            Err(SettingsMismatch::Unrecorded { line: 1, .. })
        ));
    }
}
