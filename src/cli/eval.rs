//! `mapvlm eval`: every task of a dataset through the chosen approaches, with
//! bounded concurrency and a progress bar, resumable; each plan scored with
//! KAS and PG2S against the ground truth; per-task JSON and the paper's
//! Table 3 layout as Markdown and CSV.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;

use super::eval_batch::{prefetch, BatchArgs};
use super::plan::{check_concurrency, runtime, AgentArgs};
use super::score::Metric;
use crate::agents::cost::{estimate_plans, PlanCost};
use crate::agents::pipeline::{is_first_sample, PlanInput, PlanRecord, Runner};
use crate::agents::Approach;
use crate::dataset::{Dataset, Task};
use crate::fsutil::{check_writable, write_atomic};
use crate::metrics::kas::kas;
use crate::metrics::pg2s::{Pg2sScorer, Pg2sSettings};
use crate::stats::summary::{self, Spread};

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
    /// The PG2S settings the scores were computed with (absent in results
    /// written before they were recorded: those used the defaults).
    #[serde(default)]
    pub pg2s_settings: Option<Pg2sSettings>,
    /// The whole run, when a model made the plan.
    pub record: Option<PlanRecord>,
    /// Tokens and cost of the run that made the plan, per agent.
    #[serde(default)]
    pub cost: Option<PlanCost>,
    /// Which sample of the plan this is (`--samples`; 0, and left out of
    /// the file, for the first).
    #[serde(default, skip_serializing_if = "is_first_sample")]
    pub sample: u32,
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

/// Runs `mapvlm eval`. Every task's result is written as soon as it is
/// scored; a task that fails is named with its reason and the others go on.
pub fn run(args: &EvalArgs) -> anyhow::Result<ExitCode> {
    check_concurrency(args.agents.concurrency)?;
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
    let (mut dataset, bad_lines) = Dataset::load(&args.dataset)?;
    for line in &bad_lines {
        eprintln!("mapvlm: {line}; that task was skipped");
    }
    let dataset_tasks: Vec<String> = dataset.tasks.iter().map(|t| t.id.clone()).collect();
    dataset.tasks.retain(|task| shard.contains(&task.id));
    let approaches = if args.approaches.is_empty() {
        Approach::ALL.to_vec()
    } else {
        args.approaches.clone()
    };
    let prompt_set = args.agents.prompt_set()?;
    let scorer = pg2s_scorer(args)?;
    let mut done = Finished {
        scorer: scorer.as_deref(),
        results: Vec::new(),
        failed: Vec::new(),
    };
    let mut to_make = Vec::new();
    let mut skipped = 0;
    for task in &dataset.tasks {
        for (&approach, sample) in approaches
            .iter()
            .flat_map(|a| (0..samples).map(move |k| (a, k)))
        {
            let file = tasks_dir.join(result_file(&task.id, approach, sample));
            match read_result(&file) {
                Some(result) if scored_as(&result, scorer.as_deref()) => done.results.push(result),
                Some(planned) => done.add(&file, planned),
                None if args.from_dataset_plans => match task.plans.get(approach.dataset_field()) {
                    Some(steps) => {
                        let result = new_result(task, approach, "dataset", steps.clone(), None);
                        done.add(&file, result);
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
    let prompts = super::merge::prompt_versions(&prompt_set, &approaches);
    super::merge::Manifest::new(dataset_tasks, approaches, shard, &results, failed)
        .with_prompts(prompts)
        .write(&args.out)?;
    eprintln!(
        "mapvlm: {} plans scored, {skipped} without input or plan, {failures} failed; tables in {}",
        results.len(),
        args.out.display()
    );
    if failures > 0 {
        eprintln!("mapvlm: run the same command again to retry only what failed");
    }
    Ok(if failures == 0 && bad_lines.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The results gathered so far and how many tasks failed.
struct Finished<'a> {
    scorer: Option<&'a Pg2sScorer>,
    results: Vec<TaskResult>,
    /// `ID APPROACH` of every task that failed.
    failed: Vec<String>,
}

impl Finished<'_> {
    /// Scores `result` and writes it to `file` at once, so that a later
    /// failure or a kill loses nothing already paid for; a failure is named
    /// on stderr and counted.
    fn add(&mut self, file: &Path, mut result: TaskResult) {
        let outcome = score(&mut result, self.scorer).and_then(|()| write_result(file, &result));
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
        eprintln!("mapvlm: {label}: {reason}");
        self.failed.push(label);
    }
}

fn pg2s_scorer(args: &EvalArgs) -> anyhow::Result<Option<Arc<Pg2sScorer>>> {
    let explicit = !args.metrics.is_empty();
    if explicit && !args.metrics.contains(&Metric::Pg2s) {
        return Ok(None);
    }
    match super::load_scorer(
        &args.models.with_no_cache(args.agents.no_cache),
        args.pg2s.settings()?,
        &super::say,
        &crate::models::Progress::stderr(),
    ) {
        Ok(scorer) => Ok(Some(Arc::new(scorer))),
        Err(err) if !explicit => {
            eprintln!("mapvlm: PG2S left out ({err:#}); KAS only");
            Ok(None)
        }
        Err(err) => Err(err),
    }
}

/// Whether a result read back needs no scoring again: PG2S is not asked
/// for, or it was computed with the settings asked for now.
fn scored_as(result: &TaskResult, scorer: Option<&Pg2sScorer>) -> bool {
    scorer.is_none_or(|s| {
        result.pg2s_scored && result.pg2s_settings.unwrap_or_default() == s.settings()
    })
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
        pg2s_settings: None,
        sample: record.as_ref().map_or(0, |r| r.sample),
        record,
        cost: None,
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
        result.pg2s_settings = Some(report.settings);
    }
    Ok(())
}

/// Makes the plans of `jobs`, at most `--concurrency` at once, each scored
/// and written as soon as it is made.
fn make_plans(args: &EvalArgs, jobs: Vec<Job<'_>>, done: &mut Finished) -> anyhow::Result<()> {
    let mut ledger = args.agents.ledger()?;
    let (runner, recording) = args.agents.runner()?;
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
    let cancel = CancellationToken::new();
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
                let _permit = limit.acquire_owned().await;
                let (events, mut drained) = tokio::sync::mpsc::unbounded_channel();
                let drain = tokio::spawn(async move { while drained.recv().await.is_some() {} });
                let record = runner
                    .plan_sample(approach, &input, sample, &events, &cancel)
                    .await;
                drop(events);
                let _ = drain.await;
                progress.set_message(label);
                progress.inc(1);
                (index, record)
            },
            runtime.handle(),
        );
    }
    while let Some(joined) = runtime.block_on(running.join_next()) {
        let (index, record) = joined.context("a planning task stopped")?;
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
    }
    progress.finish_and_clear();
    if let Some(prefetched) = &prefetched {
        prefetched.bill_stranded(&mut ledger);
    }
    eprint!("{}", ledger.table());
    args.agents.save_recording(recording)?;
    Ok(())
}

/// What a plan for `task` is made from.
fn plan_input(task: &Task) -> PlanInput {
    PlanInput {
        task: task.task.clone(),
        image: task.image.clone(),
        table: task.table.clone(),
    }
}

/// The name of the file of sample `sample` of task `id` through `approach`
/// under `OUT/tasks`: `ID.APPROACH.json` for the first sample (as before
/// samples existed), `ID.APPROACH.sK.json` for sample index K > 0.
pub(super) fn result_file(id: &str, approach: Approach, sample: u32) -> String {
    if sample == 0 {
        format!("{}.{approach}.json", safe_name(id))
    } else {
        format!("{}.{approach}.s{sample}.json", safe_name(id))
    }
}

fn safe_name(id: &str) -> String {
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

fn read_result(file: &Path) -> Option<TaskResult> {
    let text = std::fs::read_to_string(file).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_result(file: &Path, result: &TaskResult) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(result)?;
    write_atomic(file, text.as_bytes())?;
    Ok(())
}

fn cell(value: Option<f64>, digits: usize) -> String {
    value.map_or_else(String::new, |v| format!("{v:.digits$}"))
}

/// The mean of the values present, if any.
fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let present: Vec<f64> = values.flatten().collect();
    summary::mean(&present).ok()
}

/// Sorts `results` by task (in the order of `task_ids`, the dataset's) and
/// approach, and writes the tables of [`tables`] as `OUT/table3.md` and
/// `OUT/table3.csv`: the one writer of the tables, for `eval` and `merge`.
pub(super) fn write_tables(
    out: &Path,
    task_ids: &[String],
    approaches: &[Approach],
    results: &mut [TaskResult],
) -> anyhow::Result<()> {
    results.sort_by_key(|r| {
        let task = task_ids.iter().position(|id| *id == r.id);
        let approach = approaches.iter().position(|a| *a == r.approach);
        (task, approach, r.sample)
    });
    let (markdown, csv) = tables(task_ids, approaches, results);
    write_atomic(&out.join("table3.md"), markdown.as_bytes())?;
    write_atomic(&out.join("table3.csv"), csv.as_bytes())?;
    Ok(())
}

/// The paper's Table 3: a row per task (in the order of `task_ids`), PG2S
/// and KAS for each approach, and the means; as Markdown and as CSV.
fn tables(
    task_ids: &[String],
    approaches: &[Approach],
    results: &[TaskResult],
) -> (String, String) {
    if results.is_empty() {
        return (String::from("No plans were scored.\n"), String::new());
    }
    let samples = results.iter().map(|r| r.sample + 1).max().unwrap_or(1);
    if samples > 1 {
        return sampled_tables(task_ids, approaches, results, samples);
    }
    let find = |id: &str, approach: Approach| {
        results
            .iter()
            .find(|r| r.id == id && r.approach == approach)
    };
    let mut markdown = markdown_heading(approaches);
    let mut csv = String::from("id,task");
    for approach in approaches {
        let _ = write!(csv, ",{approach}_pg2s,{approach}_kas");
    }
    csv.push('\n');
    for id in task_ids {
        let Some(first) = approaches.iter().find_map(|a| find(id, *a)) else {
            continue;
        };
        let _ = write!(markdown, "| {id} | {} |", first.task.replace('|', "\\|"));
        let _ = write!(csv, "{},{}", csv_field(id), csv_field(&first.task));
        for approach in approaches {
            let result = find(id, *approach);
            let (pg2s, kas) = (result.and_then(|r| r.pg2s), result.and_then(|r| r.kas));
            push_scores(&mut markdown, &mut csv, pg2s, kas, "");
        }
        markdown.push('\n');
        csv.push('\n');
    }
    let _ = write!(markdown, "| **Mean** | |");
    csv.push_str("mean,");
    for approach in approaches {
        let of = |r: &&TaskResult| r.approach == *approach;
        let pg2s = mean(results.iter().filter(of).map(|r| r.pg2s));
        let kas = mean(results.iter().filter(of).map(|r| r.kas));
        push_scores(&mut markdown, &mut csv, pg2s, kas, "**");
    }
    markdown.push('\n');
    csv.push('\n');
    (markdown, csv)
}

/// One score Table 3 reports: its heading, its CSV column and its value.
struct Score {
    label: &'static str,
    column: &'static str,
    of: fn(&TaskResult) -> Option<f64>,
}

/// The scores whose spread over samples the tables show.
const SCORES: [Score; 4] = [
    Score::new("PG2S", "pg2s", |r| r.pg2s),
    Score::new("S_plan", "s_plan", |r| r.s_plan),
    Score::new("S_goal", "s_goal", |r| r.s_goal),
    Score::new("KAS", "kas", |r| r.kas),
];

impl Score {
    const fn new(
        label: &'static str,
        column: &'static str,
        of: fn(&TaskResult) -> Option<f64>,
    ) -> Self {
        Score { label, column, of }
    }
}

/// Table 3 over several samples of each plan. Markdown: each task's PG2S
/// and KAS as the mean ±sd of its samples; the Mean row and a spread table
/// over the samples' means (each sample's mean over the tasks: mean ±sd and
/// min–max of PG2S, S_plan, S_goal and KAS). CSV: for each approach and
/// score its mean, sd, min and max, per task over its samples and, in the
/// `mean` row, over the samples' means.
fn sampled_tables(
    task_ids: &[String],
    approaches: &[Approach],
    results: &[TaskResult],
    samples: u32,
) -> (String, String) {
    let mut by_plan: HashMap<(&str, Approach), Vec<&TaskResult>> = HashMap::new();
    for result in results {
        by_plan
            .entry((result.id.as_str(), result.approach))
            .or_default()
            .push(result);
    }
    let spread_of = |plans: &[&TaskResult], score: &Score| {
        Spread::of(plans.iter().filter_map(|r| (score.of)(r)))
    };
    let over_samples = |approach: Approach, score: &Score| {
        Spread::of((0..samples).filter_map(|k| {
            mean(
                results
                    .iter()
                    .filter(|r| r.approach == approach && r.sample == k)
                    .map(score.of),
            )
        }))
    };
    let [pg2s, _, _, kas] = &SCORES;
    let mut markdown = markdown_heading(approaches);
    let mut csv = String::from("id,task");
    for approach in approaches {
        for score in &SCORES {
            let c = score.column;
            let _ = write!(
                csv,
                ",{approach}_{c},{approach}_{c}_sd,{approach}_{c}_min,{approach}_{c}_max"
            );
        }
    }
    csv.push('\n');
    for id in task_ids {
        let Some(first) = approaches
            .iter()
            .find_map(|a| by_plan.get(&(id.as_str(), *a)).and_then(|p| p.first()))
        else {
            continue;
        };
        let _ = write!(markdown, "| {id} | {} |", first.task.replace('|', "\\|"));
        let _ = write!(csv, "{},{}", csv_field(id), csv_field(&first.task));
        for approach in approaches {
            let plans = by_plan
                .get(&(id.as_str(), *approach))
                .map_or(&[][..], Vec::as_slice);
            for score in [pg2s, kas] {
                let _ = write!(markdown, " {} |", spread_cell(spread_of(plans, score), ""));
            }
            for score in &SCORES {
                push_spread_csv(&mut csv, spread_of(plans, score));
            }
        }
        markdown.push('\n');
        csv.push('\n');
    }
    let _ = write!(markdown, "| **Mean** | |");
    csv.push_str("mean,");
    for approach in approaches {
        for score in [pg2s, kas] {
            let cell = spread_cell(over_samples(*approach, score), "**");
            let _ = write!(markdown, " {cell} |");
        }
        for score in &SCORES {
            push_spread_csv(&mut csv, over_samples(*approach, score));
        }
    }
    let _ = write!(
        markdown,
        "\n\nSpread over {samples} samples (each sample's mean over the tasks): mean ±sd (min–max).\n\n| Approach |"
    );
    for score in &SCORES {
        let _ = write!(markdown, " {} |", score.label);
    }
    markdown.push_str("\n| --- |");
    markdown.push_str(&" ---: |".repeat(SCORES.len()));
    markdown.push('\n');
    for approach in approaches {
        let _ = write!(markdown, "| {approach} |");
        for score in &SCORES {
            let cell = over_samples(*approach, score).map_or_else(
                || "n/a".to_string(),
                |s| format!("{} ({})", s.plus_minus(3), s.range(3)),
            );
            let _ = write!(markdown, " {cell} |");
        }
        markdown.push('\n');
    }
    csv.push('\n');
    (markdown, csv)
}

/// The heading and rule of Table 3 in Markdown: the task, its
/// instruction, then PG2S and KAS of each approach.
fn markdown_heading(approaches: &[Approach]) -> String {
    let mut markdown = String::from("| Task | Instruction |");
    let mut rule = String::from("| --- | --- |");
    for approach in approaches {
        let _ = write!(markdown, " {approach} PG2S | {approach} KAS |");
        rule.push_str(" ---: | ---: |");
    }
    let _ = writeln!(markdown, "\n{rule}");
    markdown
}

/// A Markdown cell: `0.433 ±0.020`, emphasised, or `n/a`.
fn spread_cell(spread: Option<Spread>, emphasis: &str) -> String {
    spread.map_or_else(
        || format!("{emphasis}n/a{emphasis}"),
        |s| format!("{emphasis}{}{emphasis}", s.plus_minus(3)),
    )
}

/// Appends a spread's mean, sd, min and max as four CSV cells (empty when
/// unknown).
fn push_spread_csv(csv: &mut String, spread: Option<Spread>) {
    let (mean, sd, min, max) = match spread {
        Some(s) => (Some(s.mean), s.sd, Some(s.min), Some(s.max)),
        None => (None, None, None, None),
    };
    let _ = write!(
        csv,
        ",{},{},{},{}",
        cell(mean, 6),
        cell(sd, 6),
        cell(min, 6),
        cell(max, 6)
    );
}

/// Appends one approach's PG2S and KAS cells to both tables.
fn push_scores(
    markdown: &mut String,
    csv: &mut String,
    pg2s: Option<f64>,
    kas: Option<f64>,
    emphasis: &str,
) {
    let (p, k) = (or_na(cell(pg2s, 3)), or_na(cell(kas, 3)));
    let _ = write!(
        markdown,
        " {emphasis}{p}{emphasis} | {emphasis}{k}{emphasis} |"
    );
    let _ = write!(csv, ",{},{}", cell(pg2s, 6), cell(kas, 6));
}

fn or_na(text: String) -> String {
    if text.is_empty() {
        "n/a".into()
    } else {
        text
    }
}

fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scored(
        id: &str,
        approach: Approach,
        sample: u32,
        pg2s: f64,
        kas: Option<f64>,
    ) -> TaskResult {
        TaskResult {
            id: id.into(),
            approach,
            task: format!("Task {id}, with a comma"),
            source: "model".into(),
            ground_truth: vec!["Walk to the sink.".into()],
            steps: vec!["Walk to the sink.".into()],
            kas,
            kas_reason: None,
            pg2s_scored: true,
            s_plan: Some(pg2s + 0.1),
            s_goal: Some(pg2s - 0.1),
            pg2s: Some(pg2s),
            pg2s_settings: None,
            record: None,
            cost: None,
            sample,
        }
    }

    fn one_sample_results() -> Vec<TaskResult> {
        vec![
            scored("t1", Approach::SingleImage, 0, 0.5, Some(0.25)),
            scored("t1", Approach::MultiImage, 0, 0.625, None),
            scored("t2", Approach::SingleImage, 0, 0.375, Some(0.75)),
        ]
    }

    #[test]
    fn tables_of_one_sample_are_as_before_samples() {
        let ids = ["t1".to_string(), "t2".to_string()];
        let approaches = [Approach::SingleImage, Approach::MultiImage];
        let (markdown, csv) = tables(&ids, &approaches, &one_sample_results());
        insta::assert_snapshot!("table3_one_sample_md", markdown);
        insta::assert_snapshot!("table3_one_sample_csv", csv);
    }

    #[test]
    fn tables_of_three_samples_show_each_tasks_spread_and_the_samples_spread() {
        let ids = ["t1".to_string(), "t2".to_string()];
        let approaches = [Approach::SingleImage];
        let mut results = Vec::new();
        for (sample, (first, second)) in [(0.5, 0.25), (0.625, 0.375), (0.75, 0.5)]
            .into_iter()
            .enumerate()
        {
            let sample = sample as u32;
            results.push(scored(
                "t1",
                Approach::SingleImage,
                sample,
                first,
                Some(first),
            ));
            results.push(scored("t2", Approach::SingleImage, sample, second, None));
        }
        let (markdown, csv) = tables(&ids, &approaches, &results);
        // t1's PG2S over its samples: 0.5, 0.625, 0.75 -> mean 0.625, sd 0.125.
        assert!(
            markdown.contains("| t1 | Task t1, with a comma | 0.625 ±0.125 | 0.625 ±0.125 |"),
            "{markdown}"
        );
        // The samples' means over the tasks: 0.375, 0.5, 0.625.
        assert!(
            markdown.contains("| **Mean** | | **0.500 ±0.125** | **0.625 ±0.125** |"),
            "{markdown}"
        );
        assert!(markdown.contains("| single-image | 0.500 ±0.125 (0.375–0.625) | 0.600 ±0.125 (0.475–0.725) | 0.400 ±0.125 (0.275–0.525) | 0.625 ±0.125 (0.500–0.750) |"), "{markdown}");
        let lines: Vec<&str> = csv.lines().collect();
        assert!(lines[0].starts_with("id,task,single-image_pg2s,single-image_pg2s_sd,single-image_pg2s_min,single-image_pg2s_max,single-image_s_plan,"), "{csv}");
        assert!(
            lines[1]
                .starts_with("t1,\"Task t1, with a comma\",0.625000,0.125000,0.500000,0.750000,"),
            "{csv}"
        );
        assert!(lines[2].ends_with(",,,,"), "t2 has no KAS: {csv}");
        assert!(
            lines[3].starts_with("mean,,0.500000,0.125000,0.375000,0.625000,"),
            "{csv}"
        );
    }
}
