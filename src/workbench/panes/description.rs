//! The Grounded Description pane: the GKM's output.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::Frame;

use super::Shared;
use crate::agents::AgentRole;
use crate::workbench::panes::{agent_badge, highlighted, pane_block, Pane};
use crate::workbench::scroll::{self, Scroll};

/// The description, wrapped to `width`, search hits highlighted (a hint
/// while there is none).
fn lines(app: &Shared, width: u16) -> Vec<Line<'static>> {
    let t = app.theme;
    let output = app
        .runs
        .agents
        .get(&AgentRole::Gkm)
        .map(|v| v.output.as_str())
        .unwrap_or_default();
    let text: Vec<Line> = if output.is_empty() {
        vec![Line::from(Span::styled(
            "No description yet: r runs the agents.",
            t.muted,
        ))]
    } else {
        output
            .lines()
            .map(|l| Line::from(highlighted(l, &app.panes.search, t.base, t.highlight)))
            .collect()
    };
    scroll::wrap_text(&text, width.into())
}

/// The furthest the description scrolls in a pane drawn in `area`.
pub(crate) fn scroll_limit(app: &Shared, area: Rect) -> usize {
    let inner = pane_block(app, Pane::Description, None, area.width).inner(area);
    lines(app, inner.width)
        .len()
        .saturating_sub(usize::from(inner.height))
}

pub(crate) fn draw(frame: &mut Frame, app: &Shared, area: Rect) {
    let t = app.theme;
    let block = pane_block(
        app,
        Pane::Description,
        Some(agent_badge(app, AgentRole::Gkm)),
        area.width,
    );
    let offset = app
        .panes
        .scroll
        .get(&Pane::Description)
        .copied()
        .unwrap_or(0);
    let text = lines(app, block.inner(area).width);
    scroll::render(
        frame,
        area,
        block,
        &text,
        Scroll::at(offset.into()),
        t.accent,
    );
}
