//! The agents of the approach and the runs: starting, streaming, finishing,
//! cancelling, and keeping each run's scores in its record.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::agents::config::AgentSettings;
use crate::agents::pipeline::{AgentEvent, AgentRecord, PlanRecord};
use crate::agents::prompts::{prompt_hash, template_name};
use crate::agents::provider::RetryNotice;
use crate::agents::{AgentRole, Approach, Usage};
use crate::plan::bounded_steps;
use crate::workbench::scoring::{score_record, Pg2sOutcome, SampleScoring, ScoreOutcome};
use crate::workbench::session::{
    PlanSource, RunRecord, RunState, SampleRecord, ScoreRecord, StepScore,
};
use crate::workbench::shared::unix_now;

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
pub fn fresh_agents() -> BTreeMap<AgentRole, AgentView> {
    AgentRole::ALL
        .iter()
        .map(|&a| (a, AgentView::idle(AgentSettings::demo_recording())))
        .collect()
}

/// What a run's record reads of the workbench beyond the runs: the
/// approach, the task, each agent's prompt as it stands, and the two step
/// lists. Taken by [`crate::workbench::app::App::run_context`].
#[derive(Debug, Clone)]
pub struct RunContext {
    /// The approach in use.
    pub approach: Approach,
    /// The task text.
    pub task: String,
    /// The prompt of each agent of the approach, as it stands (the editor's
    /// text while one is edited).
    pub prompts: BTreeMap<AgentRole, String>,
    /// The steps the Plan pane shows.
    pub plan: Vec<String>,
    /// The ground-truth steps.
    pub ground_truth: Vec<String>,
}

/// A run that ended ([`Runs::end`]): its record is in the history.
#[derive(Debug, Clone, PartialEq)]
pub struct Ended {
    /// The run's id.
    pub id: u64,
    /// How it ended.
    pub state: RunState,
    /// The plan the Plan pane showed when it started, to put back when it
    /// is not scored.
    pub kept: KeptPlan,
    /// What the status line says of it (`run 3 failed: …`).
    pub status: String,
}

/// What an agent's event changed beyond the agent's own view, for the
/// update function to carry on to the panes ([`Runs::on_event`]).
#[derive(Debug, Clone, PartialEq)]
pub enum AgentChange {
    /// Nothing more (or the event belongs to a run no longer in flight).
    Nothing,
    /// The agent started its call.
    Started(AgentRole),
    /// The agent waits before a retry: the line for the status bar.
    Retrying(String),
    /// The agent's output grew.
    Output(AgentRole),
    /// The agent answered; `all_done` when every agent of the run has.
    Finished {
        /// The agent.
        agent: AgentRole,
        /// Whether the run has every answer now.
        all_done: bool,
    },
    /// The agent failed: the run ends failed.
    Failed,
}

impl Runs {
    /// Whether `agent`'s prompt (`prompt`, as it stands) or settings differ
    /// from those its output was made with.
    pub fn agent_changed(&self, agent: AgentRole, prompt: &str) -> bool {
        let Some(v) = self.agents.get(&agent) else {
            return false;
        };
        v.status != AgentStatus::Done
            || v.ran_with
                .as_ref()
                .is_none_or(|(ran, settings)| ran != prompt || *settings != v.settings)
    }

    /// The id the next run (or corruption) gets.
    pub fn next_id(&self) -> u64 {
        self.history.iter().map(|r| r.id).max().unwrap_or(0) + 1
    }

    /// Marks `agents` waiting and run `id` in flight, keeping `kept`, the
    /// plan it may replace.
    pub fn launch(&mut self, id: u64, agents: &[AgentRole], kept: KeptPlan) {
        for agent in agents {
            if let Some(v) = self.agents.get_mut(agent) {
                v.status = AgentStatus::Waiting;
                v.begin_call();
            }
        }
        self.active = Some(ActiveRun {
            id,
            started_unix: unix_now(),
            agents: agents.to_vec(),
            reported: Vec::new(),
            samples: Vec::new(),
            kept,
        });
    }

    /// Takes the settings the pipeline resolved for run `run`, which it
    /// accepted (provider defaults, config file and environment applied; no
    /// keys), so that the views, the session and the run's records show
    /// what ran.
    pub fn accepted(&mut self, run: u64, settings: BTreeMap<AgentRole, AgentSettings>) {
        if self.active.as_ref().is_none_or(|r| r.id != run) {
            return;
        }
        for (agent, resolved) in settings {
            if let Some(v) = self.agents.get_mut(&agent) {
                v.settings = resolved.for_record();
            }
        }
    }

    /// Drops run `run`, which the pipeline refused, its agents idle again;
    /// whether it was the run in flight.
    pub fn refused(&mut self, run: u64) -> bool {
        if self.active.as_ref().is_none_or(|r| r.id != run) {
            return false;
        }
        if let Some(active) = self.active.take() {
            for agent in active.agents {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Idle;
                }
            }
        }
        true
    }

    /// The record of `active` as it stands, in `state`: each agent's
    /// output, failure, tokens, time and cache use from this run alone (an
    /// agent that never started has no output and counts nothing), and the
    /// plan its planning agent wrote (possibly broken off).
    pub fn record(&self, active: &ActiveRun, state: RunState, ctx: &RunContext) -> RunRecord {
        let mut prompts = BTreeMap::new();
        let mut agents = Vec::new();
        let mut error = None;
        let roles = ctx
            .approach
            .roles()
            .iter()
            .filter(|a| active.agents.contains(a) || active.reported.contains(a));
        for &a in roles {
            let Some(v) = self.agents.get(&a) else {
                continue;
            };
            let prompt = ctx.prompts.get(&a).cloned().unwrap_or_default();
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
                    &template_name(ctx.approach, a),
                    &prompt_hash(&prompt),
                )
            });
            prompts.insert(a, prompt);
        }
        let planning = ctx.approach.planning_role();
        let plan = match (state, self.agents.get(&planning)) {
            (RunState::Finished, _) | (_, None) => ctx.plan.clone(),
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
            approach: ctx.approach,
            task: ctx.task.clone(),
            agents,
            prompts,
            plan,
            ground_truth: ctx.ground_truth.clone(),
            scores: None,
            state,
            error,
            reason,
            corrupted: None,
            steps: Vec::new(),
            samples: active.samples.clone(),
        }
    }

    /// Ends the run in flight and keeps its record in the history:
    /// finished when every agent answered, else cancelled (`cancelled`) or
    /// failed, never scored. Whatever had not answered is dropped with the
    /// run (a miner's failure stops the other): its view says so, not
    /// "waiting".
    pub fn end(&mut self, cancelled: bool, ctx: &RunContext) -> Option<Ended> {
        let active = self.active.take()?;
        for agent in &active.agents {
            if let Some(v) = self.agents.get_mut(agent) {
                if matches!(v.status, AgentStatus::Running | AgentStatus::Waiting) {
                    v.status = AgentStatus::Cancelled;
                    v.retry = None;
                }
            }
        }
        let failed = active.agents.iter().any(|a| {
            self.agents
                .get(a)
                .is_some_and(|v| matches!(v.status, AgentStatus::Failed(_)))
        });
        let state = match (cancelled, failed) {
            (true, _) => RunState::Cancelled,
            (false, true) => RunState::Failed,
            (false, false) => RunState::Finished,
        };
        let mut record = self.record(&active, state, ctx);
        settle_samples(&mut record);
        let status = format!("run {} {}", record.id, record.state_text());
        self.history.push(record);
        Some(Ended {
            id: active.id,
            state,
            kept: active.kept,
            status,
        })
    }

    /// The run whose plan the Plan pane shows, when it shows a run's plan
    /// (`source`).
    pub fn shown(&self, source: &PlanSource) -> Option<&RunRecord> {
        let PlanSource::Run { run } = source else {
            return None;
        };
        self.history.iter().find(|r| r.id == *run)
    }

    /// The latest run when it did not finish and the Plan pane shows
    /// another plan (`source`, the last good one): the pane says it failed
    /// and why.
    pub fn unfinished_latest(&self, source: &PlanSource) -> Option<&RunRecord> {
        let latest = self.history.last()?;
        (!latest.state.is_scored() && *source != PlanSource::Run { run: latest.id })
            .then_some(latest)
    }

    /// Keeps a later sample of run `run`: with the run in flight until it
    /// finishes, else with its record (then `true`: the record changed and
    /// its samples want scoring).
    pub fn add_sample(&mut self, run: u64, record: &PlanRecord) -> bool {
        let sample = sample_record(record);
        if let Some(active) = self.active.as_mut().filter(|r| r.id == run) {
            active.samples.push(sample);
            return false;
        }
        let Some(kept) = self.history.iter_mut().find(|r| r.id == run) else {
            return false;
        };
        kept.samples.push(sample);
        kept.samples.sort_by_key(|s| s.sample);
        settle_samples(kept);
        true
    }

    /// What scoring the later samples of run `run` not scored yet asks, if
    /// there are any.
    pub fn sample_scoring(&self, run: u64) -> Option<SampleScoring> {
        let kept = self.history.iter().find(|r| r.id == run)?;
        let plans: Vec<(u32, Vec<String>)> = kept
            .samples
            .iter()
            .filter(|s| s.scores.is_none() && s.error.is_none())
            .map(|s| (s.sample, s.plan.clone()))
            .collect();
        (!plans.is_empty()).then(|| SampleScoring {
            run,
            gt: kept.ground_truth.clone(),
            plans,
        })
    }

    /// Keeps the scores of run `run`'s later samples; whether the run is
    /// still in the history.
    pub fn samples_scored(&mut self, run: u64, scores: Vec<(u32, ScoreRecord)>) -> bool {
        let Some(kept) = self.history.iter_mut().find(|r| r.id == run) else {
            return false;
        };
        for (sample, score) in scores {
            if let Some(s) = kept.samples.iter_mut().find(|s| s.sample == sample) {
                s.scores = Some(score);
            }
        }
        true
    }

    /// Applies an agent's event of run `run` to its view (`prompt`: the
    /// prompt a finishing agent answered, kept as what its output was made
    /// with) and says what else it changed. Events of a run no longer in
    /// flight change nothing; samples go through [`Runs::add_sample`].
    pub fn on_event(&mut self, run: u64, event: AgentEvent, prompt: Option<String>) -> AgentChange {
        if self.active.as_ref().is_none_or(|r| r.id != run) {
            return AgentChange::Nothing;
        }
        match event {
            AgentEvent::Started { role: agent } => {
                if let Some(active) = self.active.as_mut() {
                    if !active.reported.contains(&agent) {
                        active.reported.push(agent);
                    }
                }
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Running;
                    v.begin_call();
                    v.heard = Some(Instant::now());
                }
                AgentChange::Started(agent)
            }
            AgentEvent::Retrying {
                role: agent,
                notice,
            } => {
                let text = format!("{agent}: {notice}");
                if let Some(v) = self.agents.get_mut(&agent) {
                    let until = Instant::now() + Duration::from_millis(notice.wait_ms);
                    v.retry = Some((notice, until));
                }
                AgentChange::Retrying(text)
            }
            AgentEvent::Token { role: agent, text } => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.retry = None;
                    v.heard = Some(Instant::now());
                    v.output.push_str(&text);
                }
                AgentChange::Output(agent)
            }
            AgentEvent::Finished {
                role: agent,
                usage,
                elapsed_ms: duration_ms,
                cached,
                ..
            } => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Done;
                    v.retry = None;
                    v.usage = usage;
                    v.cached = cached;
                    v.duration_ms = duration_ms;
                    v.ran_with = Some((prompt.unwrap_or_default(), v.settings.clone()));
                }
                let all_done = self.active.as_ref().is_some_and(|r| {
                    r.agents.iter().all(|a| {
                        self.agents
                            .get(a)
                            .is_some_and(|v| v.status == AgentStatus::Done)
                    })
                });
                AgentChange::Finished { agent, all_done }
            }
            // Kept by `add_sample`, not here.
            AgentEvent::Sampled { .. } => AgentChange::Nothing,
            AgentEvent::Failed {
                role: agent,
                error,
                elapsed_ms,
            } => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Failed(error);
                    v.retry = None;
                    v.duration_ms = elapsed_ms;
                }
                AgentChange::Failed
            }
        }
    }

    /// The output `agent` has written so far.
    pub fn output(&self, agent: AgentRole) -> &str {
        self.agents.get(&agent).map_or("", |v| v.output.as_str())
    }

    /// When the screen must be drawn again for a retry's countdown to
    /// move (a quarter second on, or the wait's end), if one is shown.
    pub fn countdown_wake(&self, now: Instant) -> Option<Instant> {
        let retries = self
            .agents
            .values()
            .filter_map(|v| v.retry.as_ref().map(|(_, until)| *until))
            .filter(|until| *until > now)
            .map(|until| until.min(now + Duration::from_millis(250)));
        // The silence of a running agent, counted in whole seconds.
        let silences = self
            .agents
            .values()
            .filter(|v| v.status == AgentStatus::Running)
            .filter_map(|v| v.heard)
            .map(|heard| heard + Duration::from_secs(now.duration_since(heard).as_secs() + 1));
        retries.chain(silences).min()
    }

    /// Keeps `outcome`'s scores with the run that awaited them, when they
    /// are the scores of its plan or later; whether they were.
    pub fn scored(&mut self, outcome: &ScoreOutcome) -> bool {
        let Some((index, generation)) = self.awaiting_scores else {
            return false;
        };
        if outcome.generation < generation {
            return false;
        }
        if let Some(run) = self.history.get_mut(index) {
            run.scores = Some(score_record(outcome));
            run.steps = step_breakdown(outcome, run.plan.len());
        }
        self.awaiting_scores = None;
        true
    }
}
