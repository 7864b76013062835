//! What of the workbench a session file keeps, restoring it, and when the
//! loop copies it for the saver ([`Persist`]).

use std::time::Instant;

use crate::agents::prompts::template_name;
use crate::workbench::app::{task_view, App};
use crate::workbench::editing::Editing;
use crate::workbench::message::Cmd;
use crate::workbench::panes::steps::StepList;
use crate::workbench::panes::Pane;
use crate::workbench::runs::AgentStatus;
use crate::workbench::session::{Draft, RunState, Session, SESSION_VERSION};
use crate::workbench::shared::{single_line_editor, Severity};
use crate::workbench::snapshot::{Snapshot, SnapshotPacer, SNAPSHOT_EVERY};

/// The session copies of the loop: when the next one is due, and how many
/// were taken (a copy is the costly part of saving, so tests check that
/// typing does not take one a keystroke).
#[derive(Debug, Clone)]
pub struct Persist {
    pacer: SnapshotPacer,
    taken: u64,
    was_editing: bool,
}

impl Persist {
    /// No copy taken yet, paced at [`SNAPSHOT_EVERY`].
    pub fn new() -> Self {
        Self {
            pacer: SnapshotPacer::new(SNAPSHOT_EVERY),
            taken: 0,
            was_editing: false,
        }
    }

    /// How many copies of the session [`App::poll_snapshot`] has taken.
    pub fn taken(&self) -> u64 {
        self.taken
    }
}

impl Default for Persist {
    fn default() -> Self {
        Self::new()
    }
}

impl App {
    /// Called by the loop after each batch of messages: the copy of the
    /// session for the saver when one is due (at once when an edit was just
    /// committed, else at most every [`SNAPSHOT_EVERY`]), and otherwise the
    /// instant to ask again, if a change waits.
    pub fn poll_snapshot(&mut self, now: Instant) -> (Option<Session>, Option<Instant>) {
        if self.saving.session_dirty {
            self.saving.session_dirty = false;
            self.saving.persist.pacer.changed();
        }
        let editing = self.is_editing();
        let committed = self.saving.persist.was_editing && !editing;
        self.saving.persist.was_editing = editing;
        match self.saving.persist.pacer.poll(committed, now) {
            Snapshot::Take => {
                self.saving.persist.taken += 1;
                (Some(self.to_session()), None)
            }
            Snapshot::WaitUntil(at) => (None, Some(at)),
            Snapshot::Idle => (None, None),
        }
    }

    /// The session as it stands, for saving.
    pub fn to_session(&self) -> Session {
        let mut prompts = self.panes.prompt.texts.clone();
        if matches!(self.editing, Editing::Prompt) {
            prompts.insert(
                template_name(self.work.approach, self.panes.prompt.agent),
                self.panes.prompt.editor_text(),
            );
        }
        prompts.retain(|name, text| self.panes.prompt.defaults.get(name) != Some(text));
        let draft = match &self.editing {
            Editing::Step {
                list,
                index,
                editor,
                ..
            } => Some(Draft {
                target: list.key().to_string(),
                index: *index,
                text: editor.lines().join(" "),
            }),
            _ => None,
        };
        Session {
            version: SESSION_VERSION,
            task_id: self.work.task.id.clone(),
            approach: self.work.approach,
            ground_truth_source: self.work.ground_truth_source.clone(),
            ground_truth: self.panes.ground_truth.items.clone(),
            plan_source: self.work.plan_source.clone(),
            plan: self.panes.plan.items.clone(),
            prompts,
            settings: self
                .runs
                .agents
                .iter()
                .map(|(a, v)| (*a, v.settings.clone()))
                .collect(),
            outputs: self
                .runs
                .agents
                .iter()
                .filter(|(_, v)| v.status == AgentStatus::Done)
                .map(|(a, v)| (*a, v.output.clone()))
                .collect(),
            ran_with: self
                .runs
                .agents
                .iter()
                .filter_map(|(a, v)| v.ran_with.clone().map(|r| (*a, r)))
                .collect(),
            theme: self
                .saving
                .kept
                .theme
                .clone()
                .unwrap_or_else(|| self.looks.theme.name.clone()),
            image: self.panes.scene.enabled,
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
            samples: self.saving.kept.samples.unwrap_or(self.work.samples),
            draft,
        }
    }

    pub(crate) fn restore(&mut self, s: Session) -> Vec<Cmd> {
        let mut cmds = Vec::new();
        if let Some(id) = &s.task_id {
            match self.work.dataset.as_ref().and_then(|d| d.task(id)).cloned() {
                Some(task) => {
                    self.work.task = task_view(&task);
                    cmds.extend(self.load_scene());
                }
                None => self.set_status(
                    format!("the session's task {id} is not in the loaded dataset; showing the demo task"),
                    Severity::Warn,
                ),
            }
        }
        self.set_approach(s.approach);
        self.work.ground_truth_source = s.ground_truth_source;
        self.panes.ground_truth.items = s.ground_truth;
        self.work.plan_source = s.plan_source;
        self.panes.plan.items = s.plan;
        for (name, text) in s.prompts {
            if let Some(prompt) = self.panes.prompt.texts.get_mut(&name) {
                *prompt = text;
            }
        }
        for (agent, view) in self.runs.agents.iter_mut() {
            if let Some(st) = s.settings.get(agent) {
                view.settings = st.clone();
            }
            if let Some(out) = s.outputs.get(agent) {
                view.output = out.clone();
                view.status = AgentStatus::Done;
            }
            view.ran_with = s.ran_with.get(agent).cloned();
        }
        if let Some(theme) = self.looks.themes.iter().find(|t| t.name == s.theme) {
            if !self.looks.no_color {
                self.looks.theme = theme.clone();
            }
        }
        self.use_configured_providers();
        self.panes.scene.enabled = s.image;
        self.runs.history = s.runs;
        for run in &mut self.runs.history {
            if run.state == RunState::Running {
                run.state = RunState::Cancelled;
                run.reason =
                    Some("cancelled: the workbench stopped during the run, not scored".into());
            }
        }
        for (agent, view) in self.runs.agents.iter_mut() {
            let last = self.runs.history.iter().rev().find_map(|r| {
                r.agents
                    .iter()
                    .find(|a| a.role == *agent && a.output.is_some() && a.error.is_none())
            });
            if let Some(record) = last.filter(|_| view.status == AgentStatus::Done) {
                view.usage = record.usage;
                view.duration_ms = record.elapsed_ms;
                view.cached = record.cached;
            }
        }
        self.work.samples = s.samples;
        self.refresh_graph();
        if let Some(draft) = s.draft {
            let list = if draft.target == StepList::GroundTruth.key() {
                StepList::GroundTruth
            } else {
                StepList::Plan
            };
            let len = self.panes.steps(list).len();
            let inserted = draft.index >= len;
            if inserted {
                self.panes.steps_mut(list).items.push(String::new());
            }
            let index = draft.index.min(len);
            self.editing = Editing::Step {
                list,
                index,
                editor: single_line_editor(&draft.text),
                inserted,
            };
            self.focus = match list {
                StepList::Plan => Pane::Plan,
                StepList::GroundTruth => Pane::GroundTruth,
            };
        }
        cmds
    }
}
