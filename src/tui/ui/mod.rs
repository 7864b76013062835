//! Rendering: a pure function from the workbench's state to a frame.

mod graph;
pub mod layout;
pub(crate) mod overlays;
mod panes;

use ratatui::layout::{Alignment, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph, Wrap};
use ratatui::Frame;

use super::app::{App, Editing, ModelStatus, Pane, Severity};
use super::keymap;
use layout::{pane_rects, Screen, MIN_HEIGHT, MIN_WIDTH};

/// The visible window of a list of items `item_height` rows tall that keeps
/// `selected` in view: (first item shown, number of items shown).
pub fn list_window(
    selected: usize,
    len: usize,
    item_height: usize,
    height: usize,
) -> (usize, usize) {
    let fits = (height / item_height.max(1)).max(1);
    let first = if selected >= fits {
        selected + 1 - fits
    } else {
        0
    };
    (first, fits.min(len.saturating_sub(first)))
}

/// The part of the Scene pane the image is drawn in: inside the border,
/// below the caption line.
pub fn scene_image_area(pane: Rect) -> Rect {
    let inner = Block::bordered().inner(pane);
    Rect {
        y: inner.y.saturating_add(1),
        height: inner.height.saturating_sub(1),
        ..inner
    }
}

/// Splits `text` into spans, with every case-insensitive occurrence of
/// `needle` in the highlight style.
pub(crate) fn highlighted<'a>(
    text: &'a str,
    needle: &str,
    base: Style,
    hit: Style,
) -> Vec<Span<'a>> {
    if needle.is_empty() {
        return vec![Span::styled(text, base)];
    }
    let lower = text.to_lowercase();
    let needle = needle.to_lowercase();
    if lower.len() != text.len() {
        return vec![Span::styled(text, base)];
    }
    let mut spans = Vec::new();
    let mut at = 0;
    while let Some(found) = lower[at..].find(&needle) {
        let start = at + found;
        let end = start + needle.len();
        if start > at {
            spans.push(Span::styled(&text[at..start], base));
        }
        spans.push(Span::styled(&text[start..end], hit));
        at = end;
    }
    if at < text.len() {
        spans.push(Span::styled(&text[at..], base));
    }
    spans
}

/// The bordered block of a pane, with its title and the focus border.
pub(crate) fn pane_block<'a>(app: &App, pane: Pane, extra: Option<Span<'a>>) -> Block<'a> {
    let focused = app.focus == pane;
    let mut title = vec![Span::styled(format!(" {} ", pane.title()), app.theme.title)];
    if let Some(extra) = extra {
        title.push(extra);
        title.push(Span::styled(" ", app.theme.title));
    }
    Block::default()
        .borders(Borders::ALL)
        .border_type(if focused {
            ratatui::widgets::BorderType::Thick
        } else {
            ratatui::widgets::BorderType::Plain
        })
        .border_style(if focused {
            app.theme.focus
        } else {
            app.theme.border
        })
        .style(app.theme.base)
        .title(Line::from(title))
}

/// Draws the whole workbench.
pub fn render(frame: &mut Frame, app: &App) {
    let area = frame.area();
    frame.render_widget(Block::default().style(app.theme.base), area);
    let Screen::Panes {
        header,
        status,
        tabs,
        panes,
    } = pane_rects(area, app.focus, app.zoom)
    else {
        let text = format!(
            "mapvlm needs a terminal of at least {MIN_WIDTH}×{MIN_HEIGHT}; this one is {}×{}.\nEnlarge the window (q quits).",
            area.width, area.height
        );
        frame.render_widget(
            Paragraph::new(text)
                .style(app.theme.warn)
                .wrap(Wrap { trim: true })
                .alignment(Alignment::Center),
            area,
        );
        return;
    };
    render_header(frame, app, header);
    if let Some(tabs) = tabs {
        render_tabs(frame, app, tabs);
    }
    for (pane, rect) in panes {
        panes::render_pane(frame, app, pane, rect);
    }
    render_status(frame, app, status);
    overlays::render_overlay(frame, app, area);
}

fn render_header(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let source = match &app.task.id {
        Some(id) => id.clone(),
        None => "demo".to_string(),
    };
    let models = match &app.models {
        ModelStatus::Ready => Span::styled("models ready", t.good),
        ModelStatus::Loading(p) => Span::styled(format!("models loading: {p}"), t.warn),
        ModelStatus::Unavailable(_) => Span::styled("PG2S models missing", t.warn),
    };
    let line = Line::from(vec![
        Span::styled(" mapvlm ", t.title),
        Span::styled("│ ", t.border),
        Span::styled(source, t.accent),
        Span::styled(" │ ", t.border),
        Span::styled(app.task.text.clone(), t.base),
        Span::styled(" │ ", t.border),
        Span::styled(app.approach.name(), t.accent),
        Span::styled(" │ ", t.border),
        models,
    ]);
    frame.render_widget(Paragraph::new(line).style(t.base), area);
}

fn render_tabs(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let mut spans = Vec::new();
    for pane in Pane::ALL {
        let style = if pane == app.focus {
            t.selection
        } else {
            t.muted
        };
        spans.push(Span::styled(format!(" {} ", pane.short()), style));
        spans.push(Span::styled("│", t.border));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)).style(t.base), area);
}

fn render_status(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let context = app.editing.context();
    let hints = keymap::hints(context);
    let mode = match context.mode() {
        Some(mode) => format!("{mode}: {hints}"),
        None => hints,
    };
    let mut spans = vec![Span::styled(format!(" {mode} "), t.accent)];
    if let Editing::Search(_) = &app.editing {
        spans.push(Span::styled(format!("/{}", app.search), t.highlight));
    }
    if let Some((text, severity)) = &app.status {
        let style = match severity {
            Severity::Info => t.muted,
            Severity::Warn => t.warn,
            Severity::Error => t.bad,
        };
        spans.push(Span::styled("│ ", t.border));
        spans.push(Span::styled(text.clone(), style));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)).style(t.base), area);
}
