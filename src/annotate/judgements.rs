//! The annotations file (`annotate.md` §3): one judgement a line, appended as
//! it is made, read back with the later line for the same (item or pair,
//! annotator) winning.
//!
//! Every stage that reads or writes judgements goes through [`Judgement`]:
//! the annotation screen appends them, `agree` and `--export` read them.

use std::collections::HashMap;
use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::dataset::{read_text, DatasetError, LineError};

/// What a judgement is about: one item, or two items compared side by side.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Subject {
    /// A single item, by its `id`.
    Item(String),
    /// Two items shown side by side, by their `id`s as shown (left, right).
    Pair(String, String),
}

impl fmt::Display for Subject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Subject::Item(id) => f.write_str(id),
            Subject::Pair(left, right) => write!(f, "{left} | {right}"),
        }
    }
}

/// Which of two plans an annotator preferred.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Preference {
    /// The plan shown on the left.
    Left,
    /// The plan shown on the right.
    Right,
    /// Neither is better.
    Neither,
}

impl Preference {
    /// The word written to the file and the CSV.
    pub fn as_str(self) -> &'static str {
        match self {
            Preference::Left => "left",
            Preference::Right => "right",
            Preference::Neither => "neither",
        }
    }
}

/// What an annotator can say about one step of a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
pub enum StepLabelKind {
    /// The step is right.
    #[serde(rename = "ok")]
    Ok,
    /// The step acts on the wrong object.
    #[serde(rename = "wrong object")]
    WrongObject,
    /// The step does the wrong thing.
    #[serde(rename = "wrong action")]
    WrongAction,
    /// The step comes at the wrong point.
    #[serde(rename = "wrong order")]
    WrongOrder,
    /// A step is missing before this one.
    #[serde(rename = "missing step before")]
    MissingStepBefore,
    /// The step is not needed.
    #[serde(rename = "unnecessary")]
    Unnecessary,
    /// The step is dangerous.
    #[serde(rename = "unsafe")]
    Unsafe,
}

impl StepLabelKind {
    /// Every label, in the order the screen offers them.
    pub const ALL: [StepLabelKind; 7] = [
        StepLabelKind::Ok,
        StepLabelKind::WrongObject,
        StepLabelKind::WrongAction,
        StepLabelKind::WrongOrder,
        StepLabelKind::MissingStepBefore,
        StepLabelKind::Unnecessary,
        StepLabelKind::Unsafe,
    ];

    /// The label as written in the file and shown on screen.
    pub fn as_str(self) -> &'static str {
        match self {
            StepLabelKind::Ok => "ok",
            StepLabelKind::WrongObject => "wrong object",
            StepLabelKind::WrongAction => "wrong action",
            StepLabelKind::WrongOrder => "wrong order",
            StepLabelKind::MissingStepBefore => "missing step before",
            StepLabelKind::Unnecessary => "unnecessary",
            StepLabelKind::Unsafe => "unsafe",
        }
    }
}

/// A label on one step: `{step, label}`. In the annotations file (JSON)
/// `step` is the 0-based index of the step in the item's `pred`, as
/// `corrupt`'s `edits` count; the screen and the CSV export number steps
/// from 1, as a person reads them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
pub struct StepLabel {
    /// The 0-based index of the step in the plan.
    pub step: usize,
    /// What the annotator said about it.
    pub label: StepLabelKind,
}

/// The content of one judgement, as the annotator left it.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// The rating 1–5 of a single item; `None` leaves the item unrated.
    pub rating: Option<u8>,
    /// The preference of a pairwise judgement.
    pub preference: Option<Preference>,
    /// Labels on single steps.
    pub step_labels: Vec<StepLabel>,
    /// A free note.
    pub note: String,
    /// Seconds spent on the item.
    pub seconds: u64,
    /// A short hash of the guidelines the annotator saw ([`guidelines_hash`]).
    pub guidelines: String,
}

/// One line of an annotations file: a judgement made, or one withdrawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Judgement {
    /// The item or pair judged.
    pub subject: Subject,
    /// Who judged it.
    pub annotator: String,
    /// When, in Unix seconds (0 when a line from another tool left it out).
    pub at: u64,
    /// The judgement, or `None` for a withdrawal (`withdrawn: true`).
    pub verdict: Option<Verdict>,
}

/// The line as it is written: every field optional, checked by
/// [`Judgement::try_from`].
#[derive(Debug, Default, Deserialize, Serialize)]
struct Line {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    item: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pair: Option<[String; 2]>,
    annotator: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    withdrawn: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rating: Option<serde_json::Number>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    preference: Option<Preference>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    step_labels: Option<Vec<StepLabel>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    note: Option<String>,
    /// A line from another tool may leave the time out: 0, unknown.
    #[serde(default)]
    at: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    seconds: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    guidelines: Option<String>,
}

/// Why a line of an annotations file is not a judgement.
#[derive(Debug, thiserror::Error)]
pub enum JudgementError {
    /// Not JSON of a judgement's shape.
    #[error("not a judgement: {0}")]
    Json(#[from] serde_json::Error),
    /// Both subjects given.
    #[error("has both `item` and `pair`; keep one")]
    TwoSubjects,
    /// No subject given.
    #[error("names no `item` or `pair`")]
    NoSubject,
    /// A preference judges a pair.
    #[error("a `preference` needs a `pair`, not an `item`")]
    PreferenceOfItem,
    /// A rating judges one item.
    #[error("a `rating` needs an `item`, not a `pair`")]
    RatingOfPair,
    /// A rating outside the scale.
    #[error("rating {0} is not a whole number from 1 to 5")]
    Rating(serde_json::Number),
}

impl TryFrom<Line> for Judgement {
    type Error = JudgementError;

    fn try_from(line: Line) -> Result<Self, JudgementError> {
        let subject = match (line.item, line.pair) {
            (Some(item), None) => Subject::Item(item),
            (None, Some([left, right])) => Subject::Pair(left, right),
            (Some(_), Some(_)) => return Err(JudgementError::TwoSubjects),
            (None, None) => return Err(JudgementError::NoSubject),
        };
        let verdict = if line.withdrawn == Some(true) {
            None
        } else {
            let rating = line.rating.map(|n| rating_of(&n)).transpose()?;
            match (&subject, rating, line.preference) {
                (Subject::Item(_), _, Some(_)) => return Err(JudgementError::PreferenceOfItem),
                (Subject::Pair(..), Some(_), _) => return Err(JudgementError::RatingOfPair),
                _ => {}
            }
            Some(Verdict {
                rating,
                preference: line.preference,
                step_labels: line.step_labels.unwrap_or_default(),
                note: line.note.unwrap_or_default(),
                seconds: line.seconds.unwrap_or(0),
                guidelines: line.guidelines.unwrap_or_default(),
            })
        };
        Ok(Judgement {
            subject,
            annotator: line.annotator,
            at: line.at,
            verdict,
        })
    }
}

/// A rating must be a whole number from 1 to 5.
fn rating_of(n: &serde_json::Number) -> Result<u8, JudgementError> {
    n.as_u64()
        .filter(|r| (1..=5).contains(r))
        .and_then(|r| u8::try_from(r).ok())
        .ok_or_else(|| JudgementError::Rating(n.clone()))
}

impl From<&Judgement> for Line {
    fn from(j: &Judgement) -> Self {
        let (item, pair) = match &j.subject {
            Subject::Item(id) => (Some(id.clone()), None),
            Subject::Pair(l, r) => (None, Some([l.clone(), r.clone()])),
        };
        let mut line = Line {
            item,
            pair,
            annotator: j.annotator.clone(),
            at: j.at,
            ..Line::default()
        };
        match &j.verdict {
            None => line.withdrawn = Some(true),
            Some(v) => {
                line.rating = v.rating.map(serde_json::Number::from);
                line.preference = v.preference;
                line.step_labels = Some(v.step_labels.clone());
                line.note = Some(v.note.clone());
                line.seconds = Some(v.seconds);
                line.guidelines = Some(v.guidelines.clone());
            }
        }
        line
    }
}

impl Judgement {
    /// The judgement as one JSON line, without the newline.
    pub fn to_line(&self) -> String {
        // A struct of strings, numbers and lists always serialises.
        serde_json::to_string(&Line::from(self)).unwrap_or_default()
    }

    /// Reads one line of an annotations file.
    pub fn from_line(text: &str) -> Result<Judgement, JudgementError> {
        Judgement::try_from(serde_json::from_str::<Line>(text)?)
    }

    /// The key that a later line must share to supersede this one.
    pub fn key(&self) -> (&Subject, &str) {
        (&self.subject, &self.annotator)
    }
}

/// A short hash of a guidelines text, written with every judgement so that
/// judgements made under different guidelines can be told apart.
pub fn guidelines_hash(text: &str) -> String {
    use sha2::{Digest, Sha256};
    let digest = Sha256::digest(text.as_bytes());
    digest[..4].iter().map(|b| format!("{b:02x}")).collect()
}

/// An annotations file as read: the judgements in file order, and the lines
/// that could not be read.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Annotations {
    /// Every readable line, in file order, with its 1-based line number.
    pub lines: Vec<(usize, Judgement)>,
    /// The lines that could not be read, with file and line.
    pub errors: Vec<LineError>,
}

impl Annotations {
    /// Reads an annotations file. A missing or unreadable file is an error;
    /// a bad line is kept in [`Annotations::errors`] and the rest load.
    pub fn load(path: &Path) -> Result<Annotations, DatasetError> {
        let text = read_text(path)?;
        let mut out = Annotations::default();
        for (n, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            match Judgement::from_line(line) {
                Ok(j) => out.lines.push((n + 1, j)),
                Err(err) => out.errors.push(LineError {
                    path: path.to_path_buf(),
                    line: n + 1,
                    message: err.to_string(),
                    id: None,
                }),
            }
        }
        Ok(out)
    }

    /// Like [`Annotations::load`], but a file that does not exist yet is
    /// empty (the annotation screen starts a new file).
    pub fn load_or_empty(path: &Path) -> Result<Annotations, DatasetError> {
        if path.exists() {
            Annotations::load(path)
        } else {
            Ok(Annotations::default())
        }
    }

    /// The current judgements of these lines ([`Current::of`]).
    pub fn current(&self) -> Current {
        Current::of(self.lines.iter().map(|(_, j)| j))
    }
}

/// The current judgement of each (item or pair, annotator): the last line
/// for it, unless that line is a withdrawal.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Current {
    /// The current judgements in the order of their lines.
    judgements: Vec<Judgement>,
}

impl Current {
    /// Resolves judgements read in order (one file, or several files one
    /// after another): a later line supersedes an earlier one for the same
    /// key, and a withdrawal removes it.
    pub fn of<'a>(lines: impl IntoIterator<Item = &'a Judgement>) -> Current {
        let mut latest: HashMap<(&Subject, &str), (usize, &Judgement)> = HashMap::new();
        for (order, j) in lines.into_iter().enumerate() {
            latest.insert(j.key(), (order, j));
        }
        let mut kept: Vec<(usize, &Judgement)> = latest
            .into_values()
            .filter(|(_, j)| j.verdict.is_some())
            .collect();
        kept.sort_by_key(|(order, _)| *order);
        Current {
            judgements: kept.into_iter().map(|(_, j)| j.clone()).collect(),
        }
    }

    /// Every current judgement, in the order of its line.
    pub fn judgements(&self) -> &[Judgement] {
        &self.judgements
    }

    /// The current ratings: (item, annotator, rating), items without a
    /// rating left out.
    pub fn ratings(&self) -> impl Iterator<Item = (&str, &str, u8)> {
        self.judgements.iter().filter_map(|j| match &j.subject {
            Subject::Item(id) => {
                let rating = j.verdict.as_ref()?.rating?;
                Some((id.as_str(), j.annotator.as_str(), rating))
            }
            Subject::Pair(..) => None,
        })
    }

    /// The current preferences: (left, right, annotator, preference).
    pub fn preferences(&self) -> impl Iterator<Item = (&str, &str, &str, Preference)> {
        self.judgements.iter().filter_map(|j| match &j.subject {
            Subject::Pair(left, right) => {
                let preference = j.verdict.as_ref()?.preference?;
                Some((
                    left.as_str(),
                    right.as_str(),
                    j.annotator.as_str(),
                    preference,
                ))
            }
            Subject::Item(_) => None,
        })
    }

    /// The current judgements as CSV, one row each, with a header:
    /// `item,left,right,annotator,rating,preference,step_labels,note,at,seconds,guidelines`
    /// (`step_labels` as `STEP:LABEL` joined by `;`, steps numbered from 1
    /// as on screen). A cell that a spreadsheet would read as a formula is
    /// protected ([`csv_field`]).
    pub fn to_csv(&self) -> String {
        let mut out = String::from(
            "item,left,right,annotator,rating,preference,step_labels,note,at,seconds,guidelines\n",
        );
        for j in &self.judgements {
            let Some(v) = &j.verdict else { continue };
            let (item, left, right) = match &j.subject {
                Subject::Item(id) => (id.as_str(), "", ""),
                Subject::Pair(l, r) => ("", l.as_str(), r.as_str()),
            };
            let labels: Vec<String> = v
                .step_labels
                .iter()
                .map(|l| format!("{}:{}", l.step + 1, l.label.as_str()))
                .collect();
            let fields = [
                item.to_string(),
                left.to_string(),
                right.to_string(),
                j.annotator.clone(),
                v.rating.map(|r| r.to_string()).unwrap_or_default(),
                v.preference
                    .map(|p| p.as_str().to_string())
                    .unwrap_or_default(),
                labels.join(";"),
                v.note.clone(),
                j.at.to_string(),
                v.seconds.to_string(),
                v.guidelines.clone(),
            ];
            let row: Vec<String> = fields
                .iter()
                .map(|f| crate::sanitize::csv_text_field(f))
                .collect();
            out.push_str(&row.join(","));
            out.push('\n');
        }
        out
    }
}

/// Why a judgement could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {error}; the judgement was not saved, try again")]
pub struct WriteError {
    /// The annotations file.
    pub path: PathBuf,
    /// The underlying error.
    pub error: std::io::Error,
}

/// Appends judgements to an annotations file, each as one whole line.
///
/// Every line goes out in one `write` on a file opened for appending, under
/// an exclusive advisory lock, and is flushed to disk before
/// [`AnnotationWriter::append`] returns: two annotators appending to one file
/// never interleave partial lines, and a killed process loses at most the
/// judgement it was making.
#[derive(Debug)]
pub struct AnnotationWriter {
    path: PathBuf,
    file: File,
}

impl AnnotationWriter {
    /// Opens (creating if needed) the annotations file at `path`.
    pub fn open(path: &Path) -> Result<AnnotationWriter, WriteError> {
        let fail = |error| WriteError {
            path: path.to_path_buf(),
            error,
        };
        if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(fail)?;
        }
        let file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(path)
            .map_err(fail)?;
        Ok(AnnotationWriter {
            path: path.to_path_buf(),
            file,
        })
    }

    /// The file this writer appends to.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `judgement` as one line and flushes it to disk.
    pub fn append(&mut self, judgement: &Judgement) -> Result<(), WriteError> {
        self.append_text(&judgement.to_line())
    }

    /// Appends one line of JSON (without its newline) the same way: whole,
    /// locked and flushed (the skips file beside the annotations is
    /// written so too).
    pub fn append_text(&mut self, text: &str) -> Result<(), WriteError> {
        let mut line = text.to_string();
        line.push('\n');
        self.append_line(line).map_err(|error| WriteError {
            path: self.path.clone(),
            error,
        })
    }

    fn append_line(&mut self, mut line: String) -> std::io::Result<()> {
        lock(&self.file, true)?;
        let written = (|| {
            // A file left without a final newline (an editor, another tool)
            // must not glue its last line to ours.
            if !self.ends_with_newline()? {
                line.insert(0, '\n');
            }
            self.file.write_all(line.as_bytes())?;
            self.file.sync_data()
        })();
        let unlocked = lock(&self.file, false);
        written.and(unlocked)
    }

    fn ends_with_newline(&mut self) -> std::io::Result<bool> {
        let len = self.file.metadata()?.len();
        if len == 0 {
            return Ok(true);
        }
        self.file.seek(SeekFrom::Start(len - 1))?;
        let mut last = [0u8; 1];
        self.file.read_exact(&mut last)?;
        Ok(last[0] == b'\n')
    }
}

/// Takes (`true`) or releases (`false`) the exclusive advisory lock that
/// writers of one annotations file share.
fn lock(file: &File, take: bool) -> std::io::Result<()> {
    use rustix::fs::{flock, FlockOperation};
    let op = if take {
        FlockOperation::LockExclusive
    } else {
        FlockOperation::Unlock
    };
    flock(file, op).map_err(std::io::Error::from)
}

/// The annotations file that goes with an items file by default:
/// `items.jsonl` → `items.annotations.jsonl`, in the same folder.
pub fn default_annotations_path(items: &Path) -> PathBuf {
    let stem = items
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "items".into());
    items.with_file_name(format!("{stem}.annotations.jsonl"))
}

/// Writes the current judgements to the CSV file `csv` atomically (see
/// [`crate::fsutil::write_atomic`]), so that a reader never sees half a file.
pub fn export_csv(current: &Current, csv: &Path) -> Result<(), WriteError> {
    crate::fsutil::write_atomic(csv, current.to_csv().as_bytes()).map_err(|e| WriteError {
        path: e.path,
        error: e.error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn golden() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/golden/agree.dev.annotations.jsonl")
    }

    fn rated(item: &str, who: &str, rating: u8, at: u64) -> Judgement {
        Judgement {
            subject: Subject::Item(item.into()),
            annotator: who.into(),
            at,
            verdict: Some(Verdict {
                rating: Some(rating),
                preference: None,
                step_labels: vec![],
                note: String::new(),
                seconds: 3,
                guidelines: "abcd1234".into(),
            }),
        }
    }

    fn withdrawn(item: &str, who: &str, at: u64) -> Judgement {
        Judgement {
            subject: Subject::Item(item.into()),
            annotator: who.into(),
            at,
            verdict: None,
        }
    }

    #[test]
    fn the_golden_file_resolves_as_the_reference_does() {
        let ann = Annotations::load(&golden()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ann.errors, vec![]);
        assert_eq!(ann.lines.len(), 385);
        // The reference: later lines supersede; a withdrawal or a line
        // without a rating removes the rating.
        let mut expected: HashMap<(String, String), u8> = HashMap::new();
        for (_, j) in &ann.lines {
            let Subject::Item(id) = &j.subject else {
                panic!("pair")
            };
            let key = (id.clone(), j.annotator.clone());
            match j.verdict.as_ref().and_then(|v| v.rating) {
                Some(r) => expected.insert(key, r),
                None => expected.remove(&key),
            };
        }
        let current = ann.current();
        let got: HashMap<(String, String), u8> = current
            .ratings()
            .map(|(i, a, r)| ((i.to_string(), a.to_string()), r))
            .collect();
        assert_eq!(got, expected);
        let withdrawals = ann
            .lines
            .iter()
            .filter(|(_, j)| j.verdict.is_none())
            .count();
        assert_eq!(withdrawals, 16);
        // The line without a rating is current, yet rates nothing.
        let unrated: Vec<_> = current
            .judgements()
            .iter()
            .filter(|j| j.verdict.as_ref().is_some_and(|v| v.rating.is_none()))
            .collect();
        assert_eq!(unrated.len(), 1);
        assert_eq!(
            unrated[0].verdict.as_ref().map(|v| v.step_labels.clone()),
            Some(vec![StepLabel {
                step: 0,
                label: StepLabelKind::WrongObject
            }])
        );
        assert!(got.contains_key(&("no-such-item".to_string(), "ana".to_string())));
        // Every line is written back as it was read.
        let text = std::fs::read_to_string(golden()).unwrap_or_default();
        for ((_, j), line) in ann.lines.iter().zip(text.lines()) {
            let original: serde_json::Value = serde_json::from_str(line).unwrap_or_default();
            let again: serde_json::Value = serde_json::from_str(&j.to_line()).unwrap_or_default();
            assert_eq!(again, original);
        }
    }

    #[test]
    fn later_lines_supersede_and_withdrawals_withdraw() {
        let lines = [
            rated("a", "ana", 2, 1),
            rated("a", "bo", 5, 2),
            rated("a", "ana", 4, 3),
            rated("b", "ana", 1, 4),
            withdrawn("b", "ana", 5),
            withdrawn("c", "ana", 6),
            rated("d", "ana", 3, 7),
            withdrawn("d", "ana", 8),
            rated("d", "ana", 1, 9),
        ];
        let current = Current::of(&lines);
        let ratings: Vec<_> = current.ratings().collect();
        assert_eq!(ratings, [("a", "bo", 5), ("a", "ana", 4), ("d", "ana", 1)]);
    }

    #[test]
    fn bad_lines_are_named_with_file_and_line_and_the_rest_load() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("a.annotations.jsonl");
        let text = [
            rated("a", "ana", 2, 1).to_line(),
            "{half a line".into(),
            r#"{"item": "b", "annotator": "ana", "rating": 7, "at": 2}"#.into(),
            r#"{"item": "b", "annotator": "ana", "rating": 2.5, "at": 2}"#.into(),
            r#"{"item": "b", "annotator": "ana", "preference": "left", "at": 2}"#.into(),
            r#"{"annotator": "ana", "rating": 2, "at": 2}"#.into(),
            String::new(),
            r#"{"pair": ["x", "y"], "annotator": "ana", "preference": "neither", "at": 3}"#.into(),
        ]
        .join("\n");
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        let ann = Annotations::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let bad: Vec<usize> = ann.errors.iter().map(|e| e.line).collect();
        assert_eq!(bad, [2, 3, 4, 5, 6]);
        assert!(ann.errors[1]
            .to_string()
            .starts_with(&format!("{}:3: rating 7", path.display())));
        assert_eq!(ann.lines.len(), 2);
        let current = ann.current();
        let prefs: Vec<_> = current.preferences().collect();
        assert_eq!(prefs, [("x", "y", "ana", Preference::Neither)]);
    }

    #[test]
    fn appending_after_a_line_without_newline_starts_a_new_line() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("a.jsonl");
        std::fs::write(&path, rated("a", "ana", 2, 1).to_line()).unwrap_or_else(|e| panic!("{e}"));
        let mut w = AnnotationWriter::open(&path).unwrap_or_else(|e| panic!("{e}"));
        w.append(&rated("b", "ana", 3, 2))
            .unwrap_or_else(|e| panic!("{e}"));
        let ann = Annotations::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ann.errors, vec![]);
        assert_eq!(ann.lines.len(), 2);
    }

    #[test]
    fn two_writers_hammering_one_file_never_interleave_lines() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("shared.annotations.jsonl");
        // Long notes make each line many times larger than a pipe buffer's
        // atomic size, so interleaving would show.
        let note = "n".repeat(20_000);
        let threads: Vec<_> = ["ana", "bo"]
            .into_iter()
            .map(|who| {
                let path = path.clone();
                let note = note.clone();
                std::thread::spawn(move || {
                    let mut w = AnnotationWriter::open(&path).unwrap_or_else(|e| panic!("{e}"));
                    for i in 0..200u64 {
                        let mut j = rated(&format!("item-{i}"), who, 1 + (i % 5) as u8, i);
                        if let Some(v) = j.verdict.as_mut() {
                            v.note = note.clone();
                        }
                        w.append(&j).unwrap_or_else(|e| panic!("{e}"));
                    }
                })
            })
            .collect();
        for t in threads {
            t.join().unwrap_or_else(|_| panic!("writer panicked"));
        }
        let ann = Annotations::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ann.errors, vec![]);
        assert_eq!(ann.lines.len(), 400);
        assert_eq!(ann.current().ratings().count(), 400);
    }

    #[test]
    fn export_writes_current_judgements_only_with_quoted_fields() {
        let mut noted = rated("b", "ana", 3, 4);
        if let Some(v) = noted.verdict.as_mut() {
            v.note = "too long, \"really\"".into();
            v.step_labels = vec![
                StepLabel {
                    step: 1,
                    label: StepLabelKind::Unsafe,
                },
                StepLabel {
                    step: 2,
                    label: StepLabelKind::MissingStepBefore,
                },
            ];
        }
        let lines = [rated("a", "ana", 2, 1), rated("a", "ana", 5, 2), noted];
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let csv = dir.path().join("out.csv");
        export_csv(&Current::of(&lines), &csv).unwrap_or_else(|e| panic!("{e}"));
        let text = std::fs::read_to_string(&csv).unwrap_or_default();
        assert_eq!(
            text,
            "item,left,right,annotator,rating,preference,step_labels,note,at,seconds,guidelines\n\
             a,,,ana,5,,,,2,3,abcd1234\n\
             b,,,ana,3,,2:unsafe;3:missing step before,\"too long, \"\"really\"\"\",4,3,abcd1234\n"
        );
    }

    #[test]
    fn export_protects_cells_a_spreadsheet_would_run_as_formulas() {
        let lines: Vec<Judgement> = [
            "=HYPERLINK(\"http://x\")",
            "+1",
            "-2",
            "@SUM(A1)",
            "\tx",
            "\rx",
            "fine = yes",
        ]
        .iter()
        .enumerate()
        .map(|(n, note)| {
            let mut j = rated(&format!("i{n}"), "ana", 3, 1);
            if let Some(v) = j.verdict.as_mut() {
                v.note = (*note).into();
            }
            j
        })
        .collect();
        let csv = Current::of(&lines).to_csv();
        assert!(csv.contains(",\"'=HYPERLINK(\"\"http://x\"\")\","), "{csv}");
        assert!(
            csv.contains(",'+1,") && csv.contains(",'-2,") && csv.contains(",'@SUM(A1),"),
            "{csv}"
        );
        assert!(
            csv.contains(",'\tx,") && csv.contains(",\"'\rx\","),
            "{csv}"
        );
        assert!(csv.contains(",fine = yes,"), "{csv}");
    }

    #[test]
    fn a_line_without_at_is_read() {
        let j = Judgement::from_line(r#"{"item": "a", "annotator": "ana", "rating": 4}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(j.at, 0);
        assert_eq!(j.verdict.and_then(|v| v.rating), Some(4));
    }

    #[test]
    fn the_default_annotations_file_sits_beside_the_items() {
        assert_eq!(
            default_annotations_path(Path::new("/d/items.jsonl")),
            Path::new("/d/items.annotations.jsonl")
        );
        assert_eq!(guidelines_hash("").len(), 8);
        assert_ne!(guidelines_hash("a"), guidelines_hash("b"));
    }
}
