//! The ground-truth picker and the step-file path prompt.

use std::path::PathBuf;

use crossterm::event::KeyEvent;
use ratatui_textarea::TextArea;

use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::keymap::Action;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::{moved, Overlay};
use crate::workbench::panes::steps::{demo_ground_truth, StepList};
use crate::workbench::panes::Pane;
use crate::workbench::session::GroundTruthSource;

/// A ground truth the picker offers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GroundTruthChoice {
    /// A demo ground truth.
    Demo(usize),
    /// A dataset task, by index.
    Task(usize),
    /// Read a step file.
    File,
    /// Type a new one.
    Typed,
}

impl App {
    /// A key of the ground-truth picker.
    pub(crate) fn on_picker_key(&mut self, selected: usize, action: Option<Action>) -> Vec<Cmd> {
        let choices = self.ground_truth_choices();
        match action {
            Some(Action::Accept) => {
                if let Some((choice, _)) = choices.get(selected) {
                    return self.choose_ground_truth(choice.clone());
                }
            }
            Some(Action::Leave) => {}
            Some(Action::Move(delta)) => {
                self.overlay = Some(Overlay::GroundTruthPicker {
                    selected: moved(selected, delta, choices.len()),
                });
            }
            _ => self.overlay = Some(Overlay::GroundTruthPicker { selected }),
        }
        Vec::new()
    }

    /// A key of the step-file path prompt: other keys are typed.
    pub(crate) fn on_path_key(
        &mut self,
        mut editor: Box<TextArea<'static>>,
        action: Option<Action>,
        key: KeyEvent,
    ) -> Vec<Cmd> {
        match action {
            Some(Action::Accept) => {
                let path = PathBuf::from(editor.lines().join("").trim());
                vec![Cmd::ReadStepFile(path)]
            }
            Some(Action::Leave) => Vec::new(),
            _ => {
                editor.input(key);
                self.overlay = Some(Overlay::StepFilePath(editor));
                Vec::new()
            }
        }
    }

    /// The ground truths the picker offers, with their labels.
    pub fn ground_truth_choices(&self) -> Vec<(GroundTruthChoice, String)> {
        let mut out = Vec::new();
        if self.task.id.is_none() {
            out.push((
                GroundTruthChoice::Demo(0),
                "Demo: annotator A's ground truth".to_string(),
            ));
            out.push((
                GroundTruthChoice::Demo(1),
                "Demo: annotator B's ground truth".to_string(),
            ));
        }
        if let Some(ds) = &self.dataset {
            for (i, t) in ds.tasks.iter().enumerate() {
                out.push((GroundTruthChoice::Task(i), format!("{} · {}", t.id, t.task)));
            }
        }
        out.push((GroundTruthChoice::File, "Load a step file…".to_string()));
        out.push((
            GroundTruthChoice::Typed,
            "Type a new ground truth".to_string(),
        ));
        out
    }

    pub(crate) fn choose_ground_truth(&mut self, choice: GroundTruthChoice) -> Vec<Cmd> {
        self.overlay = None;
        match choice {
            GroundTruthChoice::Demo(index) => {
                self.ground_truth.items = demo_ground_truth(index);
                self.ground_truth_source = GroundTruthSource::Demo { index };
            }
            GroundTruthChoice::Task(index) => {
                let Some(task) = self
                    .dataset
                    .as_ref()
                    .and_then(|d| d.tasks.get(index))
                    .cloned()
                else {
                    return Vec::new();
                };
                let mut cmds = self.switch_task(&task);
                cmds.push(self.rescore());
                return cmds;
            }
            GroundTruthChoice::File => {
                self.overlay = Some(Overlay::StepFilePath(Box::default()));
                return Vec::new();
            }
            GroundTruthChoice::Typed => {
                self.ground_truth.items = vec![String::new()];
                self.ground_truth_source = GroundTruthSource::Typed;
                self.focus = Pane::GroundTruth;
                self.editing = Editing::Step {
                    list: StepList::GroundTruth,
                    index: 0,
                    editor: TextArea::default(),
                    inserted: true,
                };
            }
        }
        self.ground_truth.selected = 0;
        vec![self.rescore()]
    }
}
