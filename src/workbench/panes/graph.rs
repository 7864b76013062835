//! The Knowledge Graph pane: the SKM's triples as a whole graph, or one
//! node's neighbourhood.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use crate::agents::graph::{parse_triples, KnowledgeGraph};
use crate::agents::AgentRole;
use crate::workbench::app::App;
use crate::workbench::graph_view::GraphWidget;
use crate::workbench::panes::{agent_badge, pane_block, Pane};

/// The graph view's position.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GraphCursor {
    /// The node in the centre.
    pub node: usize,
    /// The highlighted neighbour.
    pub neighbour: usize,
    /// Nodes visited before, for going back.
    pub back: Vec<usize>,
}

/// How the Knowledge Graph pane draws the graph (`v` switches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum GraphMode {
    /// Every node and labelled edge, laid out in layers.
    #[default]
    Whole,
    /// One node with its incoming and outgoing edges.
    Neighbourhood,
}

impl App {
    pub(crate) fn refresh_graph(&mut self) {
        let output = self
            .agents
            .get(&AgentRole::Skm)
            .map(|v| v.output.as_str())
            .unwrap_or_default();
        self.graph = KnowledgeGraph::from_triples(&parse_triples(output).triples);
        if self.graph_cursor.node >= self.graph.nodes.len() {
            self.graph_cursor = GraphCursor::default();
        }
        self.graph_view.set_graph(&self.graph);
    }

    /// The neighbours of the graph view's node in the order the view lists
    /// them: the sources of the edges into it, then the targets of the edges
    /// out of it (a neighbour joined both ways appears twice).
    pub fn graph_neighbours(&self) -> Vec<usize> {
        let node = self.graph_cursor.node;
        self.graph
            .incoming(node)
            .map(|e| e.from)
            .chain(self.graph.outgoing(node).map(|e| e.to))
            .collect()
    }

    pub(crate) fn graph_enter(&mut self) {
        let neighbours = self.graph_neighbours();
        if let Some(&next) = neighbours.get(self.graph_cursor.neighbour) {
            let here = self.graph_cursor.node;
            self.graph_cursor.back.push(here);
            self.graph_cursor.node = next;
            self.graph_cursor.neighbour = 0;
        }
    }

    pub(crate) fn graph_back(&mut self) {
        if let Some(prev) = self.graph_cursor.back.pop() {
            self.graph_cursor.node = prev;
            self.graph_cursor.neighbour = 0;
        }
    }
}

/// Draws the Knowledge Graph pane.
pub(crate) fn draw(frame: &mut Frame, app: &App, area: Rect) {
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
