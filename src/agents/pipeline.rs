//! Running an approach: the agents it needs, in the order it needs them (SKM
//! and GKM concurrently, the Planner after both), each streaming its output
//! as events, answers taken from the cache when unchanged, and everything
//! gathered in one record.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use tokio::sync::mpsc::UnboundedSender;
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;

use super::anthropic::Anthropic;
use super::cache::{request_key, sample_key, CachedAnswer, ResponseCache};
use super::config::{AgentSettings, Settings};
use super::graph::{parse_triples, triples_schema, KnowledgeGraph, ParsedTriples};
use super::images::prepare_image;
use super::openai::OpenAi;
use super::prompts::{render_table, PromptSet};
use super::provider::{
    elapsed_ms, ChatRequest, Completion, ImageInput, Notifier, RetryNotice, SharedProvider,
};
use super::replay::{Pace, Recording, ReplayProvider};
use super::{AgentError, AgentRole, Approach, ProviderKind, Usage};
use crate::plan::{bounded_steps, not_a_plan};

/// What happened to an agent, for a front end to show live.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum AgentEvent {
    /// The agent sent its request.
    Started {
        /// Which agent.
        role: AgentRole,
    },
    /// A piece of the answer arrived.
    Token {
        /// Which agent.
        role: AgentRole,
        /// The text.
        text: String,
    },
    /// A later sample of the run is complete: the workbench asks for
    /// samples after the first without streaming their agents' events, and
    /// gets each whole record here.
    Sampled {
        /// The sample's run.
        record: Box<PlanRecord>,
    },
    /// The answer is complete.
    Finished {
        /// Which agent.
        role: AgentRole,
        /// Token counts.
        usage: Usage,
        /// Milliseconds from start to finish.
        elapsed_ms: u64,
        /// Whether it came from the cache.
        cached: bool,
    },
    /// The agent's provider waits before retrying a 429 or 5xx answer.
    Retrying {
        /// Which agent.
        role: AgentRole,
        /// The wait, its reason and which retry it is before.
        notice: RetryNotice,
    },
    /// The agent ended with an error.
    Failed {
        /// Which agent.
        role: AgentRole,
        /// What went wrong, in one line.
        error: String,
        /// Milliseconds from its request to the failure (0 when no request
        /// was sent), so a failed call counts its own time, never another's.
        #[serde(default)]
        elapsed_ms: u64,
    },
}

/// Where agents' events go.
pub type EventSender = UnboundedSender<AgentEvent>;

/// What a plan is made from.
#[derive(Debug, Clone, Default)]
pub struct PlanInput {
    /// The goal in natural language.
    pub task: String,
    /// The scene image (image approaches).
    pub image: Option<PathBuf>,
    /// The G-PlanET table (table approaches).
    pub table: Option<PathBuf>,
}

/// One agent's part of a run: kept in `plan` and `eval` records and in the
/// workbench's run history alike.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentRecord {
    /// Which agent.
    pub role: AgentRole,
    /// The settings it ran with (never the API key), written beside the
    /// other fields (`provider`, `model`, `temperature`…).
    #[serde(flatten)]
    pub settings: AgentSettings,
    /// The prompt template's name.
    pub prompt: String,
    /// The template's content hash: which version of the prompt ran.
    pub prompt_hash: String,
    /// The request's cache key (empty when the run does not know it).
    pub request_key: String,
    /// The raw answer, when it succeeded (possibly partial when the run
    /// was cancelled).
    pub output: Option<String>,
    /// Why it failed, when it did.
    pub error: Option<String>,
    /// Token counts.
    pub usage: Usage,
    /// Milliseconds from start to finish.
    pub elapsed_ms: u64,
    /// Whether the answer cost nothing: it came from the response cache or
    /// from a recording.
    pub cached: bool,
}

impl AgentRecord {
    /// The record of `role` before it has run: `settings` (the key left
    /// out) and the template named `prompt` with content hash `prompt_hash`.
    pub fn blank(
        role: AgentRole,
        settings: &AgentSettings,
        prompt: &str,
        prompt_hash: &str,
    ) -> Self {
        Self {
            role,
            settings: settings.for_record(),
            prompt: prompt.to_string(),
            prompt_hash: prompt_hash.to_string(),
            request_key: String::new(),
            output: None,
            error: None,
            usage: Usage::default(),
            elapsed_ms: 0,
            cached: false,
        }
    }

    /// What it wrote, or nothing.
    pub fn output_text(&self) -> &str {
        self.output.as_deref().unwrap_or_default()
    }
}

/// Everything a run produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanRecord {
    /// The approach.
    pub approach: Approach,
    /// The task.
    pub task: String,
    /// The image, if the approach used one.
    pub image: Option<PathBuf>,
    /// SHA-256 of the image bytes sent.
    pub image_sha256: Option<String>,
    /// The table, if the approach used one.
    pub table: Option<PathBuf>,
    /// Each agent, in the order they started.
    pub agents: Vec<AgentRecord>,
    /// SKM's triples (multi-agent approaches).
    pub triples: Option<ParsedTriples>,
    /// The knowledge graph of the triples.
    pub graph: Option<KnowledgeGraph>,
    /// The plan's steps (empty when the planning agent failed).
    pub steps: Vec<String>,
    /// Token counts over all agents.
    pub usage: Usage,
    /// Milliseconds for the whole run.
    pub elapsed_ms: u64,
    /// Which sample of the request this run is (0 for the first, the only
    /// one of a run without `--samples`; left out of the JSON then, so
    /// records of one sample read as before).
    #[serde(default, skip_serializing_if = "is_first_sample")]
    pub sample: u32,
}

/// The most samples of one plan a run may ask for (`--samples`): enough for
/// a spread, bounded so that a typo cannot send thousands of requests.
pub const MAX_SAMPLES: u32 = 100;

/// Whether `sample` is the first sample: records leave the index out then
/// (a serde `skip_serializing_if`), so files of one sample read as before.
pub fn is_first_sample(sample: &u32) -> bool {
    *sample == 0
}

impl PlanRecord {
    /// The first agent error, if any agent failed.
    pub fn first_error(&self) -> Option<(AgentRole, &str)> {
        self.agents
            .iter()
            .find_map(|a| a.error.as_deref().map(|e| (a.role, e)))
    }
}

/// A request an approach will send, known before it is sent.
#[derive(Debug, Clone)]
pub struct PendingRequest {
    /// The agent sending it.
    pub role: AgentRole,
    /// Its provider.
    pub provider: ProviderKind,
    /// Its cache key (the `custom_id` of a provider batch).
    pub key: String,
    /// The request.
    pub request: ChatRequest,
    /// Whether its answer costs nothing (cached or recorded).
    pub free: bool,
}

/// What an approach can send next (see [`Runner::next_stage`]).
#[derive(Debug, Clone)]
pub struct Stage {
    /// The requests whose prompts are known now.
    pub requests: Vec<PendingRequest>,
    /// The Planner, while its prompt waits on the miners: its provider,
    /// model and a rough upper bound of its tokens.
    pub planner_later: Option<(ProviderKind, String, Usage)>,
}

/// Where answers come from.
#[derive(Debug, Clone)]
pub enum Source {
    /// The providers the settings name.
    Live,
    /// A recording, at the given pace.
    Replay(Arc<Recording>, Pace),
}

/// Runs approaches with one set of settings and prompts.
#[derive(Debug, Clone)]
pub struct Runner {
    settings: Settings,
    prompts: PromptSet,
    source: Source,
    cache: Option<ResponseCache>,
    recorder: Option<Arc<Mutex<Recording>>>,
    answers: Option<(Arc<Recording>, Pace)>,
    images: Arc<Mutex<HashMap<PathBuf, ImageInput>>>,
    fresh: bool,
    token_events: bool,
}

/// The encoded bytes of prepared images a runner keeps (see
/// [`Runner::image`]); past this it starts afresh, so memory stays bounded
/// however many tasks one runner plans.
const PREPARED_IMAGE_BYTES: usize = 256 << 20;

struct Prepared<'a> {
    approach: Approach,
    sample: u32,
    values: BTreeMap<&'a str, String>,
    images: Vec<ImageInput>,
}

impl Runner {
    /// A runner with no cache and no recorder.
    pub fn new(settings: Settings, prompts: PromptSet, source: Source) -> Self {
        Self {
            settings,
            prompts,
            source,
            cache: None,
            recorder: None,
            answers: None,
            images: Arc::default(),
            fresh: false,
            token_events: true,
        }
    }

    /// Sends no [`AgentEvent::Token`]: for a caller that shows no text as
    /// it streams (`plan`, `eval`), so a copy of every piece does not wait
    /// in the event queue for a reader that drops it (an endless stream
    /// once held two copies of the answer there under load).
    pub fn without_token_events(mut self) -> Self {
        self.token_events = false;
        self
    }

    /// Reads and writes answers in `cache` (ignored when replaying).
    pub fn with_cache(mut self, cache: ResponseCache) -> Self {
        self.cache = Some(cache);
        self
    }

    /// Serves the requests `recording` has answers for from it, at `pace`,
    /// before asking a provider (the answers are not cached): a demo's
    /// recorded agents can run beside live ones.
    pub fn with_answers(mut self, recording: Arc<Recording>, pace: Pace) -> Self {
        self.answers = Some((recording, pace));
        self
    }

    /// Asks every provider afresh: the response cache is not read, and the
    /// new answers replace the cached ones (the workbench's `R`).
    pub fn fresh(mut self) -> Self {
        self.fresh = true;
        self
    }

    /// Adds every answer received to `recording`.
    pub fn with_recorder(mut self, recording: Arc<Mutex<Recording>>) -> Self {
        self.recorder = Some(recording);
        self
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Makes a plan for `input` with `approach`: its first sample (see
    /// [`Runner::plan_sample`]).
    pub async fn plan(
        &self,
        approach: Approach,
        input: &PlanInput,
        events: &EventSender,
        cancel: &CancellationToken,
    ) -> Result<PlanRecord, AgentError> {
        self.plan_sample(approach, input, 0, events, cancel).await
    }

    /// Makes the samples `samples` (e.g. `0..3`) of the plan for `input`,
    /// at most `concurrency` at once; each sample's events come tagged with
    /// its index. The records come in sample order.
    pub async fn plan_samples(
        &self,
        approach: Approach,
        input: &PlanInput,
        samples: std::ops::Range<u32>,
        concurrency: usize,
        events: &UnboundedSender<(u32, AgentEvent)>,
        cancel: &CancellationToken,
    ) -> Result<Vec<PlanRecord>, AgentError> {
        let limit = Semaphore::new(concurrency.max(1));
        let runs = samples.map(|sample| {
            let limit = &limit;
            async move {
                let _permit = limit.acquire().await;
                let (tagged, mut received) = tokio::sync::mpsc::unbounded_channel();
                let plan = async move {
                    let record = self
                        .plan_sample(approach, input, sample, &tagged, cancel)
                        .await;
                    drop(tagged);
                    record
                };
                let forward = async {
                    while let Some(event) = received.recv().await {
                        let _ = events.send((sample, event));
                    }
                };
                tokio::join!(plan, forward).0
            }
        });
        futures::future::join_all(runs).await.into_iter().collect()
    }

    /// Makes sample `sample` of the plan for `input` with `approach`: the
    /// same requests as sample 0, cached and recorded under their own keys
    /// (see [`sample_key`]), so that sample k of an unchanged request is
    /// reused and one more sample asks only for that one; the Planner of
    /// sample k reads sample k of SKM and GKM. Bad input (image, table,
    /// prompt) is an error before any request; an agent's failure is kept in
    /// its record, the other agents' results stay intact.
    pub async fn plan_sample(
        &self,
        approach: Approach,
        input: &PlanInput,
        sample: u32,
        events: &EventSender,
        cancel: &CancellationToken,
    ) -> Result<PlanRecord, AgentError> {
        let start = Instant::now();
        let prepared = self.prepare(approach, input, sample)?;
        let mut record = PlanRecord {
            approach,
            task: input.task.clone(),
            image: input.image.clone().filter(|_| approach.uses_image()),
            image_sha256: prepared.images.first().map(|i| i.sha256.clone()),
            table: input.table.clone().filter(|_| !approach.uses_image()),
            agents: Vec::new(),
            triples: None,
            graph: None,
            steps: Vec::new(),
            usage: Usage::default(),
            elapsed_ms: 0,
            sample,
        };
        let mut planner = if approach.is_multi_agent() {
            let (skm, gkm) = tokio::join!(
                self.run_agent(&prepared, AgentRole::Skm, events, cancel),
                self.run_agent(&prepared, AgentRole::Gkm, events, cancel),
            );
            let (values, triples) = planner_values(
                &prepared.values,
                skm.output.as_deref(),
                gkm.output.as_deref(),
            );
            if let Some((parsed, graph)) = triples {
                record.triples = Some(parsed);
                record.graph = Some(graph);
            }
            let failed = [&skm, &gkm]
                .into_iter()
                .find(|a| a.output.is_none())
                .map(|a| a.role);
            record.agents.extend([skm, gkm]);
            match failed {
                Some(role) => self.skipped(AgentRole::Planner, approach, role, events)?,
                None => {
                    let planner = Prepared { values, ..prepared };
                    self.run_agent(&planner, AgentRole::Planner, events, cancel)
                        .await
                }
            }
        } else {
            self.run_agent(&prepared, AgentRole::Single, events, cancel)
                .await
        };
        if let Some(text) = &planner.output {
            match not_a_plan(text) {
                Some(why) if planner.error.is_none() => planner.error = Some(why),
                _ => {
                    let (steps, cut) = bounded_steps(text);
                    if let Some(cut) = cut {
                        tracing::warn!(agent = planner.role.name(), "{cut}");
                    }
                    record.steps = steps;
                }
            }
        }
        record.agents.push(planner);
        record.usage = record.agents.iter().map(|a| &a.usage).sum();
        record.elapsed_ms = elapsed_ms(start);
        Ok(record)
    }

    fn prepare<'a>(
        &self,
        approach: Approach,
        input: &PlanInput,
        sample: u32,
    ) -> Result<Prepared<'a>, AgentError> {
        let mut values = BTreeMap::from([("task", input.task.trim().to_string())]);
        let mut images = Vec::new();
        if approach.uses_image() {
            let path = input
                .image
                .as_deref()
                .ok_or_else(|| missing(approach, "an image (--image FILE)"))?;
            images.push(self.image(path)?);
        } else {
            let path = input
                .table
                .as_deref()
                .ok_or_else(|| missing(approach, "a table (--table FILE)"))?;
            values.insert("table", render_table(path)?);
        }
        for role in approach.roles() {
            self.prompts.get(approach, *role)?;
        }
        Ok(Prepared {
            approach,
            sample,
            values,
            images,
        })
    }

    /// The image at `path` as sent: read, checked, downscaled and encoded
    /// once per runner, so that a task's estimate, each provider-batch round
    /// and its plan do not prepare it again (up to [`PREPARED_IMAGE_BYTES`]
    /// of images are kept).
    fn image(&self, path: &Path) -> Result<ImageInput, AgentError> {
        let mut images = self.images.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(image) = images.get(path) {
            return Ok(image.clone());
        }
        let image = prepare_image(path, self.settings.max_image_edge)?;
        let kept: usize = images.values().map(|i| i.data_base64.len()).sum();
        if kept + image.data_base64.len() > PREPARED_IMAGE_BYTES {
            images.clear();
        }
        images.insert(path.to_path_buf(), image.clone());
        Ok(image)
    }

    fn request(
        &self,
        prepared: &Prepared<'_>,
        role: AgentRole,
    ) -> Result<(ChatRequest, String, String), AgentError> {
        let settings = self.settings.agent(role);
        let template = self.prompts.get(prepared.approach, role)?;
        let (system, user) = template.render(&prepared.values);
        let uses_image = role != AgentRole::Planner;
        let request = ChatRequest {
            model: settings.model.clone(),
            system,
            user,
            images: if uses_image {
                prepared.images.clone()
            } else {
                Vec::new()
            },
            temperature: settings.temperature,
            max_tokens: settings.max_tokens,
            stream: settings.stream,
            json_schema: (role == AgentRole::Skm
                && settings.json_output
                && settings.provider == ProviderKind::Openai)
                .then(triples_schema),
        };
        Ok((request, template.name.clone(), template.hash.clone()))
    }

    fn skipped(
        &self,
        role: AgentRole,
        approach: Approach,
        upstream: AgentRole,
        events: &EventSender,
    ) -> Result<AgentRecord, AgentError> {
        let settings = self.settings.agent(role);
        let template = self.prompts.get(approach, role)?;
        let error = AgentError::Upstream(upstream).to_string();
        let _ = events.send(AgentEvent::Failed {
            role,
            error: error.clone(),
            elapsed_ms: 0,
        });
        Ok(AgentRecord {
            error: Some(error),
            ..AgentRecord::blank(role, settings, &template.name, &template.hash)
        })
    }

    async fn run_agent(
        &self,
        prepared: &Prepared<'_>,
        role: AgentRole,
        events: &EventSender,
        cancel: &CancellationToken,
    ) -> AgentRecord {
        let settings = self.settings.agent(role);
        let (request, prompt, prompt_hash) = match self.request(prepared, role) {
            Ok(parts) => parts,
            Err(err) => {
                let error = err.to_string();
                let _ = events.send(AgentEvent::Failed {
                    role,
                    error: error.clone(),
                    elapsed_ms: 0,
                });
                return AgentRecord {
                    error: Some(error),
                    ..AgentRecord::blank(role, settings, "", "")
                };
            }
        };
        let key = sample_key(request_key(settings.provider, &request), prepared.sample);
        let mut record = AgentRecord {
            request_key: key.clone(),
            ..AgentRecord::blank(role, settings, &prompt, &prompt_hash)
        };
        let start = Instant::now();
        let _ = events.send(AgentEvent::Started { role });
        let sink = |text: &str| {
            if self.token_events {
                let _ = events.send(AgentEvent::Token {
                    role,
                    text: text.to_string(),
                });
            }
        };
        let hit = self.cached(&key);
        let recorded = self
            .answers
            .as_ref()
            .filter(|(recording, _)| hit.is_none() && recording.answers.contains_key(&key));
        let replayed = match &self.source {
            Source::Replay(recording, pace) => Some((recording.clone(), *pace)),
            Source::Live => recorded.map(|(recording, pace)| (recording.clone(), *pace)),
        };
        let result = match hit {
            Some(answer) => {
                record.cached = true;
                for chunk in &answer.completion.chunks {
                    sink(&chunk.text);
                }
                Ok(answer.completion)
            }
            None => match replayed {
                Some((recording, pace)) => {
                    ReplayProvider::new(recording, settings.provider, pace)
                        .replay(&key, prepared.sample, &request, &sink, cancel)
                        .await
                }
                None => match self.provider(settings, role, events) {
                    Ok(provider) => provider.complete(&request, &sink, cancel).await,
                    Err(err) => Err(err),
                },
            },
        };
        record.elapsed_ms = elapsed_ms(start);
        match result {
            Ok(completion) => {
                if !record.cached && recorded.is_none() {
                    self.keep(&key, settings, &completion);
                }
                record.usage = completion.usage;
                record.output = Some(completion.text);
                let _ = events.send(AgentEvent::Finished {
                    role,
                    usage: record.usage,
                    elapsed_ms: record.elapsed_ms,
                    cached: record.cached,
                });
            }
            Err(err) => {
                let mut error = err.to_string();
                if let Some(secret) = &settings.api_key {
                    error = secret.redact(&error);
                }
                tracing::warn!(agent = role.name(), %error, "agent failed");
                let _ = events.send(AgentEvent::Failed {
                    role,
                    error: error.clone(),
                    elapsed_ms: record.elapsed_ms,
                });
                record.error = Some(error);
            }
        }
        record
    }

    /// The cached answer to the request keyed `key` (live runs only, and
    /// none when asking afresh).
    fn cached(&self, key: &str) -> Option<CachedAnswer> {
        self.cache
            .as_ref()
            .filter(|_| matches!(self.source, Source::Live) && !self.fresh)
            .and_then(|c| c.get(key))
    }

    /// The response cache live runs read and write, if any.
    pub fn cache(&self) -> Option<&ResponseCache> {
        self.cache
            .as_ref()
            .filter(|_| matches!(self.source, Source::Live))
    }

    /// Whether the request keyed `key` will cost nothing: its answer is in
    /// the cache or in a recording.
    fn is_free(&self, key: &str) -> bool {
        matches!(self.source, Source::Replay(..))
            || self.cached(key).is_some()
            || self
                .answers
                .as_ref()
                .is_some_and(|(recording, _)| recording.answers.contains_key(key))
    }

    fn pending(
        &self,
        prepared: &Prepared<'_>,
        role: AgentRole,
    ) -> Result<PendingRequest, AgentError> {
        let provider = self.settings.agent(role).provider;
        let (request, _, _) = self.request(prepared, role)?;
        let key = sample_key(request_key(provider, &request), prepared.sample);
        Ok(PendingRequest {
            role,
            provider,
            free: self.is_free(&key),
            key,
            request,
        })
    }

    /// The requests sample `sample` of `approach` can send now for
    /// `input`, before any is sent: the single agent's; or the miners'; or,
    /// once both miners' answers are in the cache, the Planner's. While the
    /// Planner waits on the miners, a rough upper bound of its tokens comes
    /// instead (its prompt without their answers, plus their token limits).
    /// Estimates and provider batches are made from this.
    pub fn next_stage(
        &self,
        approach: Approach,
        input: &PlanInput,
        sample: u32,
    ) -> Result<Stage, AgentError> {
        let prepared = self.prepare(approach, input, sample)?;
        if !approach.is_multi_agent() {
            return Ok(Stage {
                requests: vec![self.pending(&prepared, AgentRole::Single)?],
                planner_later: None,
            });
        }
        let miners = vec![
            self.pending(&prepared, AgentRole::Skm)?,
            self.pending(&prepared, AgentRole::Gkm)?,
        ];
        let answers: Option<Vec<String>> = miners
            .iter()
            .map(|m| self.cached(&m.key).map(|a| a.completion.text))
            .collect();
        if let Some([skm, gkm]) = answers.as_deref() {
            let (values, _) = planner_values(&prepared.values, Some(skm), Some(gkm));
            let planner = Prepared { values, ..prepared };
            return Ok(Stage {
                requests: vec![self.pending(&planner, AgentRole::Planner)?],
                planner_later: None,
            });
        }
        let (blank, _, _) = self.request(&prepared, AgentRole::Planner)?;
        let mut usage = blank.estimated_usage();
        usage.input_tokens += miners
            .iter()
            .map(|m| u64::from(m.request.max_tokens))
            .sum::<u64>();
        let settings = self.settings.agent(AgentRole::Planner);
        Ok(Stage {
            requests: miners,
            planner_later: Some((settings.provider, settings.model.clone(), usage)),
        })
    }

    /// The live provider of an agent: answers from a recording, and every
    /// answer of a [`Source::Replay`] run, are served before one is asked
    /// for, in `run_agent`.
    /// Its waits before retries are told to the notifier of the settings,
    /// if any, and sent as [`AgentEvent::Retrying`] events.
    fn provider(
        &self,
        settings: &AgentSettings,
        role: AgentRole,
        events: &EventSender,
    ) -> Result<SharedProvider, AgentError> {
        let mut http = self.settings.http.clone();
        let (earlier, events) = (http.notify.take(), events.clone());
        http.notify = Some(Notifier(Arc::new(move |notice| {
            if let Some(earlier) = &earlier {
                (earlier.0)(notice);
            }
            let _ = events.send(AgentEvent::Retrying {
                role,
                notice: notice.clone(),
            });
        })));
        let key = settings.api_key.clone();
        Ok(match settings.provider {
            ProviderKind::Openai => Arc::new(OpenAi::new(&settings.base_url, key, http)?),
            ProviderKind::Anthropic => Arc::new(Anthropic::new(&settings.base_url, key, http)?),
            ProviderKind::Replay => {
                let recording = self.answers.as_ref().map_or_else(
                    || Arc::new(Recording::new("no recording")),
                    |(recording, _)| recording.clone(),
                );
                Arc::new(ReplayProvider::new(
                    recording,
                    ProviderKind::Replay,
                    Pace::Instant,
                ))
            }
        })
    }

    fn keep(&self, key: &str, settings: &AgentSettings, completion: &Completion) {
        let answer = CachedAnswer {
            key: key.to_string(),
            provider: settings.provider,
            model: settings.model.clone(),
            completion: completion.clone(),
        };
        if let Some(cache) = self
            .cache
            .as_ref()
            .filter(|_| matches!(self.source, Source::Live))
        {
            if let Err(err) = cache.put(&answer) {
                // Said once a run: a read-only cache fails every answer alike.
                static SAID: std::sync::atomic::AtomicBool =
                    std::sync::atomic::AtomicBool::new(false);
                if !SAID.swap(true, std::sync::atomic::Ordering::Relaxed) {
                    tracing::warn!(
                        "the response cache {} cannot be written ({err}); this run's answers are not kept",
                        cache.dir().display()
                    );
                }
            }
        }
        if let Some(recorder) = &self.recorder {
            if let Ok(mut recording) = recorder.lock() {
                recording.answers.insert(key.to_string(), answer);
            }
        }
    }
}

/// The Planner's prompt values: the task's, plus the miners' answers and
/// SKM's triples as graph lines (its raw answer when no triple parsed); and
/// the parsed triples with their graph.
fn planner_values<'a>(
    values: &BTreeMap<&'a str, String>,
    skm: Option<&str>,
    gkm: Option<&str>,
) -> (
    BTreeMap<&'a str, String>,
    Option<(ParsedTriples, KnowledgeGraph)>,
) {
    let mut values = values.clone();
    let mut triples = None;
    if let Some(text) = skm {
        let parsed = parse_triples(text);
        let graph = KnowledgeGraph::from_triples(&parsed.triples);
        let lines = if graph.edges.is_empty() {
            text.to_string()
        } else {
            graph.to_lines()
        };
        values.insert("skm", text.to_string());
        values.insert("triples", lines);
        triples = Some((parsed, graph));
    }
    if let Some(text) = gkm {
        values.insert("gkm", text.to_string());
    }
    (values, triples)
}

fn missing(approach: Approach, what: &'static str) -> AgentError {
    AgentError::MissingInput { approach, what }
}
