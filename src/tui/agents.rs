//! The seam between the workbench and the agents: what a run asks for, the
//! events a run reports while it streams, and the demo's replay of recorded
//! outputs. A real pipeline implements [`Pipeline`] and sends the same events.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use tokio::sync::mpsc::UnboundedSender;
use tokio::task::JoinHandle;

use crate::demo;
use crate::session::{Agent, AgentSettings, Approach, Usage};

/// What happened to one agent of a run.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentEvent {
    /// The agent was called.
    Started(Agent),
    /// The agent wrote more text.
    Token {
        /// The agent writing.
        agent: Agent,
        /// The new text, to append.
        text: String,
    },
    /// The agent finished.
    Finished {
        /// The agent.
        agent: Agent,
        /// Its whole output.
        output: String,
        /// Its token use.
        usage: Usage,
        /// Its wall time in milliseconds.
        duration_ms: u64,
    },
    /// The agent failed; the run stops.
    Failed {
        /// The agent.
        agent: Agent,
        /// Why, in one line.
        error: String,
    },
}

/// Everything a pipeline needs to run some agents of one approach.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRequest {
    /// The run's id; every event is sent with it.
    pub run: u64,
    /// The approach.
    pub approach: Approach,
    /// The task text.
    pub task: String,
    /// The agents to run, in pipeline order; the others' outputs are in `previous`.
    pub agents: Vec<Agent>,
    /// The prompt of every agent of the approach.
    pub prompts: BTreeMap<Agent, String>,
    /// The settings of every agent of the approach.
    pub settings: BTreeMap<Agent, AgentSettings>,
    /// The latest outputs of the agents that are not re-run.
    pub previous: BTreeMap<Agent, String>,
    /// The scene image, when the task has one.
    pub image: Option<PathBuf>,
    /// The environment table, when the task has one.
    pub table: Option<PathBuf>,
}

/// Runs agents in the background and reports [`AgentEvent`]s.
pub trait Pipeline: Send + Sync {
    /// Why the request cannot run, in words a user can act on; `Ok` when it can.
    fn check(&self, request: &RunRequest) -> Result<(), String>;
    /// Starts the run on the current tokio runtime; aborting the handle
    /// cancels it.
    fn spawn(
        &self,
        request: RunRequest,
        events: UnboundedSender<(u64, AgentEvent)>,
    ) -> JoinHandle<()>;
}

/// The provider name of recorded outputs.
pub const REPLAY_PROVIDER: &str = "replay";

/// The settings the demo's agents start with.
pub fn demo_settings() -> AgentSettings {
    AgentSettings {
        provider: REPLAY_PROVIDER.to_string(),
        model: "demo-recording".to_string(),
        temperature: 0.0,
        max_tokens: 1024,
    }
}

/// The prompt each agent starts with.
pub fn default_prompt(agent: Agent) -> &'static str {
    match agent {
        Agent::Skm => demo::SKM_PROMPT.trim_end(),
        Agent::Gkm => demo::GKM_PROMPT.trim_end(),
        Agent::Planner => demo::PLANNER_PROMPT.trim_end(),
    }
}

/// The demo's recorded output of each agent.
pub fn recorded_output(agent: Agent) -> &'static str {
    match agent {
        Agent::Skm => demo::SKM_OUTPUT,
        Agent::Gkm => demo::GKM_OUTPUT,
        Agent::Planner => demo::PLANNER_OUTPUT,
    }
}

/// What a user must do to run an agent for real.
pub fn provider_needed(agent: Agent, why: &str) -> String {
    format!(
        "{why}: {agent} needs a provider. Press m to set {agent}'s provider and model \
         (e.g. openai, gpt-4o) and export the provider's API key (e.g. OPENAI_API_KEY) before starting mapvlm"
    )
}

/// Replays the demo's recorded outputs, streamed a word at a time: SKM and
/// GKM together, then the planner, as a live run would.
#[derive(Debug, Clone)]
pub struct ReplayPipeline {
    /// The pause between two streamed words.
    pub delay: Duration,
}

impl ReplayPipeline {
    async fn stream(
        agent: Agent,
        run: u64,
        delay: Duration,
        prompt_len: usize,
        events: &UnboundedSender<(u64, AgentEvent)>,
    ) {
        let started = Instant::now();
        let output = recorded_output(agent);
        let _ = events.send((run, AgentEvent::Started(agent)));
        for word in output.split_inclusive(' ') {
            tokio::time::sleep(delay).await;
            let event = AgentEvent::Token {
                agent,
                text: word.to_string(),
            };
            if events.send((run, event)).is_err() {
                return;
            }
        }
        let usage = Usage {
            input: prompt_len.div_ceil(4) as u64,
            output: output.len().div_ceil(4) as u64,
        };
        let _ = events.send((
            run,
            AgentEvent::Finished {
                agent,
                output: output.to_string(),
                usage,
                duration_ms: started.elapsed().as_millis() as u64,
            },
        ));
    }
}

impl Pipeline for ReplayPipeline {
    fn check(&self, request: &RunRequest) -> Result<(), String> {
        for &agent in &request.agents {
            let settings = request.settings.get(&agent);
            let provider = settings.map_or(REPLAY_PROVIDER, |s| s.provider.as_str());
            if provider != REPLAY_PROVIDER {
                return Err(provider_needed(
                    agent,
                    &format!("no provider `{provider}` is configured in this build"),
                ));
            }
            if request.prompts.get(&agent).map(String::as_str) != Some(default_prompt(agent)) {
                return Err(provider_needed(
                    agent,
                    &format!("{agent}'s prompt was edited and the demo only has outputs recorded for its own prompts"),
                ));
            }
            if request.approach != Approach::MultiImage {
                return Err(provider_needed(
                    agent,
                    &format!(
                        "the demo was recorded with the multi-image approach, not {}",
                        request.approach.label()
                    ),
                ));
            }
        }
        Ok(())
    }

    fn spawn(
        &self,
        request: RunRequest,
        events: UnboundedSender<(u64, AgentEvent)>,
    ) -> JoinHandle<()> {
        let delay = self.delay;
        tokio::spawn(async move {
            let run = request.run;
            let prompt_len = |a: Agent| request.prompts.get(&a).map_or(0, String::len);
            let wants = |a: Agent| request.agents.contains(&a);
            let miners = async {
                if wants(Agent::Skm) {
                    Self::stream(Agent::Skm, run, delay, prompt_len(Agent::Skm), &events).await;
                }
            };
            let grounded = async {
                if wants(Agent::Gkm) {
                    Self::stream(Agent::Gkm, run, delay, prompt_len(Agent::Gkm), &events).await;
                }
            };
            tokio::join!(miners, grounded);
            if wants(Agent::Planner) {
                Self::stream(
                    Agent::Planner,
                    run,
                    delay,
                    prompt_len(Agent::Planner),
                    &events,
                )
                .await;
            }
        })
    }
}
