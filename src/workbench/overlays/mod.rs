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

use crossterm::event::{MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Margin, Position, Rect};
use ratatui::text::Span;
use ratatui::widgets::{Block, Borders, Clear};
use ratatui::Frame;

use crate::workbench::component::Component;
use crate::workbench::keymap::{Action, Context};
use crate::workbench::overlays::actions::ActionsView;
use crate::workbench::overlays::corrupt::CorruptPicker;
use crate::workbench::overlays::help::Help;
use crate::workbench::overlays::model_form::ModelForm;
use crate::workbench::overlays::pickers::{GroundTruthPicker, PathPrompt};
use crate::workbench::overlays::prompt_sets::{SetName, SetPicker};
use crate::workbench::panes::list_window;
use crate::workbench::scroll::wheel_step;
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
    /// screen's resizing reaches (the wheel reaches it as its component).
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

/// A list of `len` rows in a box `width` wide and at most `len + 2` tall,
/// centred in `area`, `selected` kept in view: the box, the first row
/// shown and how many are. Drawing and the mouse share it, so a click
/// lands on the row drawn where it is.
pub(crate) fn list_box(
    area: Rect,
    width: u16,
    len: usize,
    selected: usize,
) -> (Rect, usize, usize) {
    let rect = centred(area, width, u16::try_from(len + 2).unwrap_or(u16::MAX));
    let (first, count) = list_window(selected, len, 1, usize::from(rect.height.saturating_sub(2)));
    (rect, first, count)
}

/// What the mouse does to a list drawn by [`list_box`] (`width` wide,
/// `len` rows, `selected` highlighted): the row selected after it and the
/// action to carry out. A click on a row selects it, a click on the
/// selected row chooses it (Enter), the wheel moves as ↓ and ↑ do.
pub(crate) fn list_mouse(
    mouse: &MouseEvent,
    area: Rect,
    width: u16,
    len: usize,
    selected: usize,
) -> (usize, Action) {
    let (rect, first, count) = list_box(area, width, len, selected);
    let inner = rect.inner(Margin::new(1, 1));
    let clicked = (mouse.kind == MouseEventKind::Down(MouseButton::Left)
        && inner.contains(Position::new(mouse.column, mouse.row)))
    .then(|| first + usize::from(mouse.row - inner.y))
    .filter(|&row| row < first + count);
    match clicked {
        Some(row) if row == selected => (row, Action::Accept),
        Some(row) => (row, Action::Move(0)),
        None => (selected, Action::Move(wheel_step(mouse))),
    }
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

impl Overlay {
    /// Draws the overlay over `area`.
    pub fn draw(&self, frame: &mut Frame, area: Rect, t: &Theme) {
        match self {
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
}
