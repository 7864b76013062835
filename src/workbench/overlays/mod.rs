//! The modal views over the panes, each in its own module: help, pickers,
//! the model form, the run history and the diff of two runs, the framed
//! actions, the message log.

pub mod actions;
pub mod corrupt;
mod diff_page;
pub mod help;
pub mod log;
pub mod model_form;
pub mod pickers;
pub mod prompt_sets;
pub mod runs;

use crossterm::event::KeyEvent;
use ratatui::layout::Rect;
use ratatui::text::Span;
use ratatui::widgets::{Block, Borders, Clear};
use ratatui::Frame;

use crate::workbench::app::App;
use crate::workbench::component::{self, Component};
use crate::workbench::keymap::Context;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::actions::ActionsView;
use crate::workbench::overlays::corrupt::CorruptPicker;
use crate::workbench::overlays::help::Help;
use crate::workbench::overlays::model_form::ModelForm;
use crate::workbench::overlays::pickers::{GroundTruthPicker, PathPrompt};
use crate::workbench::overlays::prompt_sets::{SetName, SetPicker};
use crate::workbench::scroll::ScrolledBox;
use crate::workbench::theme::Theme;

/// A modal view over the panes.
#[derive(Debug, Clone)]
pub enum Overlay {
    /// Every key, scrolled.
    Help(Help),
    /// Choose a ground truth.
    GroundTruthPicker(GroundTruthPicker),
    /// Type the path of a step file.
    StepFilePath(Box<PathPrompt>),
    /// Provider, model, temperature and token limit of an agent.
    ModelForm(ModelForm),
    /// The name to save the prompts under as a prompt set.
    PromptSetName(Box<SetName>),
    /// The saved prompt sets, to load one.
    PromptSetPicker(SetPicker),
    /// The history of runs and the diff of two.
    Runs(Box<runs::RunsOverlay>),
    /// The framed actions and their matches.
    Actions(Box<ActionsView>),
    /// Choose how to corrupt the plan into a new run.
    CorruptPicker(CorruptPicker),
    /// Every status message so far.
    Log(Box<log::MessageLog>),
}

/// What a key in a picker or prompt asks of the workbench.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Picked<T> {
    /// The overlay stays open.
    Open,
    /// The overlay was closed.
    Cancelled,
    /// The overlay closed on this choice.
    Chosen(T),
}

impl Overlay {
    /// The key context of this overlay; `None` for the help, which any key
    /// closes.
    pub fn context(&self) -> Option<Context> {
        match self {
            Overlay::Help(help) => Some(help.context()),
            Overlay::GroundTruthPicker(_) | Overlay::CorruptPicker(_) => Some(Context::Picker),
            Overlay::StepFilePath(_) => Some(Context::PathPrompt),
            Overlay::ModelForm(_) => Some(Context::ModelForm),
            Overlay::PromptSetName(_) => Some(Context::SetName),
            Overlay::PromptSetPicker(_) => Some(Context::Picker),
            Overlay::Runs(view) => Some(view.context()),
            Overlay::Actions(_) | Overlay::Log(_) => Some(Context::Viewer),
        }
    }

    /// The overlay as a scrolled text box, when it is one: what the
    /// screen's resizing and the mouse wheel reach.
    pub fn scrolled_box(&mut self) -> Option<&mut dyn ScrolledBox> {
        match self {
            Overlay::Help(help) => Some(help),
            Overlay::Log(log) => Some(log.as_mut()),
            Overlay::Actions(view) => Some(view.as_mut()),
            _ => None,
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
        match overlay {
            Overlay::Help(help) => {
                let _ = self.pick(help, &key, Overlay::Help);
                Vec::new()
            }
            Overlay::Actions(view) => {
                // A viewer chooses nothing: it is put back or closed.
                let _ = self.pick(*view, &key, |v| Overlay::Actions(Box::new(v)));
                Vec::new()
            }
            Overlay::Log(view) => {
                let _ = self.pick(*view, &key, |v| Overlay::Log(Box::new(v)));
                Vec::new()
            }
            Overlay::GroundTruthPicker(picker) => {
                match self.pick(picker, &key, Overlay::GroundTruthPicker) {
                    Some(choice) => self.choose_ground_truth(choice),
                    None => Vec::new(),
                }
            }
            Overlay::CorruptPicker(picker) => match self.pick(picker, &key, Overlay::CorruptPicker)
            {
                Some(kind) => self.corrupt_with(kind),
                None => Vec::new(),
            },
            Overlay::StepFilePath(prompt) => {
                match self.pick(*prompt, &key, |p| Overlay::StepFilePath(Box::new(p))) {
                    Some(path) => vec![Cmd::ReadStepFile(path)],
                    None => Vec::new(),
                }
            }
            Overlay::ModelForm(form) => self.on_model_form_key(form, key),
            Overlay::PromptSetName(prompt) => self.on_set_name_key(prompt, key),
            Overlay::PromptSetPicker(picker) => self.on_set_picker_key(picker, key),
            Overlay::Runs(mut view) => {
                let outcome = component::dispatch(view.as_mut(), &key);
                self.on_runs_outcome(view, outcome)
            }
        }
    }

    /// Hands `key` to the open picker or prompt `overlay`: puts it back
    /// (made an [`Overlay`] by `reopen`) while it stays open, and returns
    /// what it chose.
    fn pick<C, T>(
        &mut self,
        mut overlay: C,
        key: &KeyEvent,
        reopen: impl FnOnce(C) -> Overlay,
    ) -> Option<T>
    where
        C: Component<Outcome = Picked<T>>,
    {
        match component::dispatch(&mut overlay, key) {
            Picked::Open => {
                self.overlay = Some(reopen(overlay));
                None
            }
            Picked::Cancelled => None,
            Picked::Chosen(choice) => Some(choice),
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
    theme: &Theme,
    area: Rect,
    size: (u16, u16),
    title: &str,
) -> Rect {
    let rect = centred(area, size.0, size.1);
    frame.render_widget(Clear, rect);
    let block = themed_box(theme, title);
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    inner
}

/// Draws the open overlay, if any.
pub(crate) fn render_overlay(frame: &mut Frame, app: &App, area: Rect) {
    let Some(overlay) = &app.overlay else { return };
    let t = &app.looks.theme;
    match overlay {
        Overlay::Help(help) => help.draw(frame, area, t),
        Overlay::GroundTruthPicker(picker) => picker.draw(frame, area, t),
        Overlay::StepFilePath(prompt) => prompt.draw(frame, area, t),
        Overlay::ModelForm(form) => form.draw(frame, area, t),
        Overlay::PromptSetName(prompt) => prompt.draw(frame, area, t),
        Overlay::PromptSetPicker(picker) => picker.draw(frame, area, t),
        Overlay::Runs(view) => view.draw(frame, area, t),
        Overlay::Actions(view) => view.draw(frame, area, t),
        Overlay::CorruptPicker(picker) => picker.draw(frame, area, t),
        Overlay::Log(view) => view.draw(frame, area, t),
    }
}
