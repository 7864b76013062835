//! The editors that take the keyboard: a step, the prompt, the search.

use crossterm::event::KeyEvent;
use ratatui_textarea::TextArea;

use crate::workbench::app::App;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::message::Cmd;
use crate::workbench::panes::steps::StepList;
use crate::workbench::panes::Pane;
use crate::workbench::session::GroundTruthSource;
use crate::workbench::shared::Severity;

/// An editor in use.
#[derive(Debug, Clone)]
pub enum Editing {
    /// No editor: keys are commands.
    None,
    /// Editing one step.
    Step {
        /// The list.
        list: StepList,
        /// The step's index.
        index: usize,
        /// The editor.
        editor: TextArea<'static>,
        /// Whether the step was inserted for this edit (Esc removes it).
        inserted: bool,
    },
    /// Editing the selected agent's prompt.
    Prompt,
    /// Typing a search.
    Search(TextArea<'static>),
}

impl Editing {
    /// The key context of this editor ([`Context::Panes`] when none is open).
    pub fn context(&self) -> Context {
        match self {
            Editing::None => Context::Panes,
            Editing::Step { .. } => Context::StepEditor,
            Editing::Prompt => Context::PromptEditor,
            Editing::Search(_) => Context::Search,
        }
    }
}

impl App {
    pub(crate) fn on_editor_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let action = keymap::action(&[self.editing.context()], &key);
        match std::mem::replace(&mut self.editing, Editing::None) {
            Editing::Step {
                list,
                index,
                mut editor,
                inserted,
            } => match action {
                Some(Action::Accept) => {
                    let text = editor.lines().join(" ");
                    let mut before = self.steps_before(list);
                    if inserted {
                        before.steps.items.remove(index);
                    }
                    self.panes.steps_mut(list).commit(index, &text);
                    if self.panes.steps(list).items != before.steps.items {
                        self.panes.undo.push(before);
                    }
                    if list == StepList::GroundTruth {
                        self.work.ground_truth_source = GroundTruthSource::Typed;
                    }
                    vec![self.rescore()]
                }
                Some(Action::Leave) => {
                    self.panes.steps_mut(list).discard(index, inserted);
                    vec![self.rescore()]
                }
                _ => {
                    if action == Some(Action::Undo) {
                        editor.undo();
                    } else {
                        editor.input(key);
                    }
                    self.editing = Editing::Step {
                        list,
                        index,
                        editor,
                        inserted,
                    };
                    vec![self.rescore()]
                }
            },
            Editing::Prompt => {
                if action == Some(Action::Leave) {
                    self.panes.prompt.store_editor(self.work.approach);
                    self.saving.session_dirty = true;
                    if let Some(note) = self.provider_note() {
                        self.set_status(note, Severity::Warn);
                    }
                    return Vec::new();
                }
                if action == Some(Action::RunFromEditor) {
                    self.panes.prompt.store_editor(self.work.approach);
                    self.saving.session_dirty = true;
                    return self.start_run(false);
                }
                self.panes.prompt.editor.input(key);
                self.editing = Editing::Prompt;
                self.saving.session_dirty = true;
                Vec::new()
            }
            Editing::Search(mut editor) => {
                match action {
                    Some(Action::Leave) => self.panes.search.clear(),
                    Some(Action::Accept) => self.jump_to_search(),
                    _ => {
                        editor.input(key);
                        self.panes.search = editor.lines().join("");
                        self.editing = Editing::Search(editor);
                    }
                }
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    pub(crate) fn on_paste(&mut self, text: &str) -> Vec<Cmd> {
        let flat = text.replace(['\r', '\n'], " ");
        match &mut self.editing {
            Editing::Step { editor, .. } => {
                editor.insert_str(&flat);
                vec![self.rescore()]
            }
            Editing::Prompt => {
                self.panes.prompt.editor.insert_str(text);
                self.saving.session_dirty = true;
                Vec::new()
            }
            Editing::Search(editor) => {
                editor.insert_str(&flat);
                self.panes.search = editor.lines().join("");
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    /// Moves the focused list's selection to the next step holding the search.
    pub(crate) fn jump_to_search(&mut self) {
        if self.panes.search.is_empty() {
            return;
        }
        let list = match self.focus {
            Pane::GroundTruth => StepList::GroundTruth,
            _ => StepList::Plan,
        };
        let hit = self.panes.steps(list).next_hit(&self.panes.search);
        match hit {
            Some(i) => self.panes.steps_mut(list).selected = i,
            None => self.set_status(
                format!("no step holds “{}”", self.panes.search),
                Severity::Info,
            ),
        }
    }
}
