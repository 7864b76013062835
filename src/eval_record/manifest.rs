//! `OUT/manifest.json`: what one `eval` run covered and how it scored, so
//! that `merge` knows what the whole run holds and refuses shards (and
//! `eval` refuses a resume) that were not scored alike.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{result_file, write_file, EvalRecordError, TaskResult};
use crate::agents::cost::PlanCost;
use crate::agents::prompts::PromptSet;
use crate::agents::Approach;
use crate::metrics::pg2s::Pg2sSettings;
use crate::shard::Shard;

/// The name of the manifest in an eval output folder.
pub const MANIFEST: &str = "manifest.json";

/// What one `eval` run covered: enough for `merge` to know the whole.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Every task id of the dataset, in its order (the rows of Table 3).
    pub dataset_tasks: Vec<String>,
    /// The approaches, in the order of the table's columns.
    pub approaches: Vec<Approach>,
    /// The shard this run evaluated (1/1 for a whole run).
    pub shard: Shard,
    /// The result files written under `tasks/`, one per task and approach scored.
    pub results: Vec<String>,
    /// `ID APPROACH` of every task that failed in this run.
    pub failed: Vec<String>,
    /// How the results were scored: shards join only when this agrees.
    #[serde(default)]
    pub provenance: Provenance,
    /// What the plans of the results cost (for a merge, the shards' sum).
    #[serde(default)]
    pub cost: CostSum,
}

/// Everything that decides a result's scores besides the plan itself:
/// two results (or shards, or a resumed run) are comparable only when all
/// of it agrees.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The mapvlm version that scored.
    pub mapvlm_version: String,
    /// The SHA-256 of the dataset's tasks file, in hex.
    pub dataset_hash: String,
    /// The metrics computed: `kas`, and `pg2s` when PG2S was scored.
    pub metrics: Vec<String>,
    /// PG2S's thresholds and weight (none when PG2S was not scored).
    pub pg2s_settings: Option<Pg2sSettings>,
    /// The sentence encoder's verification stamp (each key file and its SHA-256).
    pub encoder: Option<String>,
    /// The word vectors' stamp (the pack's, or the file given and its SHA-256).
    pub word_vectors: Option<String>,
    /// The prompt templates of the approaches, by name: which version ran
    /// (`--prompts DIR`, the user folder or the shipped ones).
    pub prompts: BTreeMap<String, PromptVersion>,
}

/// Which version of a prompt template a run used.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PromptVersion {
    /// The template's content hash ([`crate::agents::prompts::Template::hash`]).
    pub hash: String,
    /// Where it was read from: a file, or `built-in`.
    pub source: String,
}

/// The cost of a run's plans, added up from their results.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CostSum {
    /// Plans made by a model (with a cost record).
    pub plans: u64,
    /// Tokens read by every agent.
    pub input_tokens: u64,
    /// Tokens written by every agent.
    pub output_tokens: u64,
    /// US dollars (`None` when some answer had no price).
    pub usd: Option<f64>,
}

/// Two eval folders (or a folder and the run about to resume into it) that
/// were not scored alike: which field differs, in which folders, how.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{} and {} differ in `{field}` ({} vs {}); {advice}", sides.first, sides.second, sides.first_value, sides.second_value)]
pub struct Mismatch {
    /// The field's name, as in the manifest.
    pub field: &'static str,
    /// The two folders and their values.
    pub sides: Box<Sides>,
    /// What to do about it.
    pub advice: &'static str,
}

/// The two sides of a [`Mismatch`].
#[derive(Debug, Clone, PartialEq)]
pub struct Sides {
    /// The first folder (or run).
    pub first: String,
    /// Its value, shortened.
    pub first_value: String,
    /// The second folder (or run).
    pub second: String,
    /// Its value, shortened.
    pub second_value: String,
}

/// The version of every template `approaches` use in `set`.
pub fn prompt_versions(
    set: &PromptSet,
    approaches: &[Approach],
) -> BTreeMap<String, PromptVersion> {
    approaches
        .iter()
        .flat_map(|&approach| {
            approach
                .roles()
                .iter()
                .map(move |&role| set.get(approach, role))
        })
        .flatten()
        .map(|t| {
            let version = PromptVersion {
                hash: t.hash.clone(),
                source: t.source.clone(),
            };
            (t.name.clone(), version)
        })
        .collect()
}

/// The longest value a [`Mismatch`] shows.
const SHOWN: usize = 80;

/// `value` as JSON, whole (for comparing).
fn shown(value: &impl Serialize) -> String {
    serde_json::to_string(value).unwrap_or_default()
}

/// `text` shortened to [`SHOWN`] characters, for a message.
fn short(text: String) -> String {
    if text.chars().count() > SHOWN {
        let head: String = text.chars().take(SHOWN).collect();
        format!("{head}…")
    } else {
        text
    }
}

/// The fields in which two things differ: name, and both values as shown.
#[derive(Default)]
struct Differences(Vec<(&'static str, String, String)>);

impl Differences {
    /// Notes `field` when `a` and `b` differ (compared whole as JSON, shown
    /// shortened).
    fn compare<T: Serialize>(&mut self, field: &'static str, a: &T, b: &T) {
        let (a, b) = (shown(a), shown(b));
        if a != b {
            self.0.push((field, short(a), short(b)));
        }
    }
}

impl Provenance {
    /// The name and the two values (as shown) of every field in which
    /// `self` and `other` differ, in the order of the fields. Prompts are
    /// compared by content hash: the same template read from another path
    /// is the same prompt.
    pub fn differences(&self, other: &Provenance) -> Vec<(&'static str, String, String)> {
        let hashes = |p: &Provenance| -> BTreeMap<String, String> {
            p.prompts
                .iter()
                .map(|(name, v)| (name.clone(), v.hash.clone()))
                .collect()
        };
        let mut found = Differences::default();
        found.compare(
            "mapvlm_version",
            &self.mapvlm_version,
            &other.mapvlm_version,
        );
        found.compare("dataset_hash", &self.dataset_hash, &other.dataset_hash);
        found.compare("metrics", &self.metrics, &other.metrics);
        found.compare("pg2s_settings", &self.pg2s_settings, &other.pg2s_settings);
        found.compare("encoder", &self.encoder, &other.encoder);
        found.compare("word_vectors", &self.word_vectors, &other.word_vectors);
        found.compare("prompts", &hashes(self), &hashes(other));
        found.0
    }
}

impl CostSum {
    /// The sum of the costs of `results` (those a model made).
    pub fn of(results: &[TaskResult]) -> CostSum {
        let mut sum = CostSum {
            usd: Some(0.0),
            ..CostSum::default()
        };
        for cost in results.iter().filter_map(|r| r.cost.as_ref()) {
            sum.add_plan(cost);
        }
        if sum.plans == 0 {
            sum.usd = None;
        }
        sum
    }

    /// Adds one plan's cost.
    fn add_plan(&mut self, cost: &PlanCost) {
        self.plans += 1;
        for agent in &cost.agents {
            self.input_tokens += agent.usage.input_tokens;
            self.output_tokens += agent.usage.output_tokens;
        }
        self.usd = self.usd.zip(cost.usd).map(|(a, b)| a + b);
    }

    /// The sum of `self` and `other` (a merge adds its shards' costs).
    pub fn plus(&self, other: &CostSum) -> CostSum {
        let usd = match (self.plans, other.plans) {
            (0, _) => other.usd,
            (_, 0) => self.usd,
            _ => self.usd.zip(other.usd).map(|(a, b)| a + b),
        };
        CostSum {
            plans: self.plans + other.plans,
            input_tokens: self.input_tokens + other.input_tokens,
            output_tokens: self.output_tokens + other.output_tokens,
            usd,
        }
    }
}

impl Manifest {
    /// The manifest of a run of `shard` over `dataset_tasks` that scored
    /// `results` as `provenance` says.
    pub fn new(
        dataset_tasks: Vec<String>,
        approaches: Vec<Approach>,
        shard: Shard,
        results: &[TaskResult],
        failed: Vec<String>,
        provenance: Provenance,
    ) -> Self {
        Manifest {
            dataset_tasks,
            approaches,
            shard,
            results: results
                .iter()
                .map(|r| result_file(&r.id, r.approach, r.sample))
                .collect(),
            failed,
            provenance,
            cost: CostSum::of(results),
        }
    }

    /// Writes the manifest as `OUT/manifest.json`, atomically.
    pub fn write(&self, out: &Path) -> Result<(), EvalRecordError> {
        let text = serde_json::to_string_pretty(self).map_err(|err| EvalRecordError::Io {
            path: out.join(MANIFEST),
            message: err.to_string(),
        })?;
        write_file(&out.join(MANIFEST), text.as_bytes())
    }

    /// Reads `DIR/manifest.json`; `Ok(None)` when there is none.
    pub fn read_if_any(dir: &Path) -> Result<Option<Self>, EvalRecordError> {
        let path = dir.join(MANIFEST);
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(err) if err.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(err) => {
                return Err(EvalRecordError::Io {
                    path,
                    message: err.to_string(),
                })
            }
        };
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|err| EvalRecordError::Io {
                path,
                message: format!(
                    "not an eval manifest ({err}); give the --out folder of a `mapvlm eval` run"
                ),
            })
    }

    /// Reads `DIR/manifest.json`, which must exist.
    pub fn read(dir: &Path) -> Result<Self, EvalRecordError> {
        Self::read_if_any(dir)?.ok_or_else(|| EvalRecordError::Io {
            path: dir.to_path_buf(),
            message: format!("no {MANIFEST}; give the --out folder of a `mapvlm eval` run"),
        })
    }

    /// Checks that `self` (of `name`) and `other` (of `other_name`) are
    /// parts of one run: the same dataset tasks, approaches and shard count,
    /// and the same [`Provenance`]; the first field that differs is named
    /// with both folders, and `advice` says what to do.
    pub fn check_same_run(
        &self,
        name: &str,
        other: &Manifest,
        other_name: &str,
        advice: &'static str,
    ) -> Result<(), Mismatch> {
        let mut found = Differences::default();
        found.compare("dataset_tasks", &self.dataset_tasks, &other.dataset_tasks);
        found.compare("approaches", &self.approaches, &other.approaches);
        found.compare("shard.count", &self.shard.count, &other.shard.count);
        let mut found = found.0;
        found.extend(self.provenance.differences(&other.provenance));
        first_mismatch(found, name, other_name, advice)
    }

    /// Checks that a run about to write `current` into the folder `name`
    /// that holds `self` resumes the same run: [`Manifest::check_same_run`],
    /// and the same shard.
    pub fn check_resume(&self, name: &str, current: &Manifest) -> Result<(), Mismatch> {
        let advice = "give another --out, or the options of the run that wrote it";
        self.check_same_run(name, current, "this run", advice)?;
        let mut found = Differences::default();
        let shards = (self.shard.to_string(), current.shard.to_string());
        found.compare("shard", &shards.0, &shards.1);
        first_mismatch(found.0, name, "this run", advice)
    }
}

impl Provenance {
    /// Checks that `self` (of `name`) and `other` (of `other_name`) agree,
    /// naming the first field that does not (see [`Provenance::differences`]).
    pub fn check_same(
        &self,
        name: &str,
        other: &Provenance,
        other_name: &str,
        advice: &'static str,
    ) -> Result<(), Mismatch> {
        first_mismatch(self.differences(other), name, other_name, advice)
    }
}

/// The first of `found` (field, first value, second value) as a
/// [`Mismatch`] of `first` and `second`, if any.
fn first_mismatch(
    found: Vec<(&'static str, String, String)>,
    first: &str,
    second: &str,
    advice: &'static str,
) -> Result<(), Mismatch> {
    match found.into_iter().next() {
        None => Ok(()),
        Some((field, first_value, second_value)) => Err(Mismatch {
            field,
            sides: Box::new(Sides {
                first: first.to_string(),
                first_value,
                second: second.to_string(),
                second_value,
            }),
            advice,
        }),
    }
}

impl fmt::Display for CostSum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} plans, {} tokens in, {} out",
            self.plans, self.input_tokens, self.output_tokens
        )?;
        match self.usd {
            Some(usd) => write!(f, ", ${usd:.4}"),
            None if self.plans > 0 => write!(f, ", cost unknown"),
            None => Ok(()),
        }
    }
}
