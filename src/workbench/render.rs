//! Rendering: a pure function from the workbench's state to a frame.

use ratatui::layout::{Alignment, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;
use unicode_width::UnicodeWidthStr;

use crate::agents::ProviderKind;
use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::header::Header;
use crate::workbench::keymap;
use crate::workbench::layout::{Screen, MIN_HEIGHT, MIN_WIDTH};
use crate::workbench::panes::{self, Pane};
use crate::workbench::scoring::ModelSlot;
use crate::workbench::scroll;
use crate::workbench::scroll::truncate;
use crate::workbench::shared::{fold_to_ascii, Severity};

/// Draws the whole workbench.
pub fn render(frame: &mut Frame, app: &App) {
    let area = frame.area();
    frame.render_widget(Block::default().style(app.looks.theme.base), area);
    let Screen::Panes {
        header,
        status,
        tabs,
        panes,
    } = app.layout_in(area)
    else {
        frame.render_widget(
            Paragraph::new(too_small_text(area))
                .style(app.looks.theme.warn)
                .alignment(Alignment::Center),
            area,
        );
        if app.looks.ascii {
            fold_to_ascii(frame.buffer_mut());
        }
        return;
    };
    render_header(frame, app, header);
    if let Some(tabs) = tabs {
        render_tabs(frame, app, tabs);
    }
    let shared = app.shared();
    for (pane, rect) in panes {
        panes::render_pane(frame, &shared, pane, rect);
    }
    render_status(frame, app, status);
    if let Some(overlay) = &app.overlay {
        overlay.draw(frame, area, &app.looks.theme);
    }
    if app.looks.ascii {
        fold_to_ascii(frame.buffer_mut());
    }
}

/// What a terminal below the smallest size is told, wrapped to it: the
/// longest wording whose lines all fit, so the sizes are never cut off
/// (at 10×5 the full sentence needs nine lines and lost the size).
fn too_small_text(area: Rect) -> Vec<Line<'static>> {
    let (width, height) = (area.width, area.height);
    let wordings = [
        format!(
            "mapvlm needs a terminal of at least {MIN_WIDTH}×{MIN_HEIGHT}; this one is {width}×{height}. Enlarge the window (q quits)."
        ),
        format!("Needs {MIN_WIDTH}×{MIN_HEIGHT}, this is {width}×{height}. q quits."),
        format!("Needs {MIN_WIDTH}×{MIN_HEIGHT}, is {width}×{height}"),
        format!("{MIN_WIDTH}×{MIN_HEIGHT} needed"),
    ];
    let wrap = |text: &str| scroll::wrap_hanging(&[], &[Span::raw(text.to_string())], width.into());
    wordings
        .iter()
        .map(|text| wrap(text))
        .find(|lines| lines.len() <= usize::from(height))
        .unwrap_or_else(|| wrap(&wordings[wordings.len() - 1]))
}

fn render_header(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.looks.theme;
    let source = match &app.work.task.id {
        Some(id) => id.clone(),
        None => "demo".to_string(),
    };
    let models = match &app.work.models {
        ModelSlot::Ready(_) => Span::styled("models ready", t.good),
        ModelSlot::Loading(p) => Span::styled(format!("models loading: {p}"), t.warn),
        ModelSlot::Unavailable(_) => Span::styled("PG2S models missing", t.warn),
    };
    let graphics = &app.panes.scene.graphics;
    let header = Header {
        name: Span::styled(" mapvlm ", t.title),
        source: Span::styled(source, t.accent),
        graphics: (!graphics.is_empty()).then(|| Span::styled(graphics.clone(), t.muted)),
        task: Span::styled(app.work.task.text.clone(), t.base),
        approach: Span::styled(app.work.approach.name(), t.accent),
        providers: Span::styled(providers_in_use(app), t.accent),
        models,
        border: t.border,
    };
    frame.render_widget(Paragraph::new(header.line(area.width)).style(t.base), area);
}

/// Which provider each agent of the approach runs on, short: agents in a
/// row with the same provider and model share one entry, e.g.
/// `SKM·GKM·Planner replay` or `SKM·GKM openai/gpt-4o, Planner replay`.
pub fn providers_in_use(app: &App) -> String {
    let mut groups: Vec<(Vec<&str>, String)> = Vec::new();
    for &role in app.work.approach.roles() {
        let Some(view) = app.runs.agents.get(&role) else {
            continue;
        };
        let settings = &view.settings;
        let provider = if settings.provider == ProviderKind::Replay {
            settings.provider.to_string()
        } else {
            format!("{}/{}", settings.provider, settings.model)
        };
        match groups.last_mut() {
            Some((roles, last)) if *last == provider => roles.push(role.label()),
            _ => groups.push((vec![role.label()], provider)),
        }
    }
    let entries: Vec<String> = groups
        .into_iter()
        .map(|(roles, provider)| format!("{} {provider}", roles.join("·")))
        .collect();
    entries.join(", ")
}

fn render_tabs(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.looks.theme;
    let mut spans = Vec::new();
    for pane in Pane::ALL {
        let style = if pane == app.focus {
            t.selection
        } else {
            t.muted
        };
        spans.push(Span::styled(pane.tab(), style));
        spans.push(Span::styled("│", t.border));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)).style(t.base), area);
}

/// What ends a status message cut to the status line: where it is whole.
const LOG_POINTER: &str = " · M log";

fn render_status(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.looks.theme;
    let context = app.key_context();
    let hints = keymap::hints(context);
    let mode = match context.mode() {
        Some(mode) => format!("{mode}: {hints}"),
        None => hints,
    };
    let search = match &app.editing {
        Editing::Search(_) => Some(Span::styled(format!("/{}", app.panes.search), t.highlight)),
        _ => None,
    };
    let shown = app.status_messages();
    let width = usize::from(area.width);
    let messages_width: usize = shown.iter().map(|(text, _)| text.width() + 2).sum();
    let search_width = search.as_ref().map_or(0, Span::width);
    // A message the hints would push past the edge wins over them: the
    // hints are in the help (?), the message is said once.
    let hints = if mode.width() + 2 + search_width + messages_width > width && !shown.is_empty() {
        app.short_hints()
    } else {
        mode
    };
    let mut prefix = vec![Span::styled(format!(" {hints} "), t.accent)];
    prefix.extend(search);
    let mut body = Vec::new();
    for (text, severity) in shown {
        let style = match severity {
            Severity::Info => t.muted,
            Severity::Warn => t.warn,
            Severity::Error => t.bad,
        };
        body.push(Span::styled("│ ", t.border));
        body.push(Span::styled(text, style));
    }
    // Wrapped under the hints over the status line's rows (two while a
    // message needs them); what is still longer is cut on the last row,
    // with a mark that it was and where it is whole.
    let rows = usize::from(area.height.max(1));
    let mut lines = scroll::wrap_hanging(&prefix, &body, width);
    if lines.len() > rows {
        lines.truncate(rows);
        if let Some(last) = lines.last_mut() {
            let style = last.spans.last().map(|s| s.style).unwrap_or(t.muted);
            let text: String = last.spans.iter().map(|s| s.content.as_ref()).collect();
            let cut = truncate(text.trim_end(), width.saturating_sub(LOG_POINTER.width()));
            *last = Line::from(Span::styled(format!("{cut}{LOG_POINTER}"), style));
        }
    }
    frame.render_widget(Paragraph::new(lines).style(t.base), area);
}
