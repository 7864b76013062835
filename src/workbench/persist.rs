//! What of the workbench a session file keeps, restoring it, and when the
//! loop copies it for the saver ([`Persist`]).

use std::time::Instant;

use crate::agents::prompts::template_name;
use crate::dataset::Task;
use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::message::Cmd;
use crate::workbench::panes::steps::StepList;
use crate::workbench::panes::Pane;
use crate::workbench::session::{Draft, Session, SESSION_VERSION};
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
            current: self.source_state(),
            parked: self.work.parked.clone(),
            prompts,
            theme: self
                .saving
                .kept
                .theme
                .clone()
                .unwrap_or_else(|| self.looks.theme.name.clone()),
            image: self.panes.scene.enabled,
            samples: self.saving.kept.samples.unwrap_or(self.work.samples),
            draft,
        }
    }

    /// Puts a saved session in place with `task` in use (`None`: the
    /// demo): the session's source for it when it has one, else a fresh
    /// start on it; every other source the session holds is parked, kept
    /// for when it is opened again. The draft comes back only on the
    /// source it was typed in.
    pub(crate) fn restore(&mut self, s: Session, task: Option<&Task>) -> Vec<Cmd> {
        for (name, text) in s.prompts {
            if let Some(prompt) = self.panes.prompt.texts.get_mut(&name) {
                *prompt = text;
            }
        }
        if let Some(theme) = self.looks.themes.iter().find(|t| t.name == s.theme) {
            if !self.looks.no_color {
                self.looks.theme = theme.clone();
            }
        }
        self.panes.scene.enabled = s.image;
        let wanted = task.map(|t| t.id.clone());
        let same = s.current.task_id == wanted;
        let kept = (!same).then(|| s.current.task_id.clone()).flatten();
        self.work.parked = s.parked;
        self.work.parked.retain(|p| p.task_id != s.current.task_id);
        self.work.parked.push(s.current);
        let cmds = self.open_source(task);
        if let Some(id) = kept {
            // A start notice, so that the demo's first run does not hide it.
            let opened = wanted.as_deref().unwrap_or("the demo");
            let text = format!(
                "{opened} opened; the session's task {id} and its runs are kept for when it is opened again (Esc hides this)"
            );
            self.messages.notice.get_or_insert((text, Severity::Info));
        }
        self.work.samples = s.samples;
        let draft = s.draft.filter(|_| same);
        if let Some(draft) = draft {
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
