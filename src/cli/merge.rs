//! `mapvlm merge DIR... --out DIR`: the output folders of `eval --shard`
//! joined into the per-task files and tables one whole run writes.
//!
//! Every `eval` writes `OUT/manifest.json` ([`Manifest`]): the dataset's
//! task ids, the approaches, its shard, the result files it wrote and how
//! it scored them ([`crate::eval_record::Provenance`]). From these a merge
//! knows what a whole run would hold, and refuses, naming the tasks, when a
//! shard is missing or a shard's results are incomplete, and, naming the
//! field and the shards, when two shards were not scored alike.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use crate::eval_record::{write_tables, CostSum, Manifest, TaskResult};
use crate::fsutil::write_atomic;
use crate::shard::Shard;

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

/// What to do when two shards differ.
const RERUN: &str =
    "run that shard's eval again with the options of the others, into an empty --out";

/// Runs `mapvlm merge`.
pub fn run(args: &MergeArgs) -> anyhow::Result<ExitCode> {
    let shards = args
        .shards
        .iter()
        .map(|dir| Ok((dir.as_path(), Manifest::read(dir)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let (first_dir, first) = &shards[0];
    let first_name = first_dir.display().to_string();
    let mut by_index: BTreeMap<u64, &Path> = BTreeMap::new();
    for (dir, manifest) in &shards {
        first.check_same_run(&first_name, manifest, &dir.display().to_string(), RERUN)?;
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
    let mut read = Vec::new();
    for (dir, manifest) in &shards {
        for name in &manifest.results {
            let from = dir.join("tasks").join(name);
            let bytes = std::fs::read(&from).with_context(|| {
                format!("{}: missing; run that shard's eval again", from.display())
            })?;
            let result: TaskResult = serde_json::from_slice(&bytes)
                .with_context(|| format!("{}: not a task result", from.display()))?;
            let scored = result.provenance.clone().unwrap_or_default();
            let shard_name = dir.display().to_string();
            scored.check_same(
                &from.display().to_string(),
                &manifest.provenance,
                &shard_name,
                RERUN,
            )?;
            read.push((name, bytes, result));
        }
    }
    let mut results = Vec::new();
    for (name, bytes, result) in read {
        write_atomic(&args.out.join("tasks").join(name), &bytes)?;
        results.push(result);
    }
    write_tables(
        &args.out,
        &first.dataset_tasks,
        &first.approaches,
        &mut results,
    )?;
    let mut merged = Manifest::new(
        first.dataset_tasks.clone(),
        first.approaches.clone(),
        Shard::WHOLE,
        &results,
        Vec::new(),
        first.provenance.clone(),
    );
    merged.cost = shards
        .iter()
        .fold(CostSum::default(), |sum, (_, m)| sum.plus(&m.cost));
    merged.write(&args.out)?;
    eprintln!(
        "mapvlm: {} shards, {} plans merged ({}); tables in {}",
        shards.len(),
        results.len(),
        merged.cost,
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}
