//! The ground-truth picker and the step-file path prompt, each a
//! [`Component`] that owns what it shows: the picker the choices offered
//! when it opened, the prompt the path being typed.

use std::path::PathBuf;

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;
use ratatui_textarea::TextArea;

use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::overlays::{list_box, list_mouse, moved, open_box, themed_box, Picked};
use crate::workbench::session::GroundTruthSource;
use crate::workbench::theme::Theme;
use crate::workbench::workspace::Workspace;

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

/// How wide the ground-truth picker's box is.
const PICKER_WIDTH: u16 = 90;

/// The ground-truth picker (`g`): the choices with their labels, one
/// highlighted.
#[derive(Debug, Clone)]
pub struct GroundTruthPicker {
    choices: Vec<(GroundTruthChoice, String)>,
    selected: usize,
}

impl GroundTruthPicker {
    /// A picker over `choices`, on the one at `selected`.
    pub fn new(choices: Vec<(GroundTruthChoice, String)>, selected: usize) -> GroundTruthPicker {
        GroundTruthPicker { choices, selected }
    }

    /// `g`: a picker over what `work` offers, on the ground truth in use.
    pub fn open(work: &Workspace) -> GroundTruthPicker {
        let choices = ground_truth_choices(work);
        let selected = choices
            .iter()
            .position(|(c, _)| match (c, &work.ground_truth_source) {
                (GroundTruthChoice::Demo(i), GroundTruthSource::Demo { index }) => i == index,
                (GroundTruthChoice::Task(i), GroundTruthSource::Dataset { task }) => work
                    .dataset
                    .as_ref()
                    .and_then(|d| d.tasks.get(*i))
                    .is_some_and(|t| &t.id == task),
                _ => false,
            })
            .unwrap_or(0);
        GroundTruthPicker::new(choices, selected)
    }
}

/// The ground truths the picker offers on `work`, with their labels: the
/// demo's two (or the demo itself, from a dataset task), each dataset
/// task, a step file, or typing one.
pub fn ground_truth_choices(work: &Workspace) -> Vec<(GroundTruthChoice, String)> {
    let mut out = Vec::new();
    if work.is_demo() {
        out.push((
            GroundTruthChoice::Demo(0),
            "Demo: annotator A's ground truth".to_string(),
        ));
        out.push((
            GroundTruthChoice::Demo(1),
            "Demo: annotator B's ground truth".to_string(),
        ));
    }
    if let Some(ds) = &work.dataset {
        for (i, t) in ds.tasks.iter().enumerate() {
            out.push((GroundTruthChoice::Task(i), format!("{} · {}", t.id, t.task)));
        }
    }
    if !work.is_demo() {
        out.push((
            GroundTruthChoice::Demo(0),
            "Demo: the built-in task, with its own plan and runs".to_string(),
        ));
    }
    out.push((GroundTruthChoice::File, "Load a step file…".to_string()));
    out.push((
        GroundTruthChoice::Typed,
        "Type a new ground truth".to_string(),
    ));
    out
}

impl Component for GroundTruthPicker {
    type Outcome = Picked<GroundTruthChoice>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Picker]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Accept => self
                .choices
                .get(self.selected)
                .map_or(Picked::Cancelled, |(choice, _)| {
                    Picked::Chosen(choice.clone())
                }),
            Action::Leave => Picked::Cancelled,
            Action::Move(delta) => {
                self.selected = moved(self.selected, delta, self.choices.len());
                Picked::Open
            }
            _ => Picked::Open,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Self::Outcome {
        Picked::Open
    }

    /// A click selects a row, a click on the selected row chooses it, the
    /// wheel moves the selection.
    fn on_mouse(&mut self, mouse: MouseEvent, area: Rect) -> Self::Outcome {
        let (selected, action) = list_mouse(
            &mouse,
            area,
            PICKER_WIDTH,
            self.choices.len(),
            self.selected,
        );
        self.selected = selected;
        self.on_action(action)
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (rect, first, count) = list_box(area, PICKER_WIDTH, self.choices.len(), self.selected);
        let lines: Vec<Line> = self
            .choices
            .iter()
            .enumerate()
            .skip(first)
            .take(count)
            .map(|(i, (_, label))| {
                let style = if i == self.selected {
                    theme.selection
                } else {
                    theme.base
                };
                Line::from(Span::styled(label.clone(), style))
            })
            .collect();
        frame.render_widget(Clear, rect);
        frame.render_widget(
            Paragraph::new(lines).block(themed_box(
                theme,
                &format!("Ground truth ({})", keymap::hints(Context::Picker)),
            )),
            rect,
        );
    }
}

/// The step-file path prompt: the path being typed.
#[derive(Debug, Clone, Default)]
pub struct PathPrompt {
    editor: TextArea<'static>,
}

impl Component for PathPrompt {
    type Outcome = Picked<PathBuf>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::PathPrompt]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Accept => Picked::Chosen(PathBuf::from(self.editor.lines().join("").trim())),
            Action::Leave => Picked::Cancelled,
            _ => Picked::Open,
        }
    }

    fn on_other_key(&mut self, key: KeyEvent) -> Self::Outcome {
        self.editor.input(key);
        Picked::Open
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let inner = open_box(
            frame,
            theme,
            area,
            (80, 3),
            &format!("Step file path ({})", keymap::hints(Context::PathPrompt)),
        );
        frame.render_widget(&self.editor, inner);
    }
}

#[cfg(test)]
mod tests {
    use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

    use super::*;
    use crate::workbench::component::dispatch;

    fn press(code: KeyCode) -> KeyEvent {
        KeyEvent::new(code, KeyModifiers::NONE)
    }

    #[test]
    fn the_picker_moves_within_its_choices_and_chooses_the_highlighted_one() {
        let choices = vec![
            (GroundTruthChoice::Demo(0), "A".to_string()),
            (GroundTruthChoice::File, "file".to_string()),
        ];
        let mut picker = GroundTruthPicker::new(choices, 0);
        for _ in 0..3 {
            assert_eq!(dispatch(&mut picker, &press(KeyCode::Down)), Picked::Open);
        }
        assert_eq!(
            dispatch(&mut picker, &press(KeyCode::Char('x'))),
            Picked::Open
        );
        assert_eq!(
            dispatch(&mut picker, &press(KeyCode::Enter)),
            Picked::Chosen(GroundTruthChoice::File)
        );
        assert_eq!(
            dispatch(&mut picker, &press(KeyCode::Esc)),
            Picked::Cancelled
        );
    }

    #[test]
    fn the_path_prompt_types_keys_and_gives_the_trimmed_path() {
        let mut prompt = PathPrompt::default();
        for c in " a/b.txt ".chars() {
            assert_eq!(
                dispatch(&mut prompt, &press(KeyCode::Char(c))),
                Picked::Open
            );
        }
        assert_eq!(
            dispatch(&mut prompt, &press(KeyCode::Enter)),
            Picked::Chosen(PathBuf::from("a/b.txt"))
        );
        assert_eq!(
            dispatch(&mut prompt, &press(KeyCode::Esc)),
            Picked::Cancelled
        );
    }
}
