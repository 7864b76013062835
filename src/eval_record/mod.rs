//! What `mapvlm eval` writes and `mapvlm merge` reads: one [`TaskResult`]
//! a task, approach and sample under `OUT/tasks/`, the run's [`Manifest`]
//! (with the [`Provenance`] two shards must share to be joined) and the
//! paper's Table 3 ([`write_tables`]). A library module, so that the two
//! commands (and any program reading an eval folder) share one definition.

mod manifest;
mod tables;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::agents::cost::PlanCost;
use crate::agents::pipeline::{is_first_sample, PlanRecord};
use crate::agents::Approach;
use crate::fsutil::write_atomic;

pub use manifest::{
    prompt_versions, CostSum, Manifest, Mismatch, PromptVersion, Provenance, Sides, MANIFEST,
};
pub use tables::{tables, write_tables};

/// Why an eval folder could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum EvalRecordError {
    /// A file could not be read or written.
    #[error("{}: {message}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong, and what to do.
        message: String,
    },
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] crate::fsutil::FsError),
    /// Two runs that must agree do not (see [`Mismatch`]).
    #[error("{0}")]
    Mismatch(#[from] Mismatch),
}

/// One task through one approach: the plan, where it came from, its scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskResult {
    /// The task's id.
    pub id: String,
    /// The approach.
    pub approach: Approach,
    /// The task.
    pub task: String,
    /// `dataset` (published plan) or `model` (made now).
    pub source: String,
    /// The reference plan.
    pub ground_truth: Vec<String>,
    /// The plan's steps.
    pub steps: Vec<String>,
    /// KAS, when applicable.
    pub kas: Option<f64>,
    /// Why KAS is not applicable.
    pub kas_reason: Option<String>,
    /// Whether PG2S was computed.
    pub pg2s_scored: bool,
    /// S_plan.
    pub s_plan: Option<f64>,
    /// S_goal.
    pub s_goal: Option<f64>,
    /// PG2S.
    pub pg2s: Option<f64>,
    /// The whole run, when a model made the plan.
    pub record: Option<PlanRecord>,
    /// Tokens and cost of the run that made the plan, per agent.
    #[serde(default)]
    pub cost: Option<PlanCost>,
    /// Which sample of the plan this is (`--samples`; 0, and left out of
    /// the file, for the first).
    #[serde(default, skip_serializing_if = "is_first_sample")]
    pub sample: u32,
    /// How the scores were computed (metrics, models, dataset, prompts,
    /// version): a result is only ever joined with results of the same.
    #[serde(default)]
    pub provenance: Option<Provenance>,
}

/// The name of the file of sample `sample` of task `id` through `approach`
/// under `OUT/tasks`: `ID.APPROACH.json` for the first sample (as before
/// samples existed), `ID.APPROACH.sK.json` for sample index K > 0.
pub fn result_file(id: &str, approach: Approach, sample: u32) -> String {
    named_result_file(&crate::dataset::file_stem(id), approach, sample)
}

/// [`result_file`] with the file stem given: the name older versions gave a
/// task (its legacy stem) is found with it, so old output folders resume.
pub fn named_result_file(stem: &str, approach: Approach, sample: u32) -> String {
    if sample == 0 {
        format!("{stem}.{approach}.json")
    } else {
        format!("{stem}.{approach}.s{sample}.json")
    }
}

/// Writes `bytes` to `path` atomically (the one writer of eval folders).
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), EvalRecordError> {
    Ok(write_atomic(path, bytes)?)
}
