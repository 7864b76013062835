//! The Knowledge Graph pane: the whole graph ([`GraphWidget`]) or, as a
//! mode, the graph drawn around one node: the node in a box, the edges
//! coming in on the left and going out on the right, each neighbour one key
//! away; the other nodes listed below.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use super::pane_block;
use super::panes::agent_badge;
use crate::agents::AgentRole;
use crate::tui::app::{App, GraphMode, Pane};
use crate::tui::graph_view::GraphWidget;

/// Draws the Knowledge Graph pane.
pub(super) fn render(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let g = &app.graph;
    let block = pane_block(app, Pane::Graph, Some(agent_badge(app, AgentRole::Skm)));
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if g.nodes.is_empty() {
        frame.render_widget(
            Paragraph::new(Span::styled(
                "No triples yet: the SKM's (subject, relation, object) lines appear here as a graph.",
                t.muted,
            ))
            .wrap(Wrap { trim: true }),
            inner,
        );
        return;
    }
    if app.graph_mode == GraphMode::Whole {
        let widget = GraphWidget::new(&app.graph_view, t).focused(app.focus == Pane::Graph);
        frame.render_widget(widget, inner);
        return;
    }
    let node = app.graph_cursor.node.min(g.nodes.len() - 1);
    let name = &g.nodes[node];
    let incoming: Vec<(&str, usize)> = g
        .incoming(node)
        .map(|e| (e.label.as_str(), e.from))
        .collect();
    let outgoing: Vec<(&str, usize)> = g.outgoing(node).map(|e| (e.label.as_str(), e.to)).collect();
    let selected = app.graph_cursor.neighbour;
    let box_width = name.chars().count() + 4;
    let [header, body, footer] = Layout::vertical([
        Constraint::Length(3),
        Constraint::Min(1),
        Constraint::Length(1),
    ])
    .areas(inner);
    let pad = (header.width as usize).saturating_sub(box_width) / 2;
    let indent = " ".repeat(pad);
    let edge = "─".repeat(box_width.saturating_sub(2));
    let header_lines = vec![
        Line::from(Span::styled(format!("{indent}┌{edge}┐"), t.accent)),
        Line::from(vec![
            Span::styled(format!("{indent}│ "), t.accent),
            Span::styled(name.clone(), t.title),
            Span::styled(" │", t.accent),
            Span::styled(
                format!("  node {}/{} · [ ] others", node + 1, g.nodes.len()),
                t.muted,
            ),
        ]),
        Line::from(Span::styled(format!("{indent}└{edge}┘"), t.accent)),
    ];
    frame.render_widget(Paragraph::new(header_lines), header);
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(body);
    let style_for = |i: usize| {
        if i == selected && app.focus == Pane::Graph {
            t.selection
        } else {
            t.base
        }
    };
    let mut in_lines = vec![Line::from(Span::styled("◀ into it", t.muted))];
    for (i, (relation, from)) in incoming.iter().enumerate() {
        in_lines.push(Line::from(vec![
            Span::styled(g.nodes[*from].clone(), style_for(i)),
            Span::styled(format!(" ─{relation}─▶ ●"), t.muted),
        ]));
    }
    let mut out_lines = vec![Line::from(Span::styled("out of it ▶", t.muted))];
    for (k, (relation, to)) in outgoing.iter().enumerate() {
        out_lines.push(Line::from(vec![
            Span::styled(format!("● ─{relation}─▶ "), t.muted),
            Span::styled(g.nodes[*to].clone(), style_for(incoming.len() + k)),
        ]));
    }
    frame.render_widget(Paragraph::new(in_lines), left);
    frame.render_widget(Paragraph::new(out_lines), right);
    let others: Vec<Span> = g
        .nodes
        .iter()
        .enumerate()
        .flat_map(|(i, n)| {
            let style = if i == node { t.accent } else { t.muted };
            [
                Span::styled(n.clone(), style),
                Span::styled(" · ", t.border),
            ]
        })
        .collect();
    frame.render_widget(Paragraph::new(Line::from(others)), footer);
}
