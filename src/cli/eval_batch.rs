//! `mapvlm eval --batch`: the requests an eval needs sent in provider
//! batches before the plans are made from the response cache; progress
//! while polling, failed requests named, the tasks they belong to left for
//! the next run.

use std::collections::HashSet;
use std::path::Path;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use tokio_util::sync::CancellationToken;

use super::plan::AgentArgs;
use crate::agents::batch::{
    poll_interval, run_batches, BatchEvent, BatchOptions, BatchOutcome, DEFAULT_POLL,
};
use crate::agents::cost::{AgentCost, Billing, Ledger};
use crate::agents::pipeline::{PlanInput, PlanRecord, Runner};
use crate::agents::Approach;

/// The file of the output folder holding the ids of submitted batches.
pub const SAVED_BATCHES: &str = "batches.json";

/// Options of `eval --batch`.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// Send the requests in provider batches (OpenAI's Batch API, Anthropic's
    /// Message Batches): half the price, answers within 24 hours. The batch
    /// ids are saved in OUT/batches.json: interrupt, and run the same command
    /// again to resume polling.
    #[arg(long, conflicts_with_all = ["no_cache", "replay", "record"])]
    pub batch: bool,
    /// Seconds between two polls of a batch (default 30, or batch_poll_secs
    /// in the config file).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "SECS",
        requires = "batch"
    )]
    pub poll_interval: Option<f64>,
}

impl BatchArgs {
    /// How the answers of this eval are paid for.
    pub fn billing(&self) -> Billing {
        if self.batch {
            Billing::Batch
        } else {
            Billing::Interactive
        }
    }
}

/// What the batches answered, for eval to bill the plans and to leave out
/// the tasks whose requests failed.
#[derive(Debug)]
pub struct Prefetched {
    outcome: BatchOutcome,
    /// For each plan, why it cannot be made from the cache (none: it can).
    pub unfinished: Vec<Option<String>>,
    /// The answers paid for in this run that belong to plans not made yet.
    stranded: Vec<AgentCost>,
}

impl Prefetched {
    /// Counts in `ledger` the answers paid for in this run whose plans could
    /// not be made (another request of theirs failed): a later run takes
    /// them from the cache.
    pub fn bill_stranded(&self, ledger: &mut Ledger) {
        for answer in &self.stranded {
            ledger.add_answer(
                answer.role,
                answer.provider,
                &answer.model,
                answer.usage,
                Billing::Batch,
            );
        }
    }

    /// Marks the agents of `record` that a batch of this run answered as
    /// not cached: they were paid for now, at the batch price.
    pub fn mark_paid(&self, record: &mut PlanRecord) {
        for agent in &mut record.agents {
            if self.outcome.answered.contains(&agent.request_key) {
                agent.cached = false;
            }
        }
    }
}

/// Sends what `plans` still need in provider batches, resuming those saved
/// in `out`, with a progress bar on stderr while polling.
pub fn prefetch(
    args: &BatchArgs,
    agents: &AgentArgs,
    runner: &Runner,
    plans: &[(Approach, PlanInput)],
    out: &Path,
    runtime: &tokio::runtime::Runtime,
    cancel: &CancellationToken,
) -> anyhow::Result<Prefetched> {
    let poll = match args.poll_interval.or(agents.config_file()?.batch_poll_secs) {
        Some(seconds) => poll_interval(seconds)?,
        None => DEFAULT_POLL,
    };
    let options = BatchOptions {
        saved: out.join(SAVED_BATCHES),
        poll,
    };
    let progress = ProgressBar::new(0);
    progress.set_style(
        ProgressStyle::with_template(
            "batch {bar:30} {pos}/{len} requests  {elapsed_precise}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let saved = options.saved.display().to_string();
    let on_event = |event: BatchEvent<'_>| {
        match event {
        BatchEvent::Submitted(batch) => progress.suspend(|| {
            eprintln!(
                "mapvlm: submitted {} batch {} ({} requests to {}); its id is saved in {saved}: interrupt and run again to resume",
                batch.provider.name(),
                batch.id,
                batch.keys.len(),
                batch.model
            )
        }),
        BatchEvent::Polled(batch, status) => {
            progress.set_length(status.total);
            progress.set_position(status.done);
            progress.set_message(format!("{} {}", batch.id, status.state));
        }
        BatchEvent::Failed { batch, key, reason } => progress.suspend(|| {
            eprintln!("mapvlm: {}", crate::sanitize::for_terminal(&format!("batch {} request {key}: {reason}", batch.id)));
        }),
    }
    };
    let outcome = runtime.block_on(run_batches(runner, plans, &options, &on_event, cancel));
    progress.finish_and_clear();
    let outcome = outcome?;
    eprintln!(
        "mapvlm: {} batches submitted ({} requests), {} answers collected, {} requests without an answer",
        outcome.batches,
        outcome.submitted,
        outcome.answered.len(),
        outcome.failed.len()
    );
    let unfinished: Vec<Option<String>> = plans
        .iter()
        .map(|(approach, input)| unfinished(runner, *approach, input, &outcome))
        .collect();
    let stranded = plans
        .iter()
        .zip(&unfinished)
        .filter(|(_, waiting)| waiting.is_some())
        .flat_map(|((approach, input), _)| stranded(runner, *approach, input, &outcome))
        .collect();
    Ok(Prefetched {
        outcome,
        unfinished,
        stranded,
    })
}

/// The answers a batch of this run gave to the plan's next stage, whose
/// plan cannot be made yet.
fn stranded(
    runner: &Runner,
    approach: Approach,
    input: &PlanInput,
    outcome: &BatchOutcome,
) -> Vec<AgentCost> {
    let (Ok(stage), Some(cache)) = (runner.next_stage(approach, input, 0), runner.cache()) else {
        return Vec::new();
    };
    stage
        .requests
        .iter()
        .filter(|r| outcome.answered.contains(&r.key))
        .filter_map(|r| {
            let answer = cache.get(&r.key)?;
            Some(AgentCost {
                role: r.role,
                provider: r.provider,
                model: answer.model,
                usage: answer.completion.usage,
                billing: Billing::Batch,
                usd: None,
            })
        })
        .collect()
}

/// Why the plan cannot be made from the cache yet, if it cannot.
fn unfinished(
    runner: &Runner,
    approach: Approach,
    input: &PlanInput,
    outcome: &BatchOutcome,
) -> Option<String> {
    let stage = runner.next_stage(approach, input, 0).ok()?;
    let missing: Vec<_> = stage.requests.iter().filter(|r| !r.free).collect();
    if missing.is_empty() && stage.planner_later.is_none() {
        return None;
    }
    let failed: HashSet<&str> = outcome.failed.keys().map(String::as_str).collect();
    let reason = missing
        .iter()
        .find_map(|r| {
            failed.contains(r.key.as_str()).then(|| {
                format!(
                    "{} has no answer from the batch: {}",
                    r.role, outcome.failed[&r.key]
                )
            })
        })
        .unwrap_or_else(|| "the batch gave no answer to build on".to_string());
    Some(format!("{reason}; run the same command again to retry"))
}
