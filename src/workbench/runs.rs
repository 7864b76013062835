//! The agents of the approach and the runs: starting, streaming, finishing,
//! cancelling, and keeping each run's scores in its record.

use std::collections::BTreeMap;

use crate::agents::config::AgentSettings;
use crate::agents::pipeline::{AgentEvent, AgentRecord, PlanRecord};
use crate::agents::prompts::{prompt_hash, template_name};
use crate::agents::{AgentRole, Approach, ProviderKind, Usage};
use crate::plan::bounded_steps;
use crate::workbench::agents::{self, RunError, RunRequest};
use crate::workbench::app::{unix_now, App, Severity};
use crate::workbench::editing::Editing;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::steps::StepList;
use crate::workbench::scoring::{score_record, Pg2sOutcome, SampleScoring, ScoreOutcome};
use crate::workbench::session::{PlanSource, RunRecord, SampleRecord, ScoreRecord, StepScore};

/// Every sample's scores of `run`, in sample order: the one place the run
/// diff's verdicts and the Scores pane read a run's samples from. The run's
/// own scores are sample 0; each later sample follows once scored (a
/// sample not scored yet is left out).
pub fn sample_scores(run: &RunRecord) -> Vec<ScoreRecord> {
    run.scores
        .into_iter()
        .chain(run.samples.iter().filter_map(|s| s.scores))
        .collect()
}

/// The numbers of samples the `S` key steps through.
pub const SAMPLE_STEPS: [u32; 4] = [1, 3, 5, 10];

/// A later sample as a run keeps it, from the pipeline's record.
fn sample_record(record: &PlanRecord) -> SampleRecord {
    SampleRecord {
        sample: record.sample,
        outputs: record
            .agents
            .iter()
            .filter_map(|a| Some((a.role, a.output.clone()?)))
            .collect(),
        plan: record.steps.clone(),
        usage: record.usage,
        error: record
            .first_error()
            .map(|(role, error)| format!("{}: {error}", role.label())),
        scores: None,
    }
}

/// Each of `steps` plan steps' part of `outcome`: the KAS of the step and
/// the ground-truth step PG2S matched it to, as the Plan pane marks it.
fn step_breakdown(outcome: &ScoreOutcome, steps: usize) -> Vec<StepScore> {
    let matches = match &outcome.pg2s {
        Pg2sOutcome::Ready(report) => report.sentence_matches.as_slice(),
        _ => &[],
    };
    (0..steps)
        .map(|i| StepScore {
            kas: outcome.kas.step_scores.get(i).copied(),
            matched: matches
                .iter()
                .find(|m| m.pred == Some(i))
                .map(|m| (m.gt, m.cosine.unwrap_or_default())),
        })
        .collect()
}

/// What an agent is doing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AgentStatus {
    /// Nothing has run.
    Idle,
    /// Queued behind the agents it reads.
    Waiting,
    /// Writing.
    Running,
    /// Finished.
    Done,
    /// Failed, with the reason.
    Failed(String),
    /// Cancelled by the user.
    Cancelled,
}

/// One agent as the workbench sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentView {
    /// What it is doing.
    pub status: AgentStatus,
    /// Its latest output (growing while it runs).
    pub output: String,
    /// Its settings: as chosen, then as the pipeline resolved them for
    /// its latest run (never with a key).
    pub settings: AgentSettings,
    /// The prompt and settings its output was made with.
    pub ran_with: Option<(String, AgentSettings)>,
    /// Token use of its latest call.
    pub usage: Usage,
    /// Wall time of its latest call in milliseconds.
    pub duration_ms: u64,
    /// Whether its latest answer came from the cache or the recording.
    pub cached: bool,
}

/// The run in flight.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveRun {
    /// Its id.
    pub id: u64,
    /// When it started (Unix seconds).
    pub started_unix: u64,
    /// The agents it runs.
    pub agents: Vec<AgentRole>,
    /// Its later samples that came in before its first finished.
    pub samples: Vec<SampleRecord>,
}

/// The agents of the approach and every run.
pub struct Runs {
    /// The agents.
    pub agents: BTreeMap<AgentRole, AgentView>,
    /// Every run, oldest first.
    pub history: Vec<RunRecord>,
    /// The run in flight.
    pub active: Option<ActiveRun>,
    /// A finished run waiting for its scores: (index in `history`, generation).
    pub awaiting_scores: Option<(usize, u64)>,
}

impl Runs {
    /// Idle agents with the demo's settings, and no run.
    pub fn new() -> Self {
        Runs {
            agents: fresh_agents(),
            history: Vec::new(),
            active: None,
            awaiting_scores: None,
        }
    }
}

impl Default for Runs {
    fn default() -> Self {
        Self::new()
    }
}

fn fresh_agents() -> BTreeMap<AgentRole, AgentView> {
    AgentRole::ALL
        .iter()
        .map(|&a| {
            (
                a,
                AgentView {
                    status: AgentStatus::Idle,
                    output: String::new(),
                    settings: AgentSettings::demo_recording(),
                    ran_with: None,
                    usage: Usage::default(),
                    duration_ms: 0,
                    cached: false,
                },
            )
        })
        .collect()
}

impl App {
    /// Whether an agent's prompt or settings differ from those its output was made with.
    pub fn agent_changed(&self, agent: AgentRole) -> bool {
        let Some(v) = self.runs.agents.get(&agent) else {
            return false;
        };
        let prompt = self.prompt_of(agent);
        v.status != AgentStatus::Done || v.ran_with.as_ref() != Some(&(prompt, v.settings.clone()))
    }

    /// The agents a run re-executes: those whose inputs changed, and the
    /// planner when a miner it reads re-runs.
    pub fn agents_to_run(&self, all: bool) -> Vec<AgentRole> {
        let mut out: Vec<AgentRole> = Vec::new();
        for &agent in self.approach.roles() {
            let upstream = agent == AgentRole::Planner && !out.is_empty();
            if all || upstream || self.agent_changed(agent) {
                out.push(agent);
            }
        }
        out
    }

    /// The note shown when the selected agent's prompt was edited but only
    /// recorded outputs can be replayed.
    pub fn provider_note(&self) -> Option<String> {
        let agent = self.prompt.agent;
        let view = self.runs.agents.get(&agent)?;
        let prompt = self.prompt_of(agent);
        let why = if self.approach != Approach::MultiImage {
            "the demo's recording has only the multi-image approach"
        } else {
            "this prompt was edited and the demo's recording has no answer for it"
        };
        (view.settings.provider == ProviderKind::Replay
            && !self.prompt.is_recorded(self.approach, agent, &prompt))
        .then(|| agents::provider_needed(agent, why).to_string())
    }

    pub(crate) fn start_run(&mut self, all: bool) -> Vec<Cmd> {
        if self.runs.active.is_some() {
            self.set_status("a run is in flight: x cancels it", Severity::Warn);
            return Vec::new();
        }
        if matches!(self.editing, Editing::Prompt) {
            self.store_prompt_editor();
        }
        let to_run = self.agents_to_run(all);
        if to_run.is_empty() {
            self.set_status(
                "nothing changed since the last run: R re-runs every agent",
                Severity::Info,
            );
            return Vec::new();
        }
        let id = self.runs.history.iter().map(|r| r.id).max().unwrap_or(0) + 1;
        let approach_agents = self.approach.roles();
        let request = RunRequest {
            run: id,
            approach: self.approach,
            task: self.task.text.clone(),
            agents: to_run.clone(),
            prompts: approach_agents
                .iter()
                .map(|a| (*a, self.prompt_of(*a)))
                .collect(),
            settings: approach_agents
                .iter()
                .filter_map(|a| self.runs.agents.get(a).map(|v| (*a, v.settings.clone())))
                .collect(),
            demo: self.is_demo(),
            image: self.task.image.clone(),
            table: self.task.table.clone(),
            samples: self.samples,
        };
        for &agent in &to_run {
            if let Some(v) = self.runs.agents.get_mut(&agent) {
                v.status = AgentStatus::Waiting;
                v.output.clear();
            }
        }
        self.runs.active = Some(ActiveRun {
            id,
            started_unix: unix_now(),
            agents: to_run.clone(),
            samples: Vec::new(),
        });
        let names: Vec<&str> = to_run.iter().map(|a| a.label()).collect();
        let samples = match self.samples {
            1 => String::new(),
            n => format!(" ({n} samples)"),
        };
        self.set_status(
            format!("run {id}: {}{samples}", names.join(", ")),
            Severity::Info,
        );
        vec![Cmd::StartRun(request)]
    }

    /// Takes the settings the pipeline resolved for a run it accepted
    /// (provider defaults, config file and environment applied; no keys),
    /// so that the views, the session and the run's records show what ran;
    /// called by the runtime.
    pub fn run_accepted(&mut self, run: u64, settings: BTreeMap<AgentRole, AgentSettings>) {
        if self.runs.active.as_ref().is_none_or(|r| r.id != run) {
            return;
        }
        for (agent, resolved) in settings {
            if let Some(v) = self.runs.agents.get_mut(&agent) {
                v.settings = resolved.for_record();
            }
        }
    }

    /// Refuses a run the pipeline cannot do; called by the runtime.
    pub fn run_refused(&mut self, run: u64, reason: RunError) {
        if self.runs.active.as_ref().is_some_and(|r| r.id == run) {
            if let Some(active) = self.runs.active.take() {
                for agent in active.agents {
                    if let Some(v) = self.runs.agents.get_mut(&agent) {
                        v.status = AgentStatus::Idle;
                    }
                }
            }
            self.set_status(reason.to_string(), Severity::Warn);
        }
    }

    pub(crate) fn finish_run(&mut self, cancelled: bool) -> Vec<Cmd> {
        let Some(active) = self.runs.active.take() else {
            return Vec::new();
        };
        let mut prompts = BTreeMap::new();
        let mut agents = Vec::new();
        for &a in &active.agents {
            let Some(v) = self.runs.agents.get(&a) else {
                continue;
            };
            let prompt = self.prompt_of(a);
            agents.push(AgentRecord {
                output: Some(v.output.clone()),
                error: match &v.status {
                    AgentStatus::Failed(e) => Some(e.clone()),
                    _ => None,
                },
                usage: v.usage,
                elapsed_ms: v.duration_ms,
                cached: v.cached,
                ..AgentRecord::blank(
                    a,
                    &v.settings,
                    &template_name(self.approach, a),
                    &prompt_hash(&prompt),
                )
            });
            prompts.insert(a, prompt);
        }
        self.runs.history.push(RunRecord {
            id: active.id,
            started_unix: active.started_unix,
            approach: self.approach,
            task: self.task.text.clone(),
            agents,
            prompts,
            plan: self.plan.items.clone(),
            ground_truth: self.ground_truth.items.clone(),
            scores: None,
            cancelled,
            corrupted: None,
            steps: Vec::new(),
            samples: active.samples,
        });
        let mut cmds = vec![self.rescore()];
        self.runs.awaiting_scores = Some((self.runs.history.len() - 1, self.score_generation));
        cmds.extend(self.score_samples(active.id));
        self.refresh_runs();
        cmds
    }

    /// Steps the number of samples `r` asks for through [`SAMPLE_STEPS`].
    pub(crate) fn next_samples(&mut self) {
        let next = SAMPLE_STEPS
            .iter()
            .find(|&&n| n > self.samples)
            .copied()
            .unwrap_or(SAMPLE_STEPS[0]);
        self.samples = next;
        self.session_dirty = true;
        self.set_status(
            format!("samples per run: {next} (r asks each agent {next} times)"),
            Severity::Info,
        );
    }

    /// A later sample of run `run` arrived: kept with the run (or with the
    /// run in flight until it finishes) and scored.
    fn on_sample(&mut self, run: u64, record: &PlanRecord) -> Vec<Cmd> {
        let sample = sample_record(record);
        if let Some(active) = self.runs.active.as_mut().filter(|r| r.id == run) {
            active.samples.push(sample);
            return Vec::new();
        }
        let Some(kept) = self.runs.history.iter_mut().find(|r| r.id == run) else {
            return Vec::new();
        };
        kept.samples.push(sample);
        kept.samples.sort_by_key(|s| s.sample);
        self.session_dirty = true;
        self.refresh_runs();
        self.score_samples(run).into_iter().collect()
    }

    /// Scores the later samples of run `run` not scored yet.
    fn score_samples(&self, run: u64) -> Option<Cmd> {
        let kept = self.runs.history.iter().find(|r| r.id == run)?;
        let plans: Vec<(u32, Vec<String>)> = kept
            .samples
            .iter()
            .filter(|s| s.scores.is_none())
            .map(|s| (s.sample, s.plan.clone()))
            .collect();
        (!plans.is_empty()).then(|| {
            Cmd::ScoreSamples(SampleScoring {
                run,
                gt: kept.ground_truth.clone(),
                plans,
            })
        })
    }

    /// The later samples of run `run` were scored.
    pub(crate) fn on_samples_scored(&mut self, run: u64, scores: Vec<(u32, ScoreRecord)>) {
        let Some(kept) = self.runs.history.iter_mut().find(|r| r.id == run) else {
            return;
        };
        for (sample, score) in scores {
            if let Some(s) = kept.samples.iter_mut().find(|s| s.sample == sample) {
                s.scores = Some(score);
            }
        }
        self.session_dirty = true;
        self.refresh_runs();
    }

    pub(crate) fn on_agent(&mut self, run: u64, event: AgentEvent) -> Vec<Cmd> {
        if let AgentEvent::Sampled { record } = &event {
            return self.on_sample(run, record);
        }
        if self.runs.active.as_ref().is_none_or(|r| r.id != run) {
            return Vec::new();
        }
        match event {
            AgentEvent::Started { role: agent } => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.status = AgentStatus::Running;
                    v.output.clear();
                }
                if agent == self.approach.planning_role() {
                    if matches!(
                        self.editing,
                        Editing::Step {
                            list: StepList::Plan,
                            ..
                        }
                    ) {
                        self.editing = Editing::None;
                    }
                    self.plan.items.clear();
                    self.plan_source = PlanSource::Run { run };
                }
                Vec::new()
            }
            AgentEvent::Token { role: agent, text } => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.output.push_str(&text);
                }
                match agent {
                    AgentRole::Skm => {
                        self.refresh_graph();
                        Vec::new()
                    }
                    AgentRole::Planner | AgentRole::Single => {
                        self.plan.items = bounded_steps(&self.runs.agents[&agent].output).0;
                        vec![self.rescore()]
                    }
                    AgentRole::Gkm => Vec::new(),
                }
            }
            AgentEvent::Finished {
                role: agent,
                usage,
                elapsed_ms: duration_ms,
                cached,
                ..
            } => {
                let prompt = self.prompt_of(agent);
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.status = AgentStatus::Done;
                    v.usage = usage;
                    v.cached = cached;
                    v.duration_ms = duration_ms;
                    v.ran_with = Some((prompt, v.settings.clone()));
                }
                self.session_dirty = true;
                let mut cmds = Vec::new();
                match agent {
                    AgentRole::Skm => self.refresh_graph(),
                    AgentRole::Planner | AgentRole::Single => {
                        self.plan.items = bounded_steps(&self.runs.agents[&agent].output).0;
                        self.plan.selected = 0;
                    }
                    AgentRole::Gkm => {}
                }
                let all_done = self.runs.active.as_ref().is_some_and(|r| {
                    r.agents.iter().all(|a| {
                        self.runs
                            .agents
                            .get(a)
                            .is_some_and(|v| v.status == AgentStatus::Done)
                    })
                });
                if all_done {
                    let id = run;
                    cmds.extend(self.finish_run(false));
                    self.set_status(format!("run {id} finished"), Severity::Info);
                }
                cmds
            }
            // Taken before the run's own events, above.
            AgentEvent::Sampled { .. } => Vec::new(),
            AgentEvent::Failed { role: agent, error } => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.status = AgentStatus::Failed(error.clone());
                }
                self.set_status(
                    format!("{} failed: {error}", agent.label()),
                    Severity::Error,
                );
                let mut cmds = vec![Cmd::CancelRun(run)];
                cmds.extend(self.finish_run(false));
                cmds
            }
        }
    }

    pub(crate) fn cancel_run(&mut self) -> Vec<Cmd> {
        let Some(id) = self.runs.active.as_ref().map(|r| r.id) else {
            self.set_status("no run in flight", Severity::Info);
            return Vec::new();
        };
        for v in self.runs.agents.values_mut() {
            if matches!(v.status, AgentStatus::Running | AgentStatus::Waiting) {
                v.status = AgentStatus::Cancelled;
            }
        }
        self.set_status(format!("run {id} cancelled"), Severity::Warn);
        let mut cmds = vec![Cmd::CancelRun(id)];
        cmds.extend(self.finish_run(true));
        cmds
    }

    pub(crate) fn on_scored(&mut self, outcome: ScoreOutcome) {
        if outcome.generation > self.score_generation {
            return;
        }
        if let Some((index, generation)) = self.runs.awaiting_scores {
            if outcome.generation >= generation {
                if let Some(run) = self.runs.history.get_mut(index) {
                    run.scores = Some(score_record(&outcome));
                    run.steps = step_breakdown(&outcome, run.plan.len());
                }
                self.runs.awaiting_scores = None;
                self.refresh_runs();
                self.session_dirty = true;
            }
        }
        if self
            .scores
            .as_ref()
            .is_none_or(|s| s.generation <= outcome.generation)
        {
            if let Some(Overlay::Actions(view)) = &mut self.overlay {
                view.scores = Some(outcome.clone());
            }
            self.scores = Some(outcome);
        }
    }
}
