//! The Grounded Description pane: the GKM's output.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span, Text};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use crate::agents::AgentRole;
use crate::workbench::app::App;
use crate::workbench::panes::{agent_badge, highlighted, pane_block, Pane};

pub(crate) fn draw(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.looks.theme;
    let block = pane_block(
        app,
        Pane::Description,
        Some(agent_badge(app, AgentRole::Gkm)),
    );
    let output = app
        .runs
        .agents
        .get(&AgentRole::Gkm)
        .map(|v| v.output.as_str())
        .unwrap_or_default();
    let text: Text = if output.is_empty() {
        Text::from(Span::styled(
            "No description yet: r runs the agents.",
            t.muted,
        ))
    } else {
        Text::from(
            output
                .lines()
                .map(|l| Line::from(highlighted(l, &app.panes.search, t.base, t.highlight)))
                .collect::<Vec<_>>(),
        )
    };
    let scroll = app
        .panes
        .scroll
        .get(&Pane::Description)
        .copied()
        .unwrap_or(0);
    frame.render_widget(
        Paragraph::new(text)
            .block(block)
            .wrap(Wrap { trim: false })
            .scroll((scroll, 0)),
        area,
    );
}
