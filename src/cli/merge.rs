//! `mapvlm merge DIR... --out DIR`: the output folders of `eval --shard`
//! joined into the per-task files and tables one whole run writes.
//!
//! Every `eval` writes `OUT/manifest.json`: the dataset's task ids, the
//! approaches, its shard and the result files it wrote. From these a merge
//! knows what a whole run would hold, and refuses, naming the tasks, when a
//! shard is missing or a shard's results are incomplete.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use serde::{Deserialize, Serialize};

use super::eval::{result_file, write_tables, TaskResult};
use crate::agents::prompts::PromptSet;
use crate::agents::Approach;
use crate::fsutil::write_atomic;
use crate::shard::Shard;

/// The name of the manifest in an eval output folder.
const MANIFEST: &str = "manifest.json";

/// Options of `mapvlm merge`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The `--out` folders of the shards' `mapvlm eval` runs.
    #[arg(required = true, value_name = "DIR")]
    pub shards: Vec<PathBuf>,
    /// Where the joined per-task files and tables go.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

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
    /// The prompt templates of the approaches, by name: which version ran
    /// (`--prompts DIR`, the user folder or the shipped ones).
    #[serde(default)]
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

impl Manifest {
    /// The manifest of a run of `shard` over `dataset_tasks` that scored `results`.
    pub fn new(
        dataset_tasks: Vec<String>,
        approaches: Vec<Approach>,
        shard: Shard,
        results: &[TaskResult],
        failed: Vec<String>,
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
            prompts: BTreeMap::new(),
        }
    }

    /// The manifest with the prompt versions the run used.
    pub fn with_prompts(self, prompts: BTreeMap<String, PromptVersion>) -> Self {
        Manifest { prompts, ..self }
    }

    /// Writes the manifest as `OUT/manifest.json`, atomically.
    pub fn write(&self, out: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)?;
        write_atomic(&out.join(MANIFEST), text.as_bytes())?;
        Ok(())
    }

    /// Reads `DIR/manifest.json`.
    fn read(dir: &Path) -> anyhow::Result<Self> {
        let path = dir.join(MANIFEST);
        let text = std::fs::read_to_string(&path).with_context(|| {
            format!(
                "{}: no {MANIFEST}; give the --out folder of a `mapvlm eval` run",
                dir.display()
            )
        })?;
        serde_json::from_str(&text)
            .with_context(|| format!("{}: not an eval manifest", path.display()))
    }
}

/// Runs `mapvlm merge`.
pub fn run(args: &MergeArgs) -> anyhow::Result<ExitCode> {
    let shards = args
        .shards
        .iter()
        .map(|dir| Ok((dir.as_path(), Manifest::read(dir)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let (first_dir, first) = &shards[0];
    let mut by_index: BTreeMap<u64, &Path> = BTreeMap::new();
    for (dir, manifest) in &shards {
        if manifest.dataset_tasks != first.dataset_tasks
            || manifest.approaches != first.approaches
            || manifest.shard.count != first.shard.count
            || manifest.prompts != first.prompts
        {
            bail!(
                "{} and {} are not shards of one eval (other tasks, approaches, prompts or shard count)",
                first_dir.display(),
                dir.display()
            );
        }
        if let Some(other) = by_index.insert(manifest.shard.index, dir) {
            bail!(
                "shard {} is given twice: {} and {}",
                manifest.shard,
                other.display(),
                dir.display()
            );
        }
        if !manifest.failed.is_empty() {
            bail!(
                "{}: shard {} has failed tasks ({}); run its eval again first",
                dir.display(),
                manifest.shard,
                manifest.failed.join(", ")
            );
        }
    }
    let count = first.shard.count;
    let missing: Vec<&str> = first
        .dataset_tasks
        .iter()
        .filter(|id| !by_index.contains_key(&Shard::of(id, count)))
        .map(String::as_str)
        .collect();
    if !missing.is_empty() {
        let absent: Vec<String> = (1..=count)
            .filter(|i| !by_index.contains_key(i))
            .map(|i| format!("{i}/{count}"))
            .collect();
        bail!(
            "shard {} missing: no results for task {}; give its eval --out folder too",
            absent.join(", "),
            missing.join(", ")
        );
    }
    let mut results = Vec::new();
    for (dir, manifest) in &shards {
        for name in &manifest.results {
            let from = dir.join("tasks").join(name);
            let bytes = std::fs::read(&from).with_context(|| {
                format!("{}: missing; run that shard's eval again", from.display())
            })?;
            let result: TaskResult = serde_json::from_slice(&bytes)
                .with_context(|| format!("{}: not a task result", from.display()))?;
            write_atomic(&args.out.join("tasks").join(name), &bytes)?;
            results.push(result);
        }
    }
    write_tables(
        &args.out,
        &first.dataset_tasks,
        &first.approaches,
        &mut results,
    )?;
    Manifest::new(
        first.dataset_tasks.clone(),
        first.approaches.clone(),
        Shard::WHOLE,
        &results,
        Vec::new(),
    )
    .with_prompts(first.prompts.clone())
    .write(&args.out)?;
    eprintln!(
        "mapvlm: {} shards, {} plans merged; tables in {}",
        shards.len(),
        results.len(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}
