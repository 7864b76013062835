//! `mapvlm eval`: every task of a dataset through the chosen approaches, with
//! bounded concurrency and a progress bar, resumable; each plan scored with
//! KAS and PG2S against the ground truth; per-task JSON and the paper's
//! Table 3 layout as Markdown and CSV.

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
use super::plan::{runtime, AgentArgs};
use super::score::Metric;
use crate::agents::cache::{check_writable, write_atomic};
use crate::agents::cost::{estimate_plans, PlanCost};
use crate::agents::pipeline::{PlanInput, PlanRecord, Runner};
use crate::agents::Approach;
use crate::dataset::{Dataset, Task};
use crate::metrics::kas::kas;
use crate::metrics::pg2s::{Pg2sScorer, Pg2sSettings};

/// The most plans made at once: more only draws 429s from any provider.
const MAX_CONCURRENCY: usize = 64;

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
    /// How many plans are made at once.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 4,
        value_name = "N"
    )]
    pub concurrency: usize,
    /// Model settings for PG2S.
    #[command(flatten)]
    pub models: super::ModelArgs,
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
    /// The whole run, when a model made the plan.
    pub record: Option<PlanRecord>,
    /// Tokens and cost of the run that made the plan, per agent.
    #[serde(default)]
    pub cost: Option<PlanCost>,
}

struct Job<'a> {
    task: &'a Task,
    approach: Approach,
    file: PathBuf,
}

/// Runs `mapvlm eval`. Every task's result is written as soon as it is
/// scored; a task that fails is named with its reason and the others go on.
pub fn run(args: &EvalArgs) -> anyhow::Result<ExitCode> {
    if !(1..=MAX_CONCURRENCY).contains(&args.concurrency) {
        anyhow::bail!(
            "--concurrency {} is outside 1..={MAX_CONCURRENCY}",
            args.concurrency
        );
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
        for &approach in &approaches {
            let file = tasks_dir.join(result_file(&task.id, approach));
            match read_result(&file) {
                Some(result) if result.pg2s_scored || scorer.is_none() => done.results.push(result),
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
            Err(err) => self.fail(&result.id, result.approach, &format!("{err:#}")),
        }
    }

    /// Names a failed task on stderr and counts it.
    fn fail(&mut self, id: &str, approach: Approach, reason: &str) {
        eprintln!("mapvlm: {id} {approach}: {reason}");
        self.failed.push(format!("{id} {approach}"));
    }
}

fn pg2s_scorer(args: &EvalArgs) -> anyhow::Result<Option<Arc<Pg2sScorer>>> {
    let explicit = !args.metrics.is_empty();
    if explicit && !args.metrics.contains(&Metric::Pg2s) {
        return Ok(None);
    }
    match super::load_scorer(
        &args.models.with_no_cache(args.agents.no_cache),
        Pg2sSettings::default(),
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
            .map(|(job, input)| (job.approach, input)),
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
    let limit = Arc::new(Semaphore::new(args.concurrency.max(1)));
    let mut running = tokio::task::JoinSet::new();
    for (index, (job, input)) in jobs.iter().zip(inputs).enumerate() {
        let waiting = prefetched
            .as_ref()
            .and_then(|p| p.unfinished[index].as_ref());
        if let Some(reason) = waiting {
            progress.suspend(|| done.fail(&job.task.id, job.approach, reason));
            progress.inc(1);
            continue;
        }
        let runner: Arc<Runner> = runner.clone();
        let limit = limit.clone();
        let cancel = cancel.clone();
        let progress = progress.clone();
        let approach = job.approach;
        let label = format!("{} {approach}", job.task.id);
        running.spawn_on(
            async move {
                let _permit = limit.acquire_owned().await;
                let (events, mut drained) = tokio::sync::mpsc::unbounded_channel();
                let drain = tokio::spawn(async move { while drained.recv().await.is_some() {} });
                let record = runner.plan(approach, &input, &events, &cancel).await;
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
        let (id, approach) = (&job.task.id, job.approach);
        match record {
            Err(err) => progress.suspend(|| done.fail(id, approach, &err.to_string())),
            Ok(mut record) => {
                if let Some(prefetched) = &prefetched {
                    prefetched.mark_paid(&mut record);
                }
                let cost = ledger.add_plan(&record, billing);
                match record.first_error() {
                    Some((role, error)) => {
                        let reason = format!("{role} failed: {error}");
                        progress.suspend(|| done.fail(id, approach, &reason));
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

/// The name of the file of task `id` through `approach` under `OUT/tasks`.
pub(super) fn result_file(id: &str, approach: Approach) -> String {
    format!("{}.{approach}.json", safe_name(id))
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

fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let present: Vec<f64> = values.flatten().collect();
    (!present.is_empty()).then(|| present.iter().sum::<f64>() / present.len() as f64)
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
        (task, approach)
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
    let find = |id: &str, approach: Approach| {
        results
            .iter()
            .find(|r| r.id == id && r.approach == approach)
    };
    let mut markdown = String::from("| Task | Instruction |");
    let mut rule = String::from("| --- | --- |");
    let mut csv = String::from("id,task");
    for approach in approaches {
        let _ = write!(markdown, " {approach} PG2S | {approach} KAS |");
        rule.push_str(" ---: | ---: |");
        let _ = write!(csv, ",{approach}_pg2s,{approach}_kas");
    }
    let _ = writeln!(markdown, "\n{rule}");
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
