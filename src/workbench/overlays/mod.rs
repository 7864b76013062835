//! The modal views over the panes, each in its own module: help, pickers,
//! the model form, the run history and the diff of two runs, the framed
//! actions.

pub mod actions;
pub mod corrupt;
pub mod help;
pub mod model_form;
pub mod pickers;
pub mod prompt_sets;
pub mod runs;

use crossterm::event::KeyEvent;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;
use ratatui_textarea::TextArea;

use crate::workbench::app::App;
use crate::workbench::component::{self, Component};
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::message::Cmd;
use crate::workbench::overlays::help::{Close, Help};
use crate::workbench::overlays::model_form::ModelForm;
use crate::workbench::overlays::prompt_sets::{SetName, SetPicker};
use crate::workbench::panes::list_window;
use crate::workbench::theme::Theme;

/// A modal view over the panes.
#[derive(Debug, Clone)]
pub enum Overlay {
    /// Every key.
    Help,
    /// Choose a ground truth.
    GroundTruthPicker {
        /// The highlighted choice.
        selected: usize,
    },
    /// Type the path of a step file.
    StepFilePath(Box<TextArea<'static>>),
    /// Provider, model, temperature and token limit of an agent.
    ModelForm(ModelForm),
    /// The name to save the prompts under as a prompt set.
    PromptSetName(Box<SetName>),
    /// The saved prompt sets, to load one.
    PromptSetPicker(SetPicker),
    /// The history of runs and the diff of two.
    Runs(Box<runs::RunsOverlay>),
    /// The framed actions and their matches.
    Actions,
    /// Choose how to corrupt the plan into a new run.
    CorruptPicker {
        /// The highlighted kind.
        selected: usize,
    },
}

impl Overlay {
    /// The key context of this overlay; `None` for the help, which any key
    /// closes.
    pub fn context(&self) -> Option<Context> {
        match self {
            Overlay::Help => None,
            Overlay::GroundTruthPicker { .. } | Overlay::CorruptPicker { .. } => {
                Some(Context::Picker)
            }
            Overlay::StepFilePath(_) => Some(Context::PathPrompt),
            Overlay::ModelForm(_) => Some(Context::ModelForm),
            Overlay::PromptSetName(_) => Some(Context::SetName),
            Overlay::PromptSetPicker(_) => Some(Context::Picker),
            Overlay::Runs(view) => Some(view.context()),
            Overlay::Actions => Some(Context::Viewer),
        }
    }
}

/// `selected` moved by `delta` within a list of `len` items.
pub(crate) fn moved(selected: usize, delta: isize, len: usize) -> usize {
    selected
        .saturating_add_signed(delta)
        .min(len.saturating_sub(1))
}

impl App {
    /// A key while an overlay is open: looked up in the overlay's context
    /// and handled by the overlay's module.
    pub(crate) fn on_overlay_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let Some(overlay) = self.overlay.take() else {
            return Vec::new();
        };
        let action = overlay
            .context()
            .and_then(|context| keymap::action(&[context], &key));
        match overlay {
            Overlay::Help => {
                let Close = component::dispatch(&mut Help, &key);
                Vec::new()
            }
            Overlay::Actions => {
                if action != Some(Action::Leave) {
                    self.overlay = Some(overlay);
                }
                Vec::new()
            }
            Overlay::GroundTruthPicker { selected } => self.on_picker_key(selected, action),
            Overlay::CorruptPicker { selected } => self.on_corrupt_picker_key(selected, action),
            Overlay::StepFilePath(editor) => self.on_path_key(editor, action, key),
            Overlay::ModelForm(form) => self.on_model_form_key(form, key),
            Overlay::PromptSetName(prompt) => self.on_set_name_key(prompt, key),
            Overlay::PromptSetPicker(picker) => self.on_set_picker_key(picker, key),
            Overlay::Runs(mut view) => {
                let outcome = component::dispatch(view.as_mut(), &key);
                self.on_runs_outcome(view, outcome)
            }
        }
    }
}

/// A `width`×`height` box in the middle of `area` (smaller when it must be).
pub(crate) fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let w = width.min(area.width.saturating_sub(2));
    let h = height.min(area.height.saturating_sub(2));
    Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    )
}

pub(crate) fn frame_box<'a>(app: &App, title: &'a str) -> Block<'a> {
    themed_box(&app.theme, title)
}

/// The frame of an overlay, titled `title`, in `theme`'s colours.
pub(crate) fn themed_box<'a>(theme: &Theme, title: &'a str) -> Block<'a> {
    Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus)
        .style(theme.base)
        .title(Span::styled(format!(" {title} "), theme.title))
}

/// Clears a centred `width`×`height` box, draws its frame titled `title`,
/// and returns the area inside the frame.
pub(crate) fn open_box(
    frame: &mut Frame,
    app: &App,
    area: Rect,
    size: (u16, u16),
    title: &str,
) -> Rect {
    let rect = centred(area, size.0, size.1);
    frame.render_widget(Clear, rect);
    let block = frame_box(app, title);
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    inner
}

/// Draws the open overlay, if any.
pub(crate) fn render_overlay(frame: &mut Frame, app: &App, area: Rect) {
    let Some(overlay) = &app.overlay else { return };
    let t = &app.theme;
    match overlay {
        Overlay::Help => Help.draw(frame, area, t),
        Overlay::GroundTruthPicker { selected } => {
            let choices = app.ground_truth_choices();
            let rect = centred(area, 90, choices.len() as u16 + 2);
            let inner_height = rect.height.saturating_sub(2) as usize;
            let (first, count) = list_window(*selected, choices.len(), 1, inner_height);
            let lines: Vec<Line> = choices
                .iter()
                .enumerate()
                .skip(first)
                .take(count)
                .map(|(i, (_, label))| {
                    let style = if i == *selected { t.selection } else { t.base };
                    Line::from(Span::styled(label.clone(), style))
                })
                .collect();
            frame.render_widget(Clear, rect);
            frame.render_widget(
                Paragraph::new(lines).block(frame_box(app, "Ground truth (Enter chooses)")),
                rect,
            );
        }
        Overlay::StepFilePath(editor) => {
            let inner = open_box(
                frame,
                app,
                area,
                (80, 3),
                "Step file path (Enter loads, Esc cancels)",
            );
            frame.render_widget(editor.as_ref(), inner);
        }
        Overlay::ModelForm(form) => form.draw(frame, area, t),
        Overlay::PromptSetName(prompt) => prompt.draw(frame, area, t),
        Overlay::PromptSetPicker(picker) => picker.draw(frame, area, t),
        Overlay::Runs(view) => view.draw(frame, area, t),
        Overlay::Actions => actions::draw(frame, app, area),
        Overlay::CorruptPicker { selected } => corrupt::draw(frame, app, area, *selected),
    }
}

pub(crate) fn fmt_score(v: Option<f64>) -> String {
    v.map_or("–".to_string(), |v| format!("{v:.3}"))
}
