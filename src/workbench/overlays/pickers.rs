//! The ground-truth picker and the step-file path prompt.

use ratatui_textarea::TextArea;

use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;
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
                self.ground_truth = demo_ground_truth(index);
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
                self.ground_truth = vec![String::new()];
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
        self.ground_truth_selected = 0;
        vec![self.rescore()]
    }
}
