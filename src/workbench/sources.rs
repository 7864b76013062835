//! The sources of plans a session holds — the built-in demo and each
//! dataset task opened — and moving between them: the one in use lives in
//! the panes and the runs, the others are parked as they were left, so
//! nothing of one is shown or scored against another.

use crate::agents::Approach;
use crate::dataset::Task;
use crate::workbench::app::{demo_task, task_view, App};
use crate::workbench::message::Cmd;
use crate::workbench::panes::steps::demo_ground_truth;
use crate::workbench::runs::{fresh_agents, AgentStatus, AgentView};
use crate::workbench::session::{GroundTruthSource, PlanSource, RunState, SourceState};
use crate::workbench::shared::Severity;

impl App {
    /// The source in use as the session keeps it, the run in flight
    /// included (as running, restored as cancelled).
    pub(crate) fn source_state(&self) -> SourceState {
        let agents = &self.runs.agents;
        SourceState {
            task_id: self.work.task.id.clone(),
            approach: self.work.approach,
            ground_truth_source: self.work.ground_truth_source.clone(),
            ground_truth: self.panes.ground_truth.items.clone(),
            plan_source: self.work.plan_source.clone(),
            plan: self.panes.plan.items.clone(),
            settings: agents
                .iter()
                .map(|(a, v)| (*a, v.settings.clone()))
                .collect(),
            outputs: agents
                .iter()
                .filter(|(_, v)| v.status == AgentStatus::Done)
                .map(|(a, v)| (*a, v.output.clone()))
                .collect(),
            ran_with: agents
                .iter()
                .filter_map(|(a, v)| v.ran_with.clone().map(|r| (*a, r)))
                .collect(),
            runs: self
                .runs
                .history
                .iter()
                .cloned()
                .chain(
                    self.runs
                        .active
                        .as_ref()
                        .map(|active| self.run_record(active, RunState::Running)),
                )
                .collect(),
        }
    }

    /// Opens another source (`None`: the demo) from the picker: the one in
    /// use is parked as it is, and the other comes back as it was left, or
    /// fresh when it was never opened. Refused while a run is in flight,
    /// since its answers belong to the source it started on.
    pub(crate) fn switch_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        if self.runs.active.is_some() {
            self.set_status(
                "a run is in flight: x cancels it before another task opens",
                Severity::Warn,
            );
            return Vec::new();
        }
        let parked = self.source_state();
        let undo = std::mem::take(&mut self.panes.undo);
        self.work.parked_undo.insert(parked.task_id.clone(), undo);
        self.work.parked.retain(|p| p.task_id != parked.task_id);
        self.work.parked.push(parked);
        self.saving.session_dirty = true;
        let mut cmds = self.open_source(task);
        cmds.push(self.rescore());
        cmds
    }

    /// Puts `task` (`None`: the demo) in use: its parked state when the
    /// session has one, else a fresh start on it (the demo runs its
    /// recording, a dataset task shows its published plan).
    pub(crate) fn open_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        let id = task.map(|t| t.id.clone());
        self.panes.undo = self.work.parked_undo.remove(&id).unwrap_or_default();
        match self.work.parked.iter().position(|p| p.task_id == id) {
            Some(at) => {
                let state = self.work.parked.remove(at);
                self.apply_source(state, task)
            }
            None => self.fresh_source(task),
        }
    }

    /// A source opened for the first time: no runs, no answers.
    fn fresh_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        self.runs.history.clear();
        self.runs.awaiting_scores = None;
        match task {
            Some(task) => {
                for view in self.runs.agents.values_mut() {
                    *view = AgentView::idle(view.settings.clone());
                }
                self.work.task = task_view(task);
                self.panes.ground_truth.replace(task.ground_truth.clone());
                self.work.ground_truth_source = GroundTruthSource::Dataset {
                    task: task.id.clone(),
                };
                let published = task.plans.contains_key(self.work.approach.dataset_field());
                if !self.work.approach.uses_image() && task.table.is_none() && !published {
                    self.set_approach(Approach::MultiImage);
                }
                self.use_configured_providers();
                self.refresh_graph();
                self.load_published_plan();
                self.load_scene()
            }
            None => {
                self.runs.agents = fresh_agents();
                self.work.task = demo_task();
                self.set_approach(Approach::MultiImage);
                self.panes.ground_truth.replace(demo_ground_truth(0));
                self.work.ground_truth_source = GroundTruthSource::Demo { index: 0 };
                self.panes.plan.replace(Vec::new());
                self.work.plan_source = PlanSource::None;
                self.refresh_graph();
                let mut cmds = self.load_scene();
                cmds.extend(self.start_run(false));
                cmds
            }
        }
    }

    /// Puts a saved source in use: its task, lists, answers and runs (a run
    /// saved in flight comes back cancelled); each agent's pane shows the
    /// time and tokens of its latest good call.
    pub(crate) fn apply_source(&mut self, s: SourceState, task: Option<&Task>) -> Vec<Cmd> {
        self.work.task = task.map_or_else(demo_task, task_view);
        self.set_approach(s.approach);
        self.work.ground_truth_source = s.ground_truth_source;
        self.panes.ground_truth.replace(s.ground_truth);
        self.work.plan_source = s.plan_source;
        self.panes.plan.replace(s.plan);
        for (agent, view) in self.runs.agents.iter_mut() {
            let settings = s.settings.get(agent).unwrap_or(&view.settings).clone();
            *view = AgentView::idle(settings);
            if let Some(out) = s.outputs.get(agent) {
                view.output = out.clone();
                view.status = AgentStatus::Done;
            }
            view.ran_with = s.ran_with.get(agent).cloned();
        }
        self.use_configured_providers();
        self.runs.history = s.runs;
        self.runs.awaiting_scores = None;
        for run in &mut self.runs.history {
            if run.state == RunState::Running {
                run.state = RunState::Cancelled;
                run.reason =
                    Some("cancelled: the workbench stopped during the run, not scored".into());
            }
        }
        for (agent, view) in self.runs.agents.iter_mut() {
            let last = self.runs.history.iter().rev().find_map(|r| {
                r.calls()
                    .find(|a| a.role == *agent && a.output.is_some() && a.error.is_none())
            });
            if let Some(record) = last.filter(|_| view.status == AgentStatus::Done) {
                view.usage = record.usage;
                view.duration_ms = record.elapsed_ms;
                view.cached = record.cached;
            }
        }
        self.refresh_graph();
        self.load_scene()
    }
}
