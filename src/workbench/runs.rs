//! The agents of the approach and the runs: starting, streaming, finishing,
//! cancelling, and keeping each run's scores in its record.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::{Duration, Instant};

use crate::agents::config::AgentSettings;
use crate::agents::cost::Estimate;
use crate::agents::pipeline::{AgentEvent, AgentRecord, PlanRecord};
use crate::agents::prompts::{prompt_hash, template_name};
use crate::agents::provider::RetryNotice;
use crate::agents::{AgentRole, Approach, ProviderKind, Usage};
use crate::plan::bounded_steps;
use crate::workbench::agents::{self, RunError, RunRequest};
use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::steps::StepList;
use crate::workbench::scoring::{score_record, Pg2sOutcome, SampleScoring, ScoreOutcome};
use crate::workbench::session::{
    PlanSource, RunRecord, RunState, SampleRecord, ScoreRecord, StepScore,
};
use crate::workbench::shared::{unix_now, Severity};

/// The mean of one score over the complete samples of `run` (see
/// [`RunRecord::sample_scores`]), the value the history, the Scores pane and the diff
/// all show for it; `None` when no complete sample has it.
pub fn mean_score(run: &RunRecord, of: impl Fn(&ScoreRecord) -> Option<f64>) -> Option<f64> {
    crate::stats::summary::Spread::of(run.sample_scores().iter().filter_map(of)).map(|s| s.mean)
}

/// Marks `run` partial when one of its later samples failed, saying how
/// many of its samples are complete; its scores are then over those only.
fn settle_samples(run: &mut RunRecord) {
    let failed: Vec<&SampleRecord> = run.samples.iter().filter(|s| s.error.is_some()).collect();
    let Some(first) = failed.first() else {
        return;
    };
    if !run.state.is_scored() {
        return;
    }
    let total = run.samples.len() + 1;
    run.state = RunState::Partial;
    run.reason = Some(format!(
        "{} of {total} samples complete, scored over those; sample {} failed: {}",
        total - failed.len(),
        first.sample + 1,
        first.error.as_deref().unwrap_or_default()
    ));
}

/// The numbers of samples the `S` key steps through.
pub const SAMPLE_STEPS: [u32; 4] = [1, 3, 5, 10];

/// A later sample as a run keeps it, from the pipeline's record.
fn sample_record(record: &PlanRecord) -> SampleRecord {
    SampleRecord {
        sample: record.sample,
        agents: record.agents.clone(),
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
    /// The wait before a retry it is in, and when the wait ends: shown in
    /// its pane's title, counting down, until the answer starts.
    pub retry: Option<(RetryNotice, Instant)>,
    /// When it last heard from its provider while running (the call's
    /// start, then each token): its pane's title counts the silence since.
    pub heard: Option<Instant>,
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
    /// Every agent that reported in it, those answered from the cache
    /// included: the run's record keeps each.
    pub reported: Vec<AgentRole>,
    /// Its later samples that came in before its first finished.
    pub samples: Vec<SampleRecord>,
    /// The plan the Plan pane showed when it started, put back when the run
    /// does not finish: the pane keeps the last good plan.
    pub kept: KeptPlan,
}

/// A plan the Plan pane showed, with where it came from and the selected step.
#[derive(Debug, Clone, PartialEq)]
pub struct KeptPlan {
    /// Its steps.
    pub items: Vec<String>,
    /// Where it came from.
    pub source: PlanSource,
    /// The selected step.
    pub selected: usize,
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
    /// Where `R` stands: priced first, sent at once when free, else on a
    /// second `R`.
    pub fresh: FreshRun,
}

/// Where a run of every agent afresh (`R`) stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FreshRun {
    /// Nothing asked.
    #[default]
    Idle,
    /// Its estimate is being made.
    Pricing,
    /// Its estimate is on the status line; `R` again sends it.
    Confirm,
}

impl Runs {
    /// Idle agents with the demo's settings, and no run.
    pub fn new() -> Self {
        Runs {
            agents: fresh_agents(),
            history: Vec::new(),
            active: None,
            awaiting_scores: None,
            fresh: FreshRun::Idle,
        }
    }
}

impl Default for Runs {
    fn default() -> Self {
        Self::new()
    }
}

impl AgentView {
    /// An agent with `settings` that has not answered yet on the source in
    /// use: no output, tokens, time or wait.
    pub fn idle(settings: AgentSettings) -> AgentView {
        AgentView {
            status: AgentStatus::Idle,
            output: String::new(),
            settings,
            ran_with: None,
            usage: Usage::default(),
            duration_ms: 0,
            cached: false,
            retry: None,
            heard: None,
        }
    }

    /// Starts a new call: no output, tokens, time or cache use yet, so
    /// nothing of the call before is counted for this one.
    fn begin_call(&mut self) {
        self.retry = None;
        self.heard = None;
        self.output.clear();
        self.usage = Usage::default();
        self.duration_ms = 0;
        self.cached = false;
    }
}

/// Every agent idle on the demo's recording, as a fresh start has them.
pub(crate) fn fresh_agents() -> BTreeMap<AgentRole, AgentView> {
    AgentRole::ALL
        .iter()
        .map(|&a| (a, AgentView::idle(AgentSettings::demo_recording())))
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
        for &agent in self.work.approach.roles() {
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
        let agent = self.panes.prompt.agent;
        let view = self.runs.agents.get(&agent)?;
        let prompt = self.prompt_of(agent);
        let why = if self.work.approach != Approach::MultiImage {
            "the demo's recording has only the multi-image approach"
        } else {
            "this prompt was edited and the demo's recording has no answer for it"
        };
        (view.settings.provider == ProviderKind::Replay
            && !self
                .panes
                .prompt
                .is_recorded(self.work.approach, agent, &prompt))
        .then(|| agents::provider_needed(agent, why).to_string())
    }

    /// `r` (`all` false: the agents whose inputs changed) or a run of
    /// every agent afresh that was priced and, if it costs anything,
    /// confirmed (see [`App::price_fresh_run`]).
    pub(crate) fn start_run(&mut self, all: bool) -> Vec<Cmd> {
        match self.run_request(all) {
            Some(request) => self.launch_run(request),
            None => Vec::new(),
        }
    }

    /// `R`: prices asking every agent afresh first; the answer
    /// ([`App::on_fresh_run_priced`]) starts the run, or asks for a second
    /// `R` when it costs something.
    pub(crate) fn price_fresh_run(&mut self) -> Vec<Cmd> {
        match self.run_request(true) {
            Some(request) => {
                self.runs.fresh = FreshRun::Pricing;
                self.set_status("R: pricing a run of every agent afresh…", Severity::Info);
                vec![Cmd::PriceFreshRun(request)]
            }
            None => Vec::new(),
        }
    }

    /// What asking every agent afresh would cost arrived: nothing to pay
    /// (every answer recorded, or free) starts the run; otherwise the
    /// estimate is shown and a second `R` sends it. Ignored when another
    /// key came between (the user moved on).
    pub(crate) fn on_fresh_run_priced(&mut self, priced: Result<Estimate, String>) -> Vec<Cmd> {
        if self.runs.fresh != FreshRun::Pricing {
            return Vec::new();
        }
        self.runs.fresh = FreshRun::Idle;
        let estimate = match priced {
            Ok(estimate) => estimate,
            // The run fails the same way, and says so where runs do.
            Err(_) => return self.start_run(true),
        };
        if estimate.usd <= 0.0 {
            let cmds = self.start_run(true);
            if let Some((text, _)) = self
                .messages
                .status
                .as_mut()
                .filter(|_| !cmds.is_empty() && !estimate.unpriced.is_empty())
            {
                let _ = write!(
                    text,
                    " · {} requests afresh{}",
                    estimate.requests,
                    estimate.unpriced_suffix()
                );
            }
            return cmds;
        }
        self.runs.fresh = FreshRun::Confirm;
        self.set_status(
            format!(
                "R asks every agent afresh, past the cache: {} requests, ~${:.4}{}; R again sends them, any other key keeps the cache",
                estimate.requests,
                estimate.usd,
                estimate.unpriced_suffix()
            ),
            Severity::Warn,
        );
        Vec::new()
    }

    /// The request of a run (`all`: every agent, afresh), or `None` with
    /// the reason on the status line.
    fn run_request(&mut self, all: bool) -> Option<RunRequest> {
        if self.runs.active.is_some() {
            self.set_status("a run is in flight: x cancels it", Severity::Warn);
            return None;
        }
        if !self.work.approach.uses_image() && self.work.task.table.is_none() {
            self.set_status(
                format!(
                    "the {} approach reads the task's environment table, and this task has none: give it a `table` file in tasks.jsonl, or press a for an image approach (the Plan pane shows the paper's plan as a reference)",
                    self.work.approach
                ),
                Severity::Warn,
            );
            return None;
        }
        if matches!(self.editing, Editing::Prompt) {
            self.panes.prompt.store_editor(self.work.approach);
        }
        // More samples than the last run asked for: every agent runs, its
        // earlier samples answered from the cache.
        let more_samples = self
            .runs
            .history
            .last()
            .is_some_and(|r| r.samples.len() as u32 + 1 < self.work.samples);
        let to_run = self.agents_to_run(all || more_samples);
        if to_run.is_empty() {
            self.set_status(
                "nothing changed since the last run: R re-runs every agent",
                Severity::Info,
            );
            return None;
        }
        let id = self.runs.history.iter().map(|r| r.id).max().unwrap_or(0) + 1;
        let approach_agents = self.work.approach.roles();
        let request = RunRequest {
            run: id,
            approach: self.work.approach,
            task: self.work.task.text.clone(),
            agents: to_run,
            prompts: approach_agents
                .iter()
                .map(|a| (*a, self.prompt_of(*a)))
                .collect(),
            settings: approach_agents
                .iter()
                .filter_map(|a| self.runs.agents.get(a).map(|v| (*a, v.settings.clone())))
                .collect(),
            demo: self.is_demo(),
            image: self.work.task.image.clone(),
            table: self.work.task.table.clone(),
            samples: self.work.samples,
            fresh: all,
        };
        Some(request)
    }

    /// Marks the request's agents waiting and the run in flight, keeping
    /// the plan it may replace, and asks for it to start.
    fn launch_run(&mut self, request: RunRequest) -> Vec<Cmd> {
        let (id, to_run) = (request.run, request.agents.clone());
        for &agent in &to_run {
            if let Some(v) = self.runs.agents.get_mut(&agent) {
                v.status = AgentStatus::Waiting;
                v.begin_call();
            }
        }
        self.runs.active = Some(ActiveRun {
            id,
            started_unix: unix_now(),
            agents: to_run.clone(),
            reported: Vec::new(),
            samples: Vec::new(),
            kept: KeptPlan {
                items: self.panes.plan.items.clone(),
                source: self.work.plan_source.clone(),
                selected: self.panes.plan.selected,
            },
        });
        let names: Vec<&str> = to_run.iter().map(|a| a.label()).collect();
        let samples = match self.work.samples {
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

    /// The record of `active` as it stands, in `state`: each agent's
    /// output, failure, tokens, time and cache use from this run alone (an
    /// agent that never started has no output and counts nothing), and the
    /// plan its planning agent wrote (possibly broken off).
    pub(crate) fn run_record(&self, active: &ActiveRun, state: RunState) -> RunRecord {
        let mut prompts = BTreeMap::new();
        let mut agents = Vec::new();
        let mut error = None;
        let roles = self
            .work
            .approach
            .roles()
            .iter()
            .filter(|a| active.agents.contains(a) || active.reported.contains(a));
        for &a in roles {
            let Some(v) = self.runs.agents.get(&a) else {
                continue;
            };
            let prompt = self.prompt_of(a);
            let failure = match &v.status {
                AgentStatus::Failed(e) => Some(e.clone()),
                _ => None,
            };
            if let (None, Some(e)) = (&error, &failure) {
                error = Some(format!("{}: {e}", a.label()));
            }
            let started = !matches!(v.status, AgentStatus::Waiting | AgentStatus::Idle);
            agents.push(AgentRecord {
                output: (started && (v.status == AgentStatus::Done || !v.output.is_empty()))
                    .then(|| v.output.clone()),
                error: failure,
                usage: v.usage,
                elapsed_ms: v.duration_ms,
                cached: v.cached,
                ..AgentRecord::blank(
                    a,
                    &v.settings,
                    &template_name(self.work.approach, a),
                    &prompt_hash(&prompt),
                )
            });
            prompts.insert(a, prompt);
        }
        let planning = self.work.approach.planning_role();
        let plan = match (state, self.runs.agents.get(&planning)) {
            (RunState::Finished, _) | (_, None) => self.panes.plan.items.clone(),
            (_, Some(v)) if active.agents.contains(&planning) => bounded_steps(&v.output).0,
            _ => Vec::new(),
        };
        let kept_plan = if plan.is_empty() {
            "no plan"
        } else {
            "its partial plan is kept"
        };
        let reason = match state {
            RunState::Finished | RunState::Partial => None,
            RunState::Running => Some("running".to_string()),
            RunState::Cancelled => Some(format!("cancelled: {kept_plan}, not scored")),
            RunState::Failed => Some(format!("{kept_plan}, not scored")),
        };
        RunRecord {
            id: active.id,
            started_unix: active.started_unix,
            approach: self.work.approach,
            task: self.work.task.text.clone(),
            agents,
            prompts,
            plan,
            ground_truth: self.panes.ground_truth.items.clone(),
            scores: None,
            state,
            error,
            reason,
            corrupted: None,
            steps: Vec::new(),
            samples: active.samples.clone(),
        }
    }

    /// Ends the run in flight and keeps its record: finished when every
    /// agent answered (then scored), else cancelled (`cancelled`) or
    /// failed, never scored, and the Plan pane gets back the plan it showed
    /// before the run.
    pub(crate) fn finish_run(&mut self, cancelled: bool) -> Vec<Cmd> {
        let Some(active) = self.runs.active.take() else {
            return Vec::new();
        };
        // Whatever had not answered is dropped with the run (a miner's
        // failure stops the other): its pane says so, not "waiting".
        for agent in &active.agents {
            if let Some(v) = self.runs.agents.get_mut(agent) {
                if matches!(v.status, AgentStatus::Running | AgentStatus::Waiting) {
                    v.status = AgentStatus::Cancelled;
                    v.retry = None;
                }
            }
        }
        let failed = active.agents.iter().any(|a| {
            self.runs
                .agents
                .get(a)
                .is_some_and(|v| matches!(v.status, AgentStatus::Failed(_)))
        });
        let state = match (cancelled, failed) {
            (true, _) => RunState::Cancelled,
            (false, true) => RunState::Failed,
            (false, false) => RunState::Finished,
        };
        let mut record = self.run_record(&active, state);
        settle_samples(&mut record);
        let status = format!("run {} {}", record.id, record.state_text());
        self.runs.history.push(record);
        self.saving.session_dirty = true;
        let severity = match state {
            RunState::Finished => Severity::Info,
            RunState::Failed => Severity::Error,
            _ => Severity::Warn,
        };
        if !state.is_scored() {
            self.panes.plan.items = active.kept.items;
            self.work.plan_source = active.kept.source;
            self.panes.plan.selected = active.kept.selected;
            let cmds = vec![self.rescore()];
            self.refresh_runs();
            self.set_status(status, severity);
            return cmds;
        }
        let mut cmds = vec![self.rescore()];
        self.runs.awaiting_scores = Some((self.runs.history.len() - 1, self.work.score_generation));
        cmds.extend(self.score_samples(active.id));
        self.refresh_runs();
        self.set_status(status, severity);
        cmds
    }

    /// The run whose plan the Plan pane shows, when it shows a run's plan.
    pub fn shown_run(&self) -> Option<&RunRecord> {
        let PlanSource::Run { run } = self.work.plan_source else {
            return None;
        };
        self.runs.history.iter().find(|r| r.id == run)
    }

    /// The latest run when it did not finish and the Plan pane shows
    /// another plan (the last good one): the pane says it failed and why.
    pub fn unfinished_latest(&self) -> Option<&RunRecord> {
        let latest = self.runs.history.last()?;
        (!latest.state.is_scored() && self.work.plan_source != PlanSource::Run { run: latest.id })
            .then_some(latest)
    }

    /// Steps the number of samples `r` asks for through [`SAMPLE_STEPS`].
    pub(crate) fn next_samples(&mut self) {
        let next = SAMPLE_STEPS
            .iter()
            .find(|&&n| n > self.work.samples)
            .copied()
            .unwrap_or(SAMPLE_STEPS[0]);
        self.work.samples = next;
        self.saving.kept.samples = None;
        self.saving.session_dirty = true;
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
        settle_samples(kept);
        self.saving.session_dirty = true;
        self.refresh_runs();
        self.score_samples(run).into_iter().collect()
    }

    /// Scores the later samples of run `run` not scored yet.
    fn score_samples(&self, run: u64) -> Option<Cmd> {
        let kept = self.runs.history.iter().find(|r| r.id == run)?;
        let plans: Vec<(u32, Vec<String>)> = kept
            .samples
            .iter()
            .filter(|s| s.scores.is_none() && s.error.is_none())
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
        self.saving.session_dirty = true;
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
                if let Some(active) = self.runs.active.as_mut() {
                    if !active.reported.contains(&agent) {
                        active.reported.push(agent);
                    }
                }
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.status = AgentStatus::Running;
                    v.begin_call();
                    v.heard = Some(Instant::now());
                }
                if agent == self.work.approach.planning_role() {
                    if matches!(
                        self.editing,
                        Editing::Step {
                            list: StepList::Plan,
                            ..
                        }
                    ) {
                        self.editing = Editing::None;
                    }
                    self.panes.plan.items.clear();
                    self.work.plan_source = PlanSource::Run { run };
                }
                Vec::new()
            }
            AgentEvent::Retrying {
                role: agent,
                notice,
            } => {
                self.set_status(format!("{agent}: {notice}"), Severity::Warn);
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    let until = Instant::now() + Duration::from_millis(notice.wait_ms);
                    v.retry = Some((notice, until));
                }
                Vec::new()
            }
            AgentEvent::Token { role: agent, text } => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.retry = None;
                    v.heard = Some(Instant::now());
                    v.output.push_str(&text);
                }
                match agent {
                    AgentRole::Skm => {
                        self.refresh_graph();
                        Vec::new()
                    }
                    AgentRole::Planner | AgentRole::Single => {
                        self.panes.plan.items = bounded_steps(&self.runs.agents[&agent].output).0;
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
                    v.retry = None;
                    v.usage = usage;
                    v.cached = cached;
                    v.duration_ms = duration_ms;
                    v.ran_with = Some((prompt, v.settings.clone()));
                }
                self.saving.session_dirty = true;
                let mut cmds = Vec::new();
                match agent {
                    AgentRole::Skm => self.refresh_graph(),
                    AgentRole::Planner | AgentRole::Single => {
                        self.panes.plan.items = bounded_steps(&self.runs.agents[&agent].output).0;
                        self.panes.plan.selected = 0;
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
                    cmds.extend(self.finish_run(false));
                }
                cmds
            }
            // Taken before the run's own events, above.
            AgentEvent::Sampled { .. } => Vec::new(),
            AgentEvent::Failed {
                role: agent,
                error,
                elapsed_ms,
            } => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.status = AgentStatus::Failed(error);
                    v.retry = None;
                    v.duration_ms = elapsed_ms;
                }
                let mut cmds = vec![Cmd::CancelRun(run)];
                cmds.extend(self.finish_run(false));
                cmds
            }
        }
    }

    /// When the screen must be drawn again for a retry's countdown to
    /// move (a quarter second on, or the wait's end), if one is shown.
    pub fn countdown_wake(&self, now: Instant) -> Option<Instant> {
        let retries = self
            .runs
            .agents
            .values()
            .filter_map(|v| v.retry.as_ref().map(|(_, until)| *until))
            .filter(|until| *until > now)
            .map(|until| until.min(now + Duration::from_millis(250)));
        // The silence of a running agent, counted in whole seconds.
        let silences = self
            .runs
            .agents
            .values()
            .filter(|v| v.status == AgentStatus::Running)
            .filter_map(|v| v.heard)
            .map(|heard| heard + Duration::from_secs(now.duration_since(heard).as_secs() + 1));
        retries.chain(silences).min()
    }

    pub(crate) fn cancel_run(&mut self) -> Vec<Cmd> {
        let Some(id) = self.runs.active.as_ref().map(|r| r.id) else {
            self.set_status("no run in flight", Severity::Info);
            return Vec::new();
        };
        let mut cmds = vec![Cmd::CancelRun(id)];
        cmds.extend(self.finish_run(true));
        cmds
    }

    pub(crate) fn on_scored(&mut self, outcome: ScoreOutcome) {
        if outcome.generation > self.work.score_generation {
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
                self.saving.session_dirty = true;
            }
        }
        if self
            .work
            .scores
            .as_ref()
            .is_none_or(|s| s.generation <= outcome.generation)
        {
            if let Some(Overlay::Actions(view)) = &mut self.overlay {
                view.scores = Some(outcome.clone());
            }
            self.work.scores = Some(outcome);
        }
    }
}
