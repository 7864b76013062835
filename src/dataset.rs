//! Datasets (`dataset.md`): a folder with `tasks.jsonl`, one task a line, and
//! the pairs files used for batch scoring.

pub mod lines;

use std::collections::BTreeMap;
use std::fmt;
use std::io::BufRead;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The four approaches whose published plans a task may carry, in the order
/// of the paper's Table 3.
pub const APPROACHES: [&str; 4] = [
    "single_agent_table",
    "multi_agent_table",
    "single_agent_image",
    "multi_agent_image",
];

/// One task of a dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    /// Unique task id, e.g. `trial_T20190907_114323_767231-1`.
    pub id: String,
    /// The ALFRED trial (scene) the task belongs to.
    pub trial: Option<String>,
    /// The goal in natural language.
    pub task: String,
    /// The scene image, resolved against the dataset folder.
    pub image: Option<PathBuf>,
    /// The G-PlanET table of the scene, resolved against the dataset folder.
    pub table: Option<PathBuf>,
    /// The reference plan.
    pub ground_truth: Vec<String>,
    /// Plans produced earlier, by approach (see [`APPROACHES`]).
    pub plans: BTreeMap<String, Vec<String>>,
    /// Fields this version does not know, kept as they were.
    pub extra: Map<String, Value>,
}

/// A line of `tasks.jsonl` or of a pairs file that could not be used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineError {
    /// The file the line is in.
    pub path: PathBuf,
    /// The 1-based line number.
    pub line: usize,
    /// What was wrong with it.
    pub message: String,
    /// The `id` the line gives, when one can be read from it: a shard
    /// fails only for a bad line of its own tasks.
    pub id: Option<String>,
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.path.display(), self.line, self.message)
    }
}

/// Why a dataset or pairs file could not be read at all.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The file is missing or unreadable.
    #[error("cannot read {path}: {error}")]
    Read {
        /// The file that failed.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// The file is longer than the limit for its kind.
    #[error("{path}: {message}")]
    TooLong {
        /// The file that failed.
        path: PathBuf,
        /// The limit it passed, in words.
        message: String,
    },
    /// The file is not UTF-8 text.
    #[error("{path}: not UTF-8 text (byte {offset}); save it as UTF-8")]
    NotUtf8 {
        /// The file that failed.
        path: PathBuf,
        /// Offset of the first invalid byte.
        offset: usize,
    },
}

/// A loaded dataset: its folder and its tasks.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// The tasks, in file order.
    pub tasks: Vec<Task>,
}

/// Reads a whole text file as UTF-8, with errors naming the file; a UTF-8
/// byte-order mark at its start is dropped (it is not part of the text).
/// At most [`crate::limits::MAX_TEXT_FILE_BYTES`] are read.
pub fn read_text(path: &Path) -> Result<String, DatasetError> {
    read_text_within(path, crate::limits::MAX_TEXT_FILE_BYTES, "a text file")
}

/// [`read_text`] of a file of kind `what` (`a step file`) held to `limit`
/// bytes: a longer file (or a device) is refused naming the limit.
pub fn read_text_within(
    path: &Path,
    limit: u64,
    what: &'static str,
) -> Result<String, DatasetError> {
    let bytes = crate::limits::read_file(path, limit, what).map_err(|error| match error {
        crate::limits::ReadError::Io(error) => DatasetError::Read {
            path: path.to_path_buf(),
            error,
        },
        too_long => DatasetError::TooLong {
            path: path.to_path_buf(),
            message: too_long.to_string(),
        },
    })?;
    let mut text = String::from_utf8(bytes).map_err(|e| DatasetError::NotUtf8 {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })?;
    if text.starts_with(lines::BOM) {
        text.drain(..lines::BOM.len());
    }
    Ok(text)
}

#[derive(Deserialize)]
struct RawTask {
    id: String,
    task: String,
    ground_truth: Vec<String>,
    #[serde(default)]
    trial: Option<String>,
    #[serde(default)]
    image: Option<String>,
    #[serde(default)]
    table: Option<String>,
    #[serde(flatten)]
    rest: Map<String, Value>,
}

/// The longest task or item id, in bytes: ids name result files
/// (`ID.APPROACH.json`), and a file name has at most 255 bytes.
pub const MAX_ID_BYTES: usize = 200;

/// Refuses an id that cannot be a task's or an item's (empty, blank or
/// longer than [`MAX_ID_BYTES`]), checked before any request is made for it.
pub fn check_id(id: &str) -> Result<(), IdError> {
    if id.trim().is_empty() {
        return Err(IdError::Empty);
    }
    if id.len() > MAX_ID_BYTES {
        return Err(IdError::TooLong(id.len()));
    }
    Ok(())
}

/// Why an id is refused: ids name result files and join results to tasks,
/// so each must be a usable file name and unique in its file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum IdError {
    /// Empty or blank.
    #[error("the id is empty: give every task an id of its own")]
    Empty,
    /// Longer than [`MAX_ID_BYTES`] (the length in bytes).
    #[error("the id is {0} bytes long, past the limit of {MAX_ID_BYTES} bytes: give a shorter id")]
    TooLong(usize),
    /// Already the id of an earlier line.
    #[error("the id `{}` is also the id of line {first}: ids must be unique", crate::sanitize::for_terminal(.id))]
    Repeated {
        /// The id.
        id: String,
        /// The line that has it first.
        first: usize,
    },
}

/// The one rule every reader of tasks and items holds ids to: each valid
/// ([`check_id`]) and unique in its file, a repeat refused naming both lines.
#[derive(Debug, Default)]
pub struct IdRule {
    seen: std::collections::HashMap<String, usize>,
}

impl IdRule {
    /// Takes the id on line `line`, or says why it cannot be used.
    pub fn admit(&mut self, id: &str, line: usize) -> Result<(), IdError> {
        check_id(id)?;
        if let Some(&first) = self.seen.get(id) {
            return Err(IdError::Repeated {
                id: id.to_string(),
                first,
            });
        }
        self.seen.insert(id.to_string(), line);
        Ok(())
    }
}

/// The file stem of id `id`: the id itself when it is made of letters,
/// digits, `-`, `_` and `.` only (and does not start with `.`); otherwise
/// those kept, the rest as `_`, and `~` with 8 hex digits of the id's
/// SHA-256, so that two ids never share a file (`task/1`, `task_1` and
/// `task 1` get three names) and none is hidden.
pub fn file_stem(id: &str) -> String {
    let safe = legacy_file_stem(id);
    if safe == id && !id.starts_with('.') {
        return safe;
    }
    // A leading `.` would hide the file.
    let shown = match safe.strip_prefix('.') {
        Some(rest) => format!("_{rest}"),
        None => safe,
    };
    let hash = crate::agents::sha256_hex(id.as_bytes());
    format!("{shown}~{}", &hash[..8])
}

/// The stem older versions gave id `id` (letters, digits, `-`, `_` and `.`
/// kept, the rest as `_`, no hash suffix), to find the results an existing
/// output folder holds under it.
pub fn legacy_file_stem(id: &str) -> String {
    id.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// `path`, as a task writes it, resolved against the dataset folder `root`
/// when it stays inside: relative, with no `..` left after normalising
/// (`images/../images/1.jpg` is fine, `../x.jpg` is not). Symlinks inside
/// the dataset are followed when the file is opened, since clusters link
/// `images/` to shared storage. With `allow_outside` any path is taken.
pub fn resolve_inside(
    root: &Path,
    path: &str,
    allow_outside: bool,
) -> Result<PathBuf, OutsidePath> {
    use std::path::Component;
    let written = Path::new(path);
    if allow_outside {
        return Ok(root.join(written));
    }
    let refuse = |why| OutsidePath {
        path: path.to_string(),
        why,
    };
    let mut inside = PathBuf::new();
    for part in written.components() {
        match part {
            Component::Normal(name) => inside.push(name),
            Component::CurDir => {}
            Component::ParentDir => {
                if !inside.pop() {
                    return Err(refuse("leads out of the dataset folder"));
                }
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err(refuse("is an absolute path"));
            }
        }
    }
    if inside.as_os_str().is_empty() {
        return Err(refuse("names no file"));
    }
    Ok(root.join(inside))
}

/// A path a task names that [`resolve_inside`] refuses: a task file from
/// elsewhere must not make the tool read (and send) files outside its folder.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{}` {why}: files a task names must be inside the dataset folder; give --allow-outside-paths to use it anyway", crate::sanitize::for_terminal(.path))]
pub struct OutsidePath {
    /// The path as the task writes it.
    pub path: String,
    /// What is wrong with it ("is an absolute path", …).
    pub why: &'static str,
}

impl Dataset {
    /// Loads `DIR/tasks.jsonl` (or the given `.jsonl` file, whose folder is
    /// then the dataset folder). Lines that cannot be used are returned with
    /// their line numbers; the others load. Ids are held to [`IdRule`];
    /// images and tables to [`resolve_inside`].
    pub fn load(path: &Path) -> Result<(Dataset, Vec<LineError>), DatasetError> {
        Self::load_with(path, false)
    }

    /// [`Self::load`], taking image and table paths outside the dataset
    /// folder when `allow_outside_paths` (`--allow-outside-paths`).
    pub fn load_with(
        path: &Path,
        allow_outside_paths: bool,
    ) -> Result<(Dataset, Vec<LineError>), DatasetError> {
        let file = Self::tasks_file(path);
        let root = if path.is_dir() {
            path.to_path_buf()
        } else {
            path.parent().map_or_else(PathBuf::new, Path::to_path_buf)
        };
        let source = std::fs::File::open(&file).map_err(|error| DatasetError::Read {
            path: file.clone(),
            error,
        })?;
        let reader = std::io::BufReader::with_capacity(1 << 16, source);
        let mut tasks = Vec::new();
        let mut errors = Vec::new();
        let mut ids = IdRule::default();
        for read in lines::BoundedLines::new(reader, crate::limits::MAX_TASK_LINE_BYTES) {
            let (n, line) = read.map_err(|error| DatasetError::Read {
                path: file.clone(),
                error,
            })?;
            let error = |message: String| LineError {
                path: file.clone(),
                line: n,
                message,
                id: None,
            };
            let line = match line {
                Ok(line) => line,
                Err(problem) => {
                    errors.push(error(problem.to_string()));
                    continue;
                }
            };
            if line.trim().is_empty() {
                continue;
            }
            let with_id = |message: String| LineError {
                id: serde_json::from_str::<serde_json::Value>(&line)
                    .ok()
                    .and_then(|value| value.get("id")?.as_str().map(str::to_string)),
                ..error(message)
            };
            match serde_json::from_str::<RawTask>(&line) {
                Ok(raw) => match Task::from_raw(raw, &root, allow_outside_paths).and_then(|task| {
                    ids.admit(&task.id, n)
                        .map(|()| task)
                        .map_err(|err| err.to_string())
                }) {
                    Ok(task) => tasks.push(task),
                    Err(message) => errors.push(with_id(message)),
                },
                Err(e) => errors.push(with_id(format!("not a task: {e}"))),
            }
        }
        Ok((Dataset { root, tasks }, errors))
    }

    /// The tasks file [`Dataset::load`] reads for `path` (a dataset folder's
    /// `tasks.jsonl`, or the file given): what a run's provenance hashes.
    pub fn tasks_file(path: &Path) -> PathBuf {
        if path.is_dir() {
            path.join("tasks.jsonl")
        } else {
            path.to_path_buf()
        }
    }

    /// The task with this id.
    pub fn task(&self, id: &str) -> Option<&Task> {
        self.tasks.iter().find(|t| t.id == id)
    }
}

impl Task {
    fn from_raw(raw: RawTask, root: &Path, allow_outside: bool) -> Result<Task, String> {
        let mut plans = BTreeMap::new();
        let mut extra = Map::new();
        for (key, value) in raw.rest {
            if APPROACHES.contains(&key.as_str()) {
                let steps: Vec<String> = serde_json::from_value(value)
                    .map_err(|e| format!("field `{key}` is not a list of steps: {e}"))?;
                plans.insert(key, steps);
            } else {
                extra.insert(key, value);
            }
        }
        Ok(Task {
            id: raw.id,
            trial: raw.trial,
            task: raw.task,
            image: raw
                .image
                .map(|p| resolve_inside(root, &p, allow_outside))
                .transpose()
                .map_err(|e| format!("image {e}"))?,
            table: raw
                .table
                .map(|p| resolve_inside(root, &p, allow_outside))
                .transpose()
                .map_err(|e| format!("table {e}"))?,
            ground_truth: raw.ground_truth,
            plans,
            extra,
        })
    }
}

/// One plan pair of a pairs file, which is also an item of `annotate.md`:
/// the optional fields say what an annotator is shown and, for a corrupted
/// plan, where it came from. Unknown fields are ignored, so every items file
/// can be scored as a pairs file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct Pair {
    /// The pair's id.
    pub id: String,
    /// Ground-truth steps.
    pub gt: Vec<String>,
    /// Predicted steps.
    pub pred: Vec<String>,
    /// The goal in words, shown to annotators.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task: Option<String>,
    /// The scene image as written: absolute, or relative to the items file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// The `id` of the item this one was derived from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// What was changed, for an item made by `mapvlm corrupt`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corruption: Option<Corruption>,
    /// An opaque name shared by a plan and every plan derived from it, in a
    /// blind copy (`corrupt --blind`) that has no `source`: `annotate` keeps
    /// the members of a group apart without learning which is the original.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<String>,
}

impl Pair {
    /// A plain pair: no task, image or provenance.
    pub fn new(id: impl Into<String>, gt: Vec<String>, pred: Vec<String>) -> Self {
        Pair {
            id: id.into(),
            gt,
            pred,
            task: None,
            image: None,
            source: None,
            corruption: None,
            group: None,
        }
    }

    /// The family of the item: its `group` (a blind copy), else its
    /// `source`, else its own id. Items of one family are one plan and its
    /// corruptions.
    pub fn family(&self) -> &str {
        self.group
            .as_deref()
            .or(self.source.as_deref())
            .unwrap_or(&self.id)
    }
}

/// The record of one corruption (`annotate.md` §1): enough to see exactly
/// what differs from the source item and to make it again.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct Corruption {
    /// The kind, as named on the command line (`object-swap`, `drop`, …).
    pub kind: String,
    /// The seed it was drawn with.
    pub seed: u64,
    /// One entry per changed step.
    pub edits: Vec<Edit>,
    /// For swaps, the word-vector cosine of the two words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub similarity: Option<f64>,
    /// For swaps, the word replaced and its replacement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub words: Option<SwappedWords>,
    /// For object and place swaps, whether the word replaced names a thing
    /// the task names (the swap then changes what the task is about).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub touches_task: Option<bool>,
    /// For `reorder`, whether the two steps were neighbours.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adjacent: Option<bool>,
    /// The version of the algorithm that made it (`corrupt::ALGORITHM`): the
    /// same seed gives the same corruption only under the same version.
    /// Absent in files written before versions were recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version: Option<u32>,
}

/// One changed step of a corruption.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
pub struct Edit {
    /// The 0-based index of the step in the source plan.
    pub step: usize,
    /// The step as it was (`None` where a step was added).
    pub from: Option<String>,
    /// The step as it is now (`None` where a step was removed).
    pub to: Option<String>,
}

/// The two words of a swap.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
pub struct SwappedWords {
    /// The word that was in the plan.
    pub from: String,
    /// The word put in its place.
    pub to: String,
}

/// The longest pairs-file line read, in bytes: a longer line is skipped
/// with its number (a pair that long is not a plan), so memory stays bounded.
pub const MAX_PAIR_LINE_BYTES: usize = 4 << 20;

/// The pairs of a pairs file (`{"id", "gt", "pred"}` per line), read one line
/// at a time so that memory stays bounded whatever the file's size. Each item
/// is a pair or the reason its line could not be read (with the line's
/// number), so the good ones can still be scored in order.
pub struct PairsReader {
    path: PathBuf,
    lines: lines::BoundedLines<Box<dyn BufRead + Send>>,
    failed: bool,
    ids: IdRule,
}

/// Opens a pairs file for reading; `-` is standard input.
pub fn open_pairs(path: &Path) -> Result<PairsReader, DatasetError> {
    let source: Box<dyn BufRead + Send> = if path == Path::new("-") {
        Box::new(std::io::BufReader::new(std::io::stdin()))
    } else {
        let file = std::fs::File::open(path).map_err(|error| DatasetError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        Box::new(std::io::BufReader::with_capacity(1 << 16, file))
    };
    let shown = if path == Path::new("-") {
        PathBuf::from("standard input")
    } else {
        path.to_path_buf()
    };
    Ok(PairsReader::new(source, shown))
}

impl PairsReader {
    /// The pairs of any reader (a file, standard input, bytes in memory),
    /// with errors naming `shown` as the file.
    pub fn new(source: Box<dyn BufRead + Send>, shown: PathBuf) -> Self {
        Self {
            path: shown,
            lines: lines::BoundedLines::new(source, MAX_PAIR_LINE_BYTES),
            failed: false,
            ids: IdRule::default(),
        }
    }
}

impl Iterator for PairsReader {
    type Item = Result<Pair, LineError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        loop {
            let error = |line: usize, message: String| LineError {
                path: self.path.clone(),
                line,
                message,
                id: None,
            };
            let (n, text) = match self.lines.next()? {
                Ok(line) => line,
                Err(err) => {
                    self.failed = true;
                    return Some(Err(error(0, format!("cannot read further: {err}"))));
                }
            };
            let text = match text {
                Ok(text) => text,
                Err(problem) => return Some(Err(error(n, problem.to_string()))),
            };
            if text.trim().is_empty() {
                continue;
            }
            let pair = serde_json::from_str::<Pair>(&text)
                .map_err(|e| error(n, format!("not a pair {{\"id\", \"gt\", \"pred\"}}: {e}")))
                .and_then(|pair| match self.ids.admit(&pair.id, n) {
                    Ok(()) => Ok(pair),
                    Err(why) => Err(error(n, why.to_string())),
                });
            return Some(pair);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_item_keeps_its_task_image_and_corruption_through_a_round_trip() {
        let line = r#"{"id": "t/a~drop", "gt": ["A."], "pred": ["B."], "task": "Do it.", "image": "images/1.jpg", "source": "t/a", "corruption": {"kind": "drop", "seed": 7, "edits": [{"step": 1, "from": "C.", "to": null}]}, "extra": 1}"#;
        let item: Pair = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(item.source.as_deref(), Some("t/a"));
        let corruption = item
            .corruption
            .as_ref()
            .unwrap_or_else(|| panic!("no corruption"));
        assert_eq!(corruption.edits[0].step, 1);
        assert_eq!(corruption.edits[0].to, None);
        let again: Pair = serde_json::from_str(&serde_json::to_string(&item).unwrap_or_default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(again, item);
        let plain =
            serde_json::to_string(&Pair::new("p", vec!["A.".into()], vec![])).unwrap_or_default();
        assert_eq!(plain, r#"{"id":"p","gt":["A."],"pred":[]}"#);
    }

    #[test]
    fn bad_lines_are_reported_and_good_ones_load() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let text = concat!(
            r#"{"id": "a", "task": "T", "ground_truth": ["Walk."], "image": "images/1.jpg", "note": 3, "single_agent_image": ["Go."]}"#,
            "\n",
            "{not json\n",
            r#"{"id": "b", "ground_truth": []}"#,
            "\n\n",
            r#"{"id": "c", "task": "U", "ground_truth": ["Stop."]}"#,
            "\n"
        );
        std::fs::write(dir.path().join("tasks.jsonl"), text).unwrap_or_else(|e| panic!("{e}"));
        let (ds, errors) = Dataset::load(dir.path()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ds.tasks.len(), 2);
        assert_eq!(errors.iter().map(|e| e.line).collect::<Vec<_>>(), [2, 3]);
        assert!(errors[1].message.contains("task"), "{}", errors[1]);
        let a = &ds.tasks[0];
        assert_eq!(a.image, Some(dir.path().join("images/1.jpg")));
        assert_eq!(a.plans["single_agent_image"], ["Go."]);
        assert_eq!(a.extra["note"], 3);
    }
}
