//! `mapvlm eval`: every task of a dataset through the chosen approaches, with
//! bounded concurrency and a progress bar, resumable; each plan scored with
//! KAS and PG2S against the ground truth; per-task JSON and the paper's
//! Table 3 layout as Markdown and CSV.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;

use super::eval_batch::{prefetch, BatchArgs};
use super::plan::{check_concurrency, runtime, AgentArgs};
use super::score::Metric;
use crate::agents::cost::estimate_plans;
use crate::agents::pipeline::{PlanInput, PlanRecord, Runner};
use crate::agents::sink::OutputSink;
use crate::agents::Approach;
use crate::dataset::{Dataset, LineError, Task};
use crate::eval_record::{
    named_result_file, prompt_versions, result_file, write_tables, Manifest, Provenance, TaskResult,
};
use crate::fsutil::check_writable;
use crate::lock::Lock;
use crate::metrics::kas::kas;
use crate::metrics::pg2s::{Pg2sScorer, Pg2sSettings};
use crate::shard::Shard;

/// Options of `mapvlm eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The dataset folder (with tasks.jsonl).
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// The approaches, comma-separated (default: all four, in Table 3 order).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub approaches: Vec<Approach>,
    /// Where the per-task JSON files and the tables go.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Score the plans already in the dataset instead of calling any model.
    #[arg(long)]
    pub from_dataset_plans: bool,
    /// Take a task's image or table even when its path leads outside the
    /// dataset folder (absolute, or `..` past it); refused otherwise.
    #[arg(long)]
    pub allow_outside_paths: bool,
    /// The metrics (default: KAS, and PG2S when the model pack can be loaded).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub metrics: Vec<Metric>,
    /// Model settings for PG2S.
    #[command(flatten)]
    pub models: super::ModelArgs,
    /// The PG2S thresholds and weight.
    #[command(flatten)]
    pub pg2s: super::Pg2sArgs,
    /// Provider batch options.
    #[command(flatten)]
    pub batch: BatchArgs,
    /// Provider, prompt and cache options.
    #[command(flatten)]
    pub agents: AgentArgs,
    /// Which tasks this process evaluates (`mapvlm merge` joins the shards).
    #[command(flatten)]
    pub shard: super::ShardArgs,
}

impl EvalArgs {
    /// The approaches asked for: `--approaches`, else all four in Table 3
    /// order.
    fn approaches(&self) -> Vec<Approach> {
        if self.approaches.is_empty() {
            Approach::ALL.to_vec()
        } else {
            self.approaches.clone()
        }
    }
}

struct Job<'a> {
    task: &'a Task,
    approach: Approach,
    sample: u32,
    file: PathBuf,
}

impl Job<'_> {
    /// How the job is named in a failure line and the manifest.
    fn label(&self) -> String {
        failure_label(&self.task.id, self.approach, self.sample)
    }
}

/// `ID APPROACH`, and ` (sample K)` for a later sample.
fn failure_label(id: &str, approach: Approach, sample: u32) -> String {
    if sample == 0 {
        format!("{id} {approach}")
    } else {
        format!("{id} {approach} (sample {})", sample + 1)
    }
}

/// The lock file in an eval's `--out`: one eval writes a folder at a time.
const LOCK_FILE: &str = "eval.lock";

/// Runs `mapvlm eval`. Every task's result is written as soon as it is
/// scored; a task that fails is named with its reason and the others go on.
pub fn run(args: &EvalArgs) -> anyhow::Result<ExitCode> {
    check_concurrency(args.agents.concurrency)?;
    // The results name the dataset's files and the output folder as text.
    crate::fsutil::utf8_path("--dataset", &args.dataset)?;
    crate::fsutil::utf8_path("--out", &args.out)?;
    let samples = args.agents.samples;
    if samples > 1 && args.from_dataset_plans {
        anyhow::bail!("--samples {samples} with --from-dataset-plans: the dataset holds one plan per task and approach, so there is nothing to sample; leave out --samples");
    }
    if samples > 1 && args.batch.batch {
        anyhow::bail!("--samples {samples} with --batch: provider batches send one sample per request; leave out --batch to sample, or --samples to batch");
    }
    let shard = args.shard.shard()?;
    let tasks_dir = args.out.join("tasks");
    check_writable(&tasks_dir.join("probe.json"))
        .context("the results could not be written, so nothing was asked of any model")?;
    let _lock = Lock::acquire(&args.out.join(LOCK_FILE), "mapvlm eval")
        .context("another eval is writing this --out, so nothing was asked of any model")?;
    let (mut dataset, bad_lines) = Dataset::load_with(&args.dataset, args.allow_outside_paths)?;
    let dataset_hash = super::file_sha256(&Dataset::tasks_file(&args.dataset))?;
    let bad_tasks = bad_lines_of_shard(&bad_lines, shard);
    let dataset_tasks: Vec<String> = dataset.tasks.iter().map(|t| t.id.clone()).collect();
    dataset.tasks.retain(|task| shard.contains(&task.id));
    let approaches = args.approaches();
    let prompt_set = args.agents.prompt_set()?;
    let settings = args.pg2s.settings()?;
    let scorer = pg2s_scorer(args, settings)?;
    let (encoder, word_vectors) = match scorer {
        Some(_) => args.models.stamps()?,
        None => (None, None),
    };
    let provenance = Provenance {
        mapvlm_version: env!("CARGO_PKG_VERSION").to_string(),
        dataset_hash,
        metrics: [Some("kas"), scorer.is_some().then_some("pg2s")]
            .into_iter()
            .flatten()
            .map(str::to_string)
            .collect(),
        pg2s_settings: scorer.is_some().then_some(settings),
        encoder,
        word_vectors,
        prompts: prompt_versions(&prompt_set, &approaches),
    };
    let manifest = |results: &[TaskResult], failed: Vec<String>| {
        let (tasks, approaches) = (dataset_tasks.clone(), approaches.clone());
        Manifest::new(
            tasks,
            approaches,
            shard,
            results,
            failed,
            provenance.clone(),
        )
    };
    if let Some(before) = Manifest::read_if_any(&args.out)? {
        let out = args.out.display().to_string();
        before.check_resume(&out, &manifest(&[], Vec::new()))?;
    }
    let sink = OutputSink::new(CancellationToken::new());
    let mut done = Finished {
        scorer: scorer.as_deref(),
        provenance: &provenance,
        sink: &sink,
        results: Vec::new(),
        failed: bad_tasks,
    };
    let mut to_make = Vec::new();
    // Plans already at hand (the dataset's, or results written before
    // results recorded their provenance), scored after the loop.
    let mut to_score = Vec::new();
    let mut skipped = 0;
    for task in &dataset.tasks {
        for (&approach, sample) in approaches
            .iter()
            .flat_map(|a| (0..samples).map(move |k| (a, k)))
        {
            let file = tasks_dir.join(result_file(&task.id, approach, sample));
            match existing_result(&tasks_dir, &file, &task.id, approach, sample) {
                Some(result) => match &result.provenance {
                    Some(before) => {
                        let name = file.display().to_string();
                        let advice = "give another --out, or the options of the run that wrote it";
                        before.check_same(&name, &provenance, "this run", advice)?;
                        done.results.push(result);
                    }
                    // Written before results recorded their provenance: scored again.
                    None => to_score.push((file, result)),
                },
                None if args.from_dataset_plans => match task.plans.get(approach.dataset_field()) {
                    Some(steps) => {
                        let result = new_result(task, approach, "dataset", steps.clone(), None);
                        to_score.push((file, result));
                    }
                    None => skipped += 1,
                },
                None if has_input(task, approach) => to_make.push(Job {
                    task,
                    approach,
                    sample,
                    file,
                }),
                None => skipped += 1,
            }
        }
    }
    let mut lines = PlainProgress::new(to_score.len());
    for (file, result) in to_score {
        done.add(&file, result);
        lines.tick(done.failed.len());
    }
    if !to_make.is_empty() {
        make_plans(args, to_make, &mut done)?;
    }
    let Finished {
        mut results,
        failed,
        ..
    } = done;
    let order: Vec<String> = dataset.tasks.iter().map(|t| t.id.clone()).collect();
    write_tables(&args.out, &order, &approaches, &mut results)?;
    let failures = failed.len();
    manifest(&results, failed).write(&args.out)?;
    eprintln!(
        "mapvlm: {} plans scored, {skipped} without input or plan, {failures} failed; tables in {}",
        results.len(),
        args.out.display()
    );
    if failures > 0 {
        eprintln!("mapvlm: run the same command again to retry only what failed");
    }
    Ok(if failures == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The bad lines of the tasks file that fail this shard, as the manifest
/// lists them, each said on stderr: a line whose `id` can be read fails
/// only the shard of that task (the others skip it); a line with no
/// readable `id` fails every shard, so that `merge` refuses until it is
/// fixed.
fn bad_lines_of_shard(bad_lines: &[LineError], shard: Shard) -> Vec<String> {
    let mut failed = Vec::new();
    for bad in bad_lines {
        match &bad.id {
            Some(id) if !shard.contains(id) => {}
            Some(id) => {
                eprintln!(
                    "mapvlm: {}; task {} is in this shard, so the shard fails until the line is fixed",
                    crate::sanitize::for_terminal(&bad.to_string()),
                    crate::sanitize::for_terminal(id)
                );
                failed.push(format!("{id} (line {} of the tasks file)", bad.line));
            }
            None => {
                eprintln!(
                    "mapvlm: {}; no task id can be read there, so every shard fails until the line is fixed",
                    crate::sanitize::for_terminal(&bad.to_string())
                );
                failed.push(format!(
                    "line {} of the tasks file (no readable id)",
                    bad.line
                ));
            }
        }
    }
    failed
}

/// The results gathered so far and how many tasks failed.
struct Finished<'a> {
    scorer: Option<&'a Pg2sScorer>,
    /// How this run scores: stamped on every result it writes.
    provenance: &'a Provenance,
    /// Where the results are written; the first failure cancels the run.
    sink: &'a OutputSink,
    results: Vec<TaskResult>,
    /// `ID APPROACH` of every task that failed.
    failed: Vec<String>,
}

impl Finished<'_> {
    /// Scores `result` and writes it to `file` at once, so that a later
    /// failure or a kill loses nothing already paid for; a failure is named
    /// on stderr and counted.
    fn add(&mut self, file: &Path, mut result: TaskResult) {
        result.provenance = Some(self.provenance.clone());
        let outcome =
            score(&mut result, self.scorer).and_then(|()| write_result(self.sink, file, &result));
        match outcome {
            Ok(()) => self.results.push(result),
            Err(err) => {
                let label = failure_label(&result.id, result.approach, result.sample);
                self.fail(label, &format!("{err:#}"));
            }
        }
    }

    /// Names a failed task (see [`failure_label`]) on stderr and counts it.
    fn fail(&mut self, label: String, reason: &str) {
        eprintln!(
            "mapvlm: {}",
            crate::sanitize::for_terminal(&format!("{label}: {reason}"))
        );
        self.failed.push(label);
    }
}

/// The PG2S scorer, when PG2S is asked for: by default, or by `--metrics`
/// naming it. Models that cannot be loaded end the run here, before any
/// provider is asked: KAS alone is only ever scored on request
/// (`--metrics kas`), and the manifest records it.
fn pg2s_scorer(args: &EvalArgs, settings: Pg2sSettings) -> anyhow::Result<Option<Arc<Pg2sScorer>>> {
    if !args.metrics.is_empty() && !args.metrics.contains(&Metric::Pg2s) {
        return Ok(None);
    }
    let scorer = super::load_scorer(
        &args.models.with_no_cache(args.agents.no_cache),
        settings,
        &super::say,
        &crate::models::Progress::stderr(),
    )
    .context("PG2S could not be loaded, so nothing was asked of any model; fix the model pack (`mapvlm models verify`, `mapvlm models fetch`) or give --metrics kas to score KAS alone")?;
    Ok(Some(Arc::new(scorer)))
}

fn has_input(task: &Task, approach: Approach) -> bool {
    if approach.uses_image() {
        task.image.is_some()
    } else {
        task.table.is_some()
    }
}

fn new_result(
    task: &Task,
    approach: Approach,
    source: &str,
    steps: Vec<String>,
    record: Option<PlanRecord>,
) -> TaskResult {
    TaskResult {
        id: task.id.clone(),
        approach,
        task: task.task.clone(),
        source: source.to_string(),
        ground_truth: task.ground_truth.clone(),
        steps,
        kas: None,
        kas_reason: None,
        pg2s_scored: false,
        s_plan: None,
        s_goal: None,
        pg2s: None,
        sample: record.as_ref().map_or(0, |r| r.sample),
        record,
        cost: None,
        provenance: None,
    }
}

fn score(result: &mut TaskResult, scorer: Option<&Pg2sScorer>) -> anyhow::Result<()> {
    let report = kas(&result.ground_truth, &result.steps);
    result.kas = report.kas;
    result.kas_reason = report.reason;
    if let Some(scorer) = scorer {
        let report = scorer
            .score(&result.ground_truth, &result.steps)
            .map_err(|err| anyhow::anyhow!("scoring {} {}: {err}", result.id, result.approach))?;
        result.s_plan = Some(report.s_plan);
        result.s_goal = report.s_goal();
        result.pg2s = report.pg2s();
        result.pg2s_scored = true;
    }
    Ok(())
}

/// Makes the plans of `jobs`, at most `--concurrency` at once, each scored
/// and written as soon as it is made.
fn make_plans(args: &EvalArgs, jobs: Vec<Job<'_>>, done: &mut Finished) -> anyhow::Result<()> {
    let mut ledger = args.agents.ledger()?;
    let (runner, recording) = args.agents.runner(&args.approaches())?;
    let inputs: Vec<PlanInput> = jobs.iter().map(|job| plan_input(job.task)).collect();
    let billing = args.batch.billing();
    let estimate = estimate_plans(
        &runner,
        jobs.iter()
            .zip(&inputs)
            .map(|(job, input)| (job.approach, input, job.sample)),
        billing,
        ledger.prices(),
    );
    args.agents.check_estimate(&estimate)?;
    let cancel = done.sink.cancel().clone();
    let runtime = runtime(&cancel)?;
    let prefetched = if args.batch.batch {
        let plans: Vec<_> = jobs
            .iter()
            .map(|j| j.approach)
            .zip(inputs.clone())
            .collect();
        Some(prefetch(
            &args.batch,
            &args.agents,
            &runner,
            &plans,
            &args.out,
            &runtime,
            &cancel,
        )?)
    } else {
        None
    };
    let runner = Arc::new(runner);
    let progress = ProgressBar::new(jobs.len() as u64);
    progress.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} plans  {elapsed_precise}  {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let limit = Arc::new(Semaphore::new(args.agents.concurrency.max(1)));
    let mut running = tokio::task::JoinSet::new();
    for (index, (job, input)) in jobs.iter().zip(inputs).enumerate() {
        let waiting = prefetched
            .as_ref()
            .and_then(|p| p.unfinished[index].as_ref());
        if let Some(reason) = waiting {
            progress.suspend(|| done.fail(job.label(), reason));
            progress.inc(1);
            continue;
        }
        let runner: Arc<Runner> = runner.clone();
        let limit = limit.clone();
        let cancel = cancel.clone();
        let progress = progress.clone();
        let (approach, sample) = (job.approach, job.sample);
        let label = job.label();
        running.spawn_on(
            async move {
                // Held until the result is written: a write that fails
                // cancels the run before the next plan may start.
                let permit = limit.acquire_owned().await;
                let (events, mut drained) = tokio::sync::mpsc::unbounded_channel();
                let drain = tokio::spawn(async move { while drained.recv().await.is_some() {} });
                let record = runner
                    .plan_sample(approach, &input, sample, &events, &cancel)
                    .await;
                drop(events);
                let _ = drain.await;
                progress.set_message(label);
                progress.inc(1);
                (index, record, permit)
            },
            runtime.handle(),
        );
    }
    let mut lines = PlainProgress::new(jobs.len());
    while let Some(joined) = runtime.block_on(running.join_next()) {
        let (index, record, permit) = joined.context("a planning task stopped")?;
        let job = &jobs[index];
        let approach = job.approach;
        match record {
            Err(err) => progress.suspend(|| done.fail(job.label(), &err.to_string())),
            Ok(mut record) => {
                if let Some(prefetched) = &prefetched {
                    prefetched.mark_paid(&mut record);
                }
                let cost = ledger.add_plan(&record, billing);
                match record.first_error() {
                    Some((role, error)) => {
                        let reason = format!("{role} failed: {error}");
                        progress.suspend(|| done.fail(job.label(), &reason));
                    }
                    None => {
                        let steps = record.steps.clone();
                        let mut result =
                            new_result(job.task, approach, "model", steps, Some(record));
                        result.cost = Some(cost);
                        progress.suspend(|| done.add(&job.file, result));
                    }
                }
            }
        }
        drop(permit);
        lines.tick(done.failed.len());
    }
    progress.finish_and_clear();
    if done.sink.failed() {
        eprintln!("mapvlm: the output could not be written, so no further plan was asked for; make room and run the same command again");
    } else if cancel.is_cancelled() {
        eprintln!("mapvlm: interrupted; what was made is kept, and the same command asks only for the rest");
    }
    if let Some(prefetched) = &prefetched {
        prefetched.bill_stranded(&mut ledger);
    }
    eprint!("{}", ledger.table());
    args.agents.save_recording(recording, done.sink)?;
    Ok(())
}

/// Plain progress lines on stderr for a log (a job's output file), where
/// the bar does not show: every [`PlainProgress::EVERY`] plans or
/// [`PlainProgress::SECONDS`] seconds, the plans done of all, the failures
/// and the rate, for the plans made and for those scored from the dataset
/// alike. Silent on a terminal, where the plans made have the bar.
struct PlainProgress {
    total: usize,
    done: usize,
    start: std::time::Instant,
    last: std::time::Instant,
    on: bool,
}

impl PlainProgress {
    /// A line at least every this many plans.
    const EVERY: usize = 10;
    /// A line at least every this many seconds (when a plan ends).
    const SECONDS: u64 = 30;

    fn new(total: usize) -> Self {
        use std::io::IsTerminal;
        let now = std::time::Instant::now();
        PlainProgress {
            total,
            done: 0,
            start: now,
            last: now,
            on: !std::io::stderr().is_terminal(),
        }
    }

    /// One plan ended; `failed` have failed so far.
    fn tick(&mut self, failed: usize) {
        self.done += 1;
        let due = self.done % Self::EVERY == 0
            || self.done == self.total
            || self.last.elapsed().as_secs() >= Self::SECONDS;
        if !self.on || !due {
            return;
        }
        self.last = std::time::Instant::now();
        let minutes = self.start.elapsed().as_secs_f64() / 60.0;
        let rate = if minutes > 0.0 {
            self.done as f64 / minutes
        } else {
            0.0
        };
        eprintln!(
            "mapvlm: {}/{} plans, {failed} failed, {rate:.1} plans/min",
            self.done, self.total
        );
    }
}

/// What a plan for `task` is made from.
fn plan_input(task: &Task) -> PlanInput {
    PlanInput {
        task: task.task.clone(),
        image: task.image.clone(),
        table: task.table.clone(),
    }
}

/// The result of task `id` already in `tasks_dir` at `file`, or under the
/// name older versions gave it (no hash suffix) when it is that task's, so
/// that an existing output folder resumes without paying again.
fn existing_result(
    tasks_dir: &Path,
    file: &Path,
    id: &str,
    approach: Approach,
    sample: u32,
) -> Option<TaskResult> {
    read_result(file).or_else(|| {
        let legacy = crate::dataset::legacy_file_stem(id);
        let old = tasks_dir.join(named_result_file(&legacy, approach, sample));
        read_result(&old).filter(|result| result.id == id)
    })
}

fn read_result(file: &Path) -> Option<TaskResult> {
    let text = std::fs::read_to_string(file).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_result(sink: &OutputSink, file: &Path, result: &TaskResult) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(result)?;
    sink.write(file, text.as_bytes())?;
    Ok(())
}
