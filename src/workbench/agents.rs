//! The seam between the workbench and the agents: what a run asks for (its
//! events are the agents' own [`AgentEvent`]s), and [`AgentsPipeline`], which runs
//! a request with [`crate::agents::pipeline::Runner`]: live providers from
//! the config file and the environment, the response cache, and the demo's
//! recording for the agents set to [`ProviderKind::Replay`].

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use tokio::sync::mpsc::{self, UnboundedSender};
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

use crate::agents::cache::ResponseCache;
use crate::agents::config::{
    AgentLayer, AgentSettings, ConfigError, ConfigFile, FlagLayers, Settings,
};
use crate::agents::cost::{estimate_plans, Billing, Estimate, PriceTable};
use crate::agents::pipeline::{AgentEvent, PlanInput, Runner, Source};
use crate::agents::prompts::{template_name, PromptSet, Template};
use crate::agents::replay::{Pace, Recording};
use crate::agents::{AgentError, AgentRole, Approach, ProviderKind, DEMO_MODEL};
use crate::demo;
use crate::fsutil::write_atomic;

/// Why a run cannot start, or stopped before its agents could report: the
/// words the status bar shows, each saying what to do.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// An agent set to the demo's recording has no recorded answer.
    #[error(
        "{why}: {agent} needs a provider. Press m to set {agent}'s provider and model \
         (e.g. openai, gpt-4o) and export the provider's API key (e.g. {example_key}) before starting mapvlm"
    )]
    ProviderNeeded {
        /// The agent, as the workbench names it.
        agent: &'static str,
        /// Why the recording cannot answer.
        why: String,
        /// The key variable named as an example.
        example_key: &'static str,
    },
    /// A live provider has no API key and would be sent to its public endpoint.
    #[error(
        "{agent} uses {provider} but no API key is set: export {key_var} before starting mapvlm, \
         or set api_key under [agents.{section}] or [defaults] in {file} (a local server: set {url_var})"
    )]
    KeyNeeded {
        /// The agent, as the workbench names it.
        agent: &'static str,
        /// The provider's name.
        provider: &'static str,
        /// The variable holding the provider's key.
        key_var: &'static str,
        /// The variable holding the provider's base URL.
        url_var: &'static str,
        /// The agent's section in the config file.
        section: &'static str,
        /// The config file, as named to the user.
        file: String,
    },
    /// A `replay` agent was asked for more than one sample.
    #[error(
        "{agent} answers from the demo's recording, which holds one sample of each answer: \
         press m to give {agent} a provider to ask {samples} samples of, or press S until samples is 1"
    )]
    OneRecordedSample {
        /// The agent, as the workbench names it.
        agent: &'static str,
        /// The samples asked for.
        samples: u32,
    },
    /// The config file and the environment do not make settings.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A template did not parse, or a file could not be written.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The templates built into the binary did not load.
    #[error("the built-in prompt templates cannot be read; this is a bug")]
    BuiltInPrompts,
    /// The recording built into the binary did not parse.
    #[error("the demo's recording cannot be read ({0}); this is a bug")]
    Recording(#[source] serde_json::Error),
    /// The demo's scene could not be made into a PNG.
    #[error("the demo's scene cannot be encoded ({0})")]
    DemoScene(#[source] image::ImageError),
    /// No runtime could be made for a headless run.
    #[error("no runtime for the run ({0})")]
    Runtime(#[source] std::io::Error),
    /// The run's task ended abnormally.
    #[error("the run stopped ({0})")]
    Stopped(#[source] tokio::task::JoinError),
}

/// Everything a pipeline needs to run the agents of one approach.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRequest {
    /// The run's id; every event is sent with it.
    pub run: u64,
    /// The approach.
    pub approach: Approach,
    /// The task text.
    pub task: String,
    /// The agents whose inputs changed; the others' answers are expected
    /// from the response cache or the recording.
    pub agents: Vec<AgentRole>,
    /// The prompt template text of every agent of the approach.
    pub prompts: BTreeMap<AgentRole, String>,
    /// The settings of every agent of the approach.
    pub settings: BTreeMap<AgentRole, AgentSettings>,
    /// Whether the task is the built-in demo (its scene is drawn, not read).
    pub demo: bool,
    /// The scene image, when the task has one.
    pub image: Option<PathBuf>,
    /// The environment table, when the task has one.
    pub table: Option<PathBuf>,
    /// How many samples each agent is asked for: the first streams its
    /// events, each later one comes whole as an [`AgentEvent::Sampled`].
    pub samples: u32,
    /// Whether every agent is asked afresh, the response cache not read
    /// (its new answers replace the cached ones): `R`.
    pub fresh: bool,
}

/// Runs agents in the background and reports [`AgentEvent`]s.
pub trait Pipeline: Send + Sync {
    /// Why the request cannot run, in words a user can act on; when it can,
    /// the settings each agent of its approach will run with, as
    /// [`crate::agents::config`] resolves them (the keys left out): what
    /// the workbench shows and keeps.
    fn check(&self, request: &RunRequest) -> Result<BTreeMap<AgentRole, AgentSettings>, RunError>;
    /// Starts the run on the current tokio runtime; aborting the handle
    /// cancels it.
    fn spawn(
        &self,
        request: RunRequest,
        events: UnboundedSender<(u64, AgentEvent)>,
    ) -> JoinHandle<()>;
    /// A job that prices `request` with `prices` before anything is sent
    /// (what `R` says before it asks every agent afresh): it reads the
    /// scene, so the carrier runs it off the loop.
    fn estimate(&self, request: &RunRequest, prices: &PriceTable) -> EstimateJob;
}

/// The pricing of a run, to be run off the loop (see [`Pipeline::estimate`]).
pub type EstimateJob = Box<dyn FnOnce() -> Result<Estimate, RunError> + Send>;

/// What a run of a request is made of: its settings and prompts (resolved
/// on the loop), the cache and the demo's answers; turned into a runner and
/// its input off the loop, since the demo's scene is a file. A run and its
/// estimate are made of the same parts, so the estimate prices what is sent.
struct RunParts {
    settings: Settings,
    prompts: PromptSet,
    cache: Option<ResponseCache>,
    answers: (Arc<Recording>, Pace),
}

impl RunParts {
    /// The runner of `request` (fresh when it asks every agent afresh) and
    /// the task, scene and table it plans from.
    fn runner(self, request: &RunRequest) -> Result<(Runner, PlanInput), RunError> {
        let image = match (request.demo, request.approach.uses_image()) {
            (true, true) => Some(demo_scene_file()?),
            _ => request.image.clone(),
        };
        let mut runner = Runner::new(self.settings, self.prompts, Source::Live)
            .with_answers(self.answers.0, self.answers.1);
        if let Some(cache) = self.cache {
            runner = runner.with_cache(cache);
        }
        if request.fresh {
            runner = runner.fresh();
        }
        let input = PlanInput {
            task: request.task.clone(),
            image,
            table: request.table.clone(),
        };
        Ok((runner, input))
    }
}

/// How many of a run's later samples are asked for at once, beside the
/// first (as `--concurrency` defaults to in `plan` and `eval`).
const LATER_SAMPLES_AT_ONCE: usize = 3;

/// The text of every template of `set`, by template name, as the prompt
/// editor shows it.
pub fn prompt_texts(set: &PromptSet) -> BTreeMap<String, String> {
    set.iter().map(|t| (t.name.clone(), t.text())).collect()
}

fn built_in_prompts() -> Option<&'static PromptSet> {
    static BUILT_IN: OnceLock<Option<PromptSet>> = OnceLock::new();
    BUILT_IN.get_or_init(|| PromptSet::load(None).ok()).as_ref()
}

/// Whether the demo's recording has an answer for `role` with the template
/// `text` in `approach`: the recording was made with the built-in templates
/// of the multi-image approach.
pub fn is_recorded_prompt(approach: Approach, role: AgentRole, text: &str) -> bool {
    let name = template_name(approach, role);
    let recorded = built_in_prompts().and_then(|set| set.get(approach, role).ok());
    let edited = Template::parse(&name, "the workbench", text).ok();
    approach == Approach::MultiImage
        && matches!((recorded, edited), (Some(r), Some(e)) if r.system == e.system && r.user == e.user)
}

/// The demo's recording.
pub fn demo_recording() -> Result<Recording, RunError> {
    serde_json::from_str(demo::RECORDING).map_err(RunError::Recording)
}

/// What a user must do to run an agent for real.
pub fn provider_needed(agent: AgentRole, why: &str) -> RunError {
    RunError::ProviderNeeded {
        agent: agent.label(),
        why: why.to_string(),
        example_key: ProviderKind::Openai.key_variable().unwrap_or_default(),
    }
}

fn key_needed(
    role: AgentRole,
    provider: ProviderKind,
    (key_var, url_var): (&'static str, &'static str),
    config_path: Option<&PathBuf>,
) -> RunError {
    RunError::KeyNeeded {
        agent: role.label(),
        provider: provider.name(),
        key_var,
        url_var,
        section: role.name(),
        file: config_path.map_or_else(
            || "the config file".to_string(),
            |p| p.display().to_string(),
        ),
    }
}

/// Reads an environment variable.
pub type EnvReader = Box<dyn Fn(&str) -> Option<String> + Send + Sync>;

/// Where the live agents' provider settings come from: the config file and
/// the environment, read when the workbench starts.
pub struct ProviderConfig {
    /// The config file's contents.
    pub file: ConfigFile,
    /// The config file's path, named in messages.
    pub path: Option<PathBuf>,
    /// The environment variables (API keys and base URLs).
    pub env: EnvReader,
}

impl ProviderConfig {
    /// The settings each configured agent starts with on a user's task:
    /// what the config file and the environment resolve for it (the key
    /// left out). An agent is configured when the config file
    /// names a provider, base URL or model under `[agents.ROLE]` or
    /// `[defaults]`, or when its provider's key or base-URL variable (e.g.
    /// `OPENAI_API_KEY`, `OPENAI_BASE_URL`) is set; the others are left out
    /// and start on the demo's recording.
    pub fn configured_agents(&self) -> Result<BTreeMap<AgentRole, AgentSettings>, ConfigError> {
        let settings = Settings::resolve(&self.file, &*self.env, &FlagLayers::default())?;
        let names = |layer: Option<&AgentLayer>| {
            layer.is_some_and(|l| l.provider.is_some() || l.base_url.is_some() || l.model.is_some())
        };
        let set = |name: &str| (self.env)(name).is_some_and(|v| !v.trim().is_empty());
        Ok(settings
            .agents
            .iter()
            .filter(|(role, agent)| {
                names(self.file.agents.get(role.name()))
                    || names(Some(&self.file.defaults))
                    || agent.provider.key_variable().is_some_and(set)
                    || agent.provider.base_url_variable().is_some_and(set)
            })
            .map(|(&role, agent)| (role, agent.without_key()))
            .collect())
    }
}

/// A [`Pipeline`] over the real agents: each run gets settings from the
/// request's provider, model, temperature and token limit on top of the
/// config file and the environment (keys never come from the session), the
/// request's prompt templates, the response cache (unchanged agents cost
/// nothing) and the demo's recording for the `replay` agents.
pub struct AgentsPipeline {
    config: ProviderConfig,
    cache: Option<ResponseCache>,
    demo: Arc<Recording>,
    pace: Pace,
}

impl AgentsPipeline {
    /// A pipeline reading providers from `config`, caching in `cache`, and
    /// replaying the demo at `pace`.
    pub fn new(
        config: ProviderConfig,
        cache: Option<ResponseCache>,
        pace: Pace,
    ) -> Result<Self, RunError> {
        Ok(Self {
            config,
            cache,
            demo: Arc::new(demo_recording()?),
            pace,
        })
    }

    /// The demo alone: no config file, no environment, no cache; agents set
    /// to a live provider are refused for want of a key.
    pub fn offline(pace: Pace) -> Result<Self, RunError> {
        Self::new(
            ProviderConfig {
                file: ConfigFile::default(),
                path: None,
                env: Box::new(|_| None),
            },
            None,
            pace,
        )
    }

    fn is_replay(request: &RunRequest, role: AgentRole) -> bool {
        request
            .settings
            .get(&role)
            .is_none_or(|s| s.provider == ProviderKind::Replay)
    }

    /// The request's provider, model, temperature and token limit on top of
    /// the config file and the environment.
    fn settings(&self, request: &RunRequest) -> Result<Settings, RunError> {
        let mut flags = FlagLayers::default();
        for (&role, chosen) in &request.settings {
            flags.per_agent.insert(
                role,
                AgentLayer {
                    provider: Some(chosen.provider),
                    model: Some(chosen.model.clone()),
                    temperature: Some(f64::from(chosen.temperature)),
                    max_tokens: Some(chosen.max_tokens),
                    ..AgentLayer::default()
                },
            );
        }
        Ok(Settings::resolve(
            &self.config.file,
            &*self.config.env,
            &flags,
        )?)
    }

    fn prompts(request: &RunRequest) -> Result<PromptSet, RunError> {
        let mut set = built_in_prompts()
            .cloned()
            .ok_or(RunError::BuiltInPrompts)?;
        for (&role, text) in &request.prompts {
            let name = template_name(request.approach, role);
            let template = Template::parse(&name, "the workbench", text)?;
            set = set.with(template);
        }
        Ok(set)
    }

    /// The parts of a run of `request`, resolved now (see [`RunParts`]).
    fn parts(&self, request: &RunRequest) -> Result<RunParts, RunError> {
        Ok(RunParts {
            settings: self.settings(request)?,
            prompts: Self::prompts(request)?,
            cache: self.cache.clone(),
            answers: (self.demo.clone(), self.pace),
        })
    }

    fn check_replay(request: &RunRequest, role: AgentRole) -> Result<(), RunError> {
        let why = if !request.demo {
            "the replay provider only has the demo's recording, not this task".to_string()
        } else if request.approach != Approach::MultiImage {
            format!(
                "the demo was recorded with the multi-image approach, not {}",
                request.approach
            )
        } else if !request
            .settings
            .get(&role)
            .is_some_and(AgentSettings::is_demo_recording)
        {
            format!(
                "the demo was recorded with {DEMO_MODEL}, temperature 0 and 1024 tokens, not {}'s settings",
                role.label()
            )
        } else if !request
            .prompts
            .get(&role)
            .is_some_and(|text| is_recorded_prompt(request.approach, role, text))
        {
            format!(
                "{}'s prompt was edited and the demo's recording has no answer for it",
                role.label()
            )
        } else if role == AgentRole::Planner
            && [AgentRole::Skm, AgentRole::Gkm]
                .iter()
                .any(|&miner| !Self::is_replay(request, miner))
        {
            "the planner reads SKM and GKM, which no longer come from the demo's recording"
                .to_string()
        } else {
            return Ok(());
        };
        Err(provider_needed(role, &why))
    }
}

impl Pipeline for AgentsPipeline {
    fn check(&self, request: &RunRequest) -> Result<BTreeMap<AgentRole, AgentSettings>, RunError> {
        Self::prompts(request)?;
        let settings = self.settings(request)?;
        let mut resolved = BTreeMap::new();
        for &role in request.approach.roles() {
            let agent = settings.agent(role);
            resolved.insert(role, agent.without_key());
            if Self::is_replay(request, role) {
                Self::check_replay(request, role)?;
                if request.samples > 1 {
                    return Err(RunError::OneRecordedSample {
                        agent: role.label(),
                        samples: request.samples,
                    });
                }
                continue;
            }
            let variables = agent
                .provider
                .key_variable()
                .zip(agent.provider.base_url_variable());
            if let Some(variables) = variables.filter(|_| {
                agent.api_key.is_none()
                    && agent.base_url.trim_end_matches('/') == agent.provider.default_base_url()
            }) {
                return Err(key_needed(
                    role,
                    agent.provider,
                    variables,
                    self.config.path.as_ref(),
                ));
            }
        }
        Ok(resolved)
    }

    fn spawn(
        &self,
        request: RunRequest,
        events: UnboundedSender<(u64, AgentEvent)>,
    ) -> JoinHandle<()> {
        let prepared = self.parts(&request);
        tokio::spawn(async move {
            let run = request.run;
            let first = request.approach.roles()[0];
            let fail = |error: RunError| {
                let _ = events.send((
                    run,
                    AgentEvent::Failed {
                        role: first,
                        error: error.to_string(),
                        elapsed_ms: 0,
                    },
                ));
            };
            let (runner, input) = match prepared.and_then(|parts| parts.runner(&request)) {
                Ok(made) => made,
                Err(error) => return fail(error),
            };
            let cancel = CancellationToken::new();
            let _cancel_on_abort = cancel.clone().drop_guard();
            let (tx, mut rx) = mpsc::unbounded_channel();
            let (approach, samples) = (request.approach, request.samples);
            let plan = async move {
                let (drained, mut ignored) = mpsc::unbounded_channel();
                let drain = async move { while ignored.recv().await.is_some() {} };
                let later = async {
                    let records = runner
                        .plan_samples(
                            approach,
                            &input,
                            1..samples,
                            LATER_SAMPLES_AT_ONCE,
                            &drained,
                            &cancel,
                        )
                        .await;
                    drop(drained);
                    records
                };
                let first = runner.plan(approach, &input, &tx, &cancel);
                let (result, later, ()) = tokio::join!(first, later, drain);
                for record in later.into_iter().flatten() {
                    let _ = tx.send(AgentEvent::Sampled {
                        record: Box::new(record),
                    });
                }
                drop(tx);
                result
            };
            let forward = async {
                while let Some(event) = rx.recv().await {
                    let event = explain_replay_failure(event, &request);
                    if events.send((run, event)).is_err() {
                        return;
                    }
                }
            };
            let (result, ()) = tokio::join!(plan, forward);
            if let Err(error) = result {
                fail(error.into());
            }
        })
    }

    fn estimate(&self, request: &RunRequest, prices: &PriceTable) -> EstimateJob {
        let prepared = self.parts(request);
        let (request, prices) = (request.clone(), prices.clone());
        Box::new(move || {
            let (runner, input) = prepared?.runner(&request)?;
            let plans = (0..request.samples).map(|sample| (request.approach, &input, sample));
            Ok(estimate_plans(
                &runner,
                plans,
                Billing::Interactive,
                &prices,
            ))
        })
    }
}

/// Checks and runs `request` to its end on a runtime of its own, returning
/// the settings its agents ran with ([`Pipeline::check`]) and its events in
/// order: for headless use, tests and benchmarks.
pub fn run_blocking(
    pipeline: &dyn Pipeline,
    request: RunRequest,
) -> Result<(BTreeMap<AgentRole, AgentSettings>, Vec<AgentEvent>), RunError> {
    let settings = pipeline.check(&request)?;
    Ok((settings, run_events(pipeline, request)?))
}

/// Runs a request the pipeline accepted to its end on the calling thread:
/// every event of the run, in order.
pub fn run_events(
    pipeline: &dyn Pipeline,
    request: RunRequest,
) -> Result<Vec<AgentEvent>, RunError> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(RunError::Runtime)?;
    let (tx, mut rx) = mpsc::unbounded_channel();
    runtime
        .block_on(async { pipeline.spawn(request, tx).await })
        .map_err(RunError::Stopped)?;
    let mut events = Vec::new();
    while let Ok((_, event)) = rx.try_recv() {
        events.push(event);
    }
    Ok(events)
}

/// Puts what a user must do in the place of a `replay` agent's failure:
/// the demo's recording has no answer for the request.
fn explain_replay_failure(event: AgentEvent, request: &RunRequest) -> AgentEvent {
    match event {
        AgentEvent::Failed {
            role, elapsed_ms, ..
        } if AgentsPipeline::is_replay(request, role) => AgentEvent::Failed {
            role,
            elapsed_ms,
            error: provider_needed(role, "the demo's recording has no answer for this request")
                .to_string(),
        },
        other => other,
    }
}

/// Writes the demo's scene to a PNG file in the temporary folder, where the
/// agents read it, and returns its path.
pub fn demo_scene_file() -> Result<PathBuf, RunError> {
    let bytes = demo::scene_png().map_err(RunError::DemoScene)?;
    let path = std::env::temp_dir().join("mapvlm-demo-scene.png");
    write_atomic(&path, &bytes).map_err(AgentError::from)?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn configured(toml: &str, env: &[(&'static str, &'static str)]) -> Vec<(AgentRole, String)> {
        let env: Vec<(&'static str, &'static str)> = env.to_vec();
        let config = ProviderConfig {
            file: toml::from_str(toml).unwrap(),
            path: None,
            env: Box::new(move |name| {
                env.iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| v.to_string())
            }),
        };
        let agents = config.configured_agents().unwrap();
        agents
            .into_iter()
            .map(|(role, s)| (role, format!("{}/{}", s.provider, s.model)))
            .collect()
    }

    #[test]
    fn an_agent_is_configured_by_the_file_or_its_providers_variables_and_only_so() {
        use AgentRole::*;
        assert_eq!(configured("", &[]), []);
        assert_eq!(
            configured("max_retries = 2\n[defaults]\ntemperature = 0.5", &[]),
            [],
            "sampling settings alone name no provider"
        );
        assert_eq!(
            configured("", &[("ANTHROPIC_API_KEY", "k")]),
            [],
            "the agents default to openai, whose key is not set"
        );
        let all = |p: &str| AgentRole::ALL.map(|r| (r, p.to_string())).to_vec();
        assert_eq!(
            configured("", &[("OPENAI_API_KEY", "k")]),
            all("openai/gpt-4o")
        );
        assert_eq!(
            configured("", &[("OPENAI_BASE_URL", "http://127.0.0.1:1/v1")]),
            all("openai/gpt-4o")
        );
        assert_eq!(
            configured("[defaults]\nmodel = \"m\"", &[]),
            all("openai/m")
        );
        assert_eq!(
            configured(
                "[agents.planner]\nprovider = \"anthropic\"",
                &[("OPENAI_API_KEY", "")]
            ),
            [(Planner, "anthropic/claude-sonnet-4-5".to_string())]
        );
        assert_eq!(
            configured(
                "[agents.gkm]\nbase_url = \"http://127.0.0.1:1/v1\"\nmodel = \"local\"",
                &[]
            ),
            [(Gkm, "openai/local".to_string())]
        );
    }
}
