//! Provider batch APIs for `eval --batch`: every request an eval still needs
//! is sent in provider batches (OpenAI's Batch API, Anthropic's Message
//! Batches) at half the price and outside the interactive rate limits, and
//! each answer is stored in the response cache like any other, so that the
//! plans are then made from the cache. Multi-agent plans go in stages: the
//! miners of every task in one batch, then the Planners.
//!
//! The ids of the submitted batches are saved (atomically) in a file of the
//! output folder as soon as each is created, so that an interrupted run
//! polls them again instead of submitting twice. The file holds the provider,
//! base URL, model, agent, batch id and the requests' cache keys: never a
//! key, and the request bodies are built in memory only.

pub mod anthropic;
pub mod openai;

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use serde_json::Value;
use tokio_util::sync::CancellationToken;

use super::cache::CachedAnswer;
use super::pipeline::{PendingRequest, PlanInput, Runner};
use super::provider::{cancellable, Assembler, Completion, HttpEndpoint};
use super::{AgentError, AgentRole, Approach, ProviderKind, Usage};
use crate::fsutil::write_atomic;

/// The most requests put in one batch (both providers accept more; smaller
/// batches finish sooner and lose less when one fails).
pub const MAX_BATCH_REQUESTS: usize = 10_000;

/// The most bytes of requests put in one batch (OpenAI takes 200 MB,
/// Anthropic 256 MB).
pub const MAX_BATCH_BYTES: usize = 100 * 1024 * 1024;

/// The shortest and longest wait between two polls of a batch.
pub const POLL_BOUNDS: (Duration, Duration) = (Duration::from_millis(10), Duration::from_secs(600));

/// The wait between two polls unless configured.
pub const DEFAULT_POLL: Duration = Duration::from_secs(30);

/// Everything that can stop a batch run.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// A request to a provider failed.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// An agent set to the recording has a request the recording cannot
    /// answer, and a recording has no batches.
    #[error("{0} is set to the replay provider, which has no batches and no answer for this request: give it a provider (openai or anthropic)")]
    Replay(AgentRole),
    /// The runner has no response cache to put the answers in.
    #[error("--batch keeps the answers in the response cache: drop --no-cache")]
    NoCache,
    /// The saved batch ids could not be read.
    #[error("{path}: not a file of batch ids ({message}); move it away to submit the batches again (those already submitted are then paid twice)")]
    Saved {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// A file could not be written whole (see [`crate::fsutil`]).
    #[error(transparent)]
    Write(#[from] crate::fsutil::FsError),
}

/// A batch's progress as its provider reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchStatus {
    /// The provider's word for it (`in_progress`, `completed`, `ended`…).
    pub state: String,
    /// Whether it will change no more.
    pub ended: bool,
    /// Requests finished, answered or not.
    pub done: u64,
    /// Requests in the batch.
    pub total: u64,
    /// Where the results are: OpenAI's output and error file ids, or
    /// Anthropic's results URL.
    pub results: Vec<String>,
    /// Why the whole batch failed, when the provider says.
    pub error: Option<String>,
}

/// One request's outcome in a batch's results.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The answer, the key removed from its text.
    Answered(Completion),
    /// Why it has no answer (failed, expired, cancelled).
    Failed(String),
}

/// A submitted batch, as saved in the output folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedBatch {
    /// The provider.
    pub provider: ProviderKind,
    /// The endpoint's base URL, its credentials replaced by `***`
    /// ([`crate::sanitize::redact_url_credentials`]): the file is a record,
    /// and the run that polls takes them from its own settings.
    pub base_url: String,
    /// The model of every request in it.
    pub model: String,
    /// The agent whose settings give the API key (from the environment or
    /// config file of the run that polls).
    pub role: AgentRole,
    /// The provider's id of the batch.
    pub id: String,
    /// The cache keys of its requests (their `custom_id`s).
    pub keys: Vec<String>,
}

/// The batches submitted and not yet collected.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SavedBatches {
    /// Oldest first.
    pub batches: Vec<SavedBatch>,
}

impl SavedBatches {
    /// Reads `path`; a missing file is no batch.
    pub fn load(path: &Path) -> Result<Self, BatchError> {
        let saved = |message: String| BatchError::Saved {
            path: path.to_path_buf(),
            message,
        };
        match std::fs::read_to_string(path) {
            Ok(text) => serde_json::from_str(&text).map_err(|err| saved(err.to_string())),
            Err(err) if err.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(err) => Err(saved(err.to_string())),
        }
    }

    /// Writes `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), BatchError> {
        let text = serde_json::to_string_pretty(self).map_err(|err| BatchError::Saved {
            path: path.to_path_buf(),
            message: err.to_string(),
        })?;
        Ok(write_atomic(path, text.as_bytes())?)
    }
}

/// What a batch run tells as it goes.
#[derive(Debug, Clone, PartialEq)]
pub enum BatchEvent<'a> {
    /// A batch was created and its id saved.
    Submitted(&'a SavedBatch),
    /// A batch was polled.
    Polled(&'a SavedBatch, &'a BatchStatus),
    /// A request of a batch has no answer.
    Failed {
        /// The batch.
        batch: &'a SavedBatch,
        /// The request's cache key (its `custom_id`).
        key: &'a str,
        /// Why.
        reason: &'a str,
    },
}

/// How a batch run goes.
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// The file of saved batch ids.
    pub saved: PathBuf,
    /// The wait between two polls.
    pub poll: Duration,
}

/// What a batch run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchOutcome {
    /// The keys of the requests a batch answered in this run (now cached).
    pub answered: HashSet<String>,
    /// The requests without an answer, and why.
    pub failed: BTreeMap<String, String>,
    /// Requests submitted in this run.
    pub submitted: usize,
    /// Batches submitted in this run.
    pub batches: usize,
}

/// Sends in provider batches every request the `plans` still need (those
/// whose answer is not cached), stage by stage, and stores the answers in
/// the runner's response cache. Batches saved in `options.saved` by an
/// interrupted run are polled and collected first, and their requests are
/// not submitted again; a request that fails is reported and not retried in
/// the same run (a new run retries it).
pub async fn run_batches(
    runner: &Runner,
    plans: &[(Approach, PlanInput)],
    options: &BatchOptions,
    on_event: &(dyn Fn(BatchEvent<'_>) + Send + Sync),
    cancel: &CancellationToken,
) -> Result<BatchOutcome, BatchError> {
    let mut saved = SavedBatches::load(&options.saved)?;
    let mut outcome = BatchOutcome::default();
    let mut attempted: HashSet<String> = saved
        .batches
        .iter()
        .flat_map(|b| b.keys.iter().cloned())
        .collect();
    loop {
        while let Some(batch) = saved.batches.first().cloned() {
            collect(runner, &batch, options.poll, &mut outcome, on_event, cancel).await?;
            saved.batches.remove(0);
            saved.save(&options.saved)?;
        }
        let groups = next_requests(runner, plans, &attempted);
        if groups.is_empty() {
            return Ok(outcome);
        }
        for ((provider, base_url, model), requests) in groups {
            for chunk in chunks(&requests) {
                let role = chunk[0].role;
                let client = client(runner, provider, &base_url, role)?;
                let id = match provider {
                    ProviderKind::Openai => openai::submit(&client, &chunk, cancel).await?,
                    ProviderKind::Anthropic => anthropic::submit(&client, &chunk, cancel).await?,
                    ProviderKind::Replay => return Err(BatchError::Replay(role)),
                };
                let batch = SavedBatch {
                    provider,
                    base_url: crate::sanitize::redact_url_credentials(&base_url),
                    model: model.clone(),
                    role,
                    id,
                    keys: chunk.iter().map(|r| r.key.clone()).collect(),
                };
                attempted.extend(batch.keys.iter().cloned());
                saved.batches.push(batch);
                saved.save(&options.saved)?;
                outcome.submitted += chunk.len();
                outcome.batches += 1;
                if let Some(batch) = saved.batches.last() {
                    on_event(BatchEvent::Submitted(batch));
                }
            }
        }
    }
}

/// The requests of the plans' next stages not cached and not yet tried,
/// each once, grouped by provider, base URL and model (a batch holds one
/// model).
fn next_requests(
    runner: &Runner,
    plans: &[(Approach, PlanInput)],
    attempted: &HashSet<String>,
) -> BTreeMap<(ProviderKind, String, String), Vec<PendingRequest>> {
    let mut groups: BTreeMap<_, Vec<PendingRequest>> = BTreeMap::new();
    let mut seen = HashSet::new();
    for (approach, input) in plans {
        let Ok(stage) = runner.next_stage(*approach, input, 0) else {
            continue;
        };
        for pending in stage.requests {
            if pending.free || attempted.contains(&pending.key) || !seen.insert(pending.key.clone())
            {
                continue;
            }
            let settings = runner.settings().agent(pending.role);
            let group = (
                pending.provider,
                settings.base_url.clone(),
                pending.request.model.clone(),
            );
            groups.entry(group).or_default().push(pending);
        }
    }
    groups
}

/// `requests` cut into batches of at most [`MAX_BATCH_REQUESTS`] requests
/// and about [`MAX_BATCH_BYTES`] bytes of prompts and images.
fn chunks(requests: &[PendingRequest]) -> Vec<Vec<&PendingRequest>> {
    let mut out: Vec<Vec<&PendingRequest>> = Vec::new();
    let mut bytes = 0;
    for pending in requests {
        let request = &pending.request;
        let size = request.system.len()
            + request.user.len()
            + request
                .images
                .iter()
                .map(|i| i.data_base64.len())
                .sum::<usize>();
        let full = out.last().is_none_or(|last| {
            last.len() >= MAX_BATCH_REQUESTS || (bytes + size > MAX_BATCH_BYTES && !last.is_empty())
        });
        if full {
            out.push(Vec::new());
            bytes = 0;
        }
        bytes += size;
        if let Some(last) = out.last_mut() {
            last.push(pending);
        }
    }
    out
}

/// The HTTP endpoint of a batch, with the key of `role`'s settings.
fn client(
    runner: &Runner,
    provider: ProviderKind,
    base_url: &str,
    role: AgentRole,
) -> Result<HttpEndpoint, AgentError> {
    let settings = runner.settings();
    let key = settings.agent(role).api_key.clone();
    HttpEndpoint::new(provider.name(), base_url, key, settings.http.clone())
}

/// Polls `batch` until it ends, then stores each answer in the cache and
/// reports each request without one.
async fn collect(
    runner: &Runner,
    batch: &SavedBatch,
    poll: Duration,
    outcome: &mut BatchOutcome,
    on_event: &(dyn Fn(BatchEvent<'_>) + Send + Sync),
    cancel: &CancellationToken,
) -> Result<(), BatchError> {
    let cache = runner.cache().ok_or(BatchError::NoCache)?;
    // The saved URL has its credentials redacted: the settings' own URL is
    // used when it is the same endpoint (an older file kept them in full).
    let configured = &runner.settings().agent(batch.role).base_url;
    let base_url = if crate::sanitize::redact_url_credentials(configured) == batch.base_url {
        configured
    } else {
        &batch.base_url
    };
    let client = client(runner, batch.provider, base_url, batch.role)?;
    let status = loop {
        let status = match batch.provider {
            ProviderKind::Openai => openai::status(&client, &batch.id, cancel).await?,
            ProviderKind::Anthropic => anthropic::status(&client, &batch.id, cancel).await?,
            ProviderKind::Replay => return Err(BatchError::Replay(batch.role)),
        };
        on_event(BatchEvent::Polled(batch, &status));
        if status.ended {
            break status;
        }
        cancellable(cancel, tokio::time::sleep(poll)).await?;
    };
    let results = match batch.provider {
        ProviderKind::Openai => openai::results(&client, &status, &batch.model, cancel).await?,
        ProviderKind::Anthropic => {
            anthropic::results(&client, &status, &batch.model, cancel).await?
        }
        ProviderKind::Replay => return Err(BatchError::Replay(batch.role)),
    };
    let mut unanswered: HashSet<&str> = batch.keys.iter().map(String::as_str).collect();
    for (key, result) in results {
        if !unanswered.remove(key.as_str()) {
            continue;
        }
        match result {
            Outcome::Answered(completion) => {
                cache.put(&CachedAnswer {
                    key: key.clone(),
                    provider: batch.provider,
                    model: batch.model.clone(),
                    completion,
                })?;
                outcome.answered.insert(key);
            }
            Outcome::Failed(reason) => {
                on_event(BatchEvent::Failed {
                    batch,
                    key: &key,
                    reason: &reason,
                });
                outcome.failed.insert(key, reason);
            }
        }
    }
    let mut missing: Vec<&str> = unanswered.into_iter().collect();
    missing.sort_unstable();
    for key in missing {
        let mut reason = format!(
            "batch {} ended ({}) without an answer",
            batch.id, status.state
        );
        if let Some(error) = &status.error {
            reason.push_str(&format!(": {error}"));
        }
        on_event(BatchEvent::Failed {
            batch,
            key,
            reason: &reason,
        });
        outcome.failed.insert(key.to_string(), reason);
    }
    Ok(())
}

/// A batch's answer text as a completion, the key removed; an empty answer
/// is a failure.
fn completion(endpoint: &HttpEndpoint, text: &str, usage: Usage, model: &str) -> Outcome {
    let mut answer = Assembler::new(&|_| {}, endpoint.key.clone());
    answer.push(text);
    answer.usage = usage;
    match answer.finish(endpoint.provider, model) {
        Ok(completion) => Outcome::Answered(completion),
        Err(err) => Outcome::Failed(err.to_string()),
    }
}

/// Each line of a results file (JSONL, blank lines skipped) with a
/// `custom_id`, read by the provider's `outcome` as an answer or a failure.
async fn read_outcomes(
    endpoint: &HttpEndpoint,
    response: reqwest::Response,
    model: &str,
    outcome: fn(&HttpEndpoint, &Value, &str) -> Outcome,
    cancel: &CancellationToken,
) -> Result<Vec<(String, Outcome)>, AgentError> {
    let text = cancellable(cancel, response.text())
        .await?
        .map_err(|err| endpoint.transport_error(&err))?;
    let mut outcomes = Vec::new();
    for (number, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let line: Value = serde_json::from_str(line).map_err(|err| {
            endpoint.invalid(format!("line {} of the batch results: {err}", number + 1))
        })?;
        if let Some(id) = line.get("custom_id").and_then(Value::as_str) {
            outcomes.push((id.to_string(), outcome(endpoint, &line, model)));
        }
    }
    Ok(outcomes)
}

/// GETs `url` with the provider's headers (`authorised`) and reads the
/// JSON answer.
async fn get_json(
    endpoint: &HttpEndpoint,
    url: &str,
    authorised: fn(&HttpEndpoint, reqwest::RequestBuilder) -> reqwest::RequestBuilder,
    cancel: &CancellationToken,
) -> Result<Value, AgentError> {
    let get = || authorised(endpoint, endpoint.client.get(url));
    let response = endpoint.send(get, cancel).await?;
    endpoint.read_json(response, cancel).await
}

/// The string `field` of a provider's answer about `what`.
fn string_field(
    endpoint: &HttpEndpoint,
    value: &Value,
    field: &str,
    what: &str,
) -> Result<String, AgentError> {
    value
        .get(field)
        .and_then(Value::as_str)
        .map(str::to_string)
        .ok_or_else(|| endpoint.invalid(format!("no `{field}` in the answer about {what}")))
}

/// One of a batch's `request_counts` (0 when absent).
fn request_count(value: &Value, field: &str) -> u64 {
    value
        .pointer(&format!("/request_counts/{field}"))
        .and_then(Value::as_u64)
        .unwrap_or(0)
}

/// Checks a poll interval in seconds against [`POLL_BOUNDS`].
pub fn poll_interval(seconds: f64) -> Result<Duration, PollIntervalError> {
    let (low, high) = POLL_BOUNDS;
    Duration::try_from_secs_f64(seconds)
        .ok()
        .filter(|wait| (low..=high).contains(wait))
        .ok_or(PollIntervalError(seconds))
}

/// A poll interval outside [`POLL_BOUNDS`]: polling faster spends the
/// provider's rate limit, slower leaves finished results waiting.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("poll interval {0} s: give between {low} and {high} seconds", low = POLL_BOUNDS.0.as_secs_f64(), high = POLL_BOUNDS.1.as_secs_f64())]
pub struct PollIntervalError(pub f64);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::provider::ChatRequest;

    fn pending(key: usize, user: &str) -> PendingRequest {
        PendingRequest {
            role: AgentRole::Single,
            provider: ProviderKind::Openai,
            key: format!("k{key}"),
            request: ChatRequest {
                model: "m".into(),
                system: String::new(),
                user: user.into(),
                images: Vec::new(),
                temperature: 0.0,
                max_tokens: 10,
                stream: false,
                json_schema: None,
            },
            free: false,
        }
    }

    #[test]
    fn batches_are_cut_by_count_and_by_size() {
        let many: Vec<PendingRequest> = (0..MAX_BATCH_REQUESTS + 1)
            .map(|i| pending(i, "x"))
            .collect();
        let sizes: Vec<usize> = chunks(&many).iter().map(Vec::len).collect();
        assert_eq!(sizes, [MAX_BATCH_REQUESTS, 1]);
        let big = "y".repeat(MAX_BATCH_BYTES / 2 + 1);
        let large = [pending(1, &big), pending(2, &big), pending(3, "z")];
        let sizes: Vec<usize> = chunks(&large).iter().map(Vec::len).collect();
        assert_eq!(sizes, [1, 2]);
    }

    #[test]
    fn poll_intervals_are_bounded_and_saved_ids_checked() {
        assert_eq!(poll_interval(0.5), Ok(Duration::from_millis(500)));
        for bad in [0.0, 0.001, 601.0, f64::NAN, -1.0] {
            assert!(poll_interval(bad).is_err(), "{bad}");
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("batches.json");
        assert_eq!(SavedBatches::load(&path).unwrap(), SavedBatches::default());
        std::fs::write(&path, "{not json").unwrap();
        let err = SavedBatches::load(&path).unwrap_err().to_string();
        assert!(
            err.contains("batches.json") && err.contains("move it away"),
            "{err}"
        );
    }
}
