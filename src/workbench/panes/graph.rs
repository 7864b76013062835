//! The Knowledge Graph pane: the SKM's triples as a whole graph (fitted to
//! the pane, or scrolled with what is hidden said), one node's
//! neighbourhood, or a list of the triples.

use crossterm::event::{KeyModifiers, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};
use ratatui::Frame;

use super::Shared;
use crate::agents::graph::{parse_triples, KnowledgeGraph};
use crate::agents::AgentRole;
use crate::workbench::graph_view::{GraphView, GraphWidget};
use crate::workbench::keymap::{Action, Context};
use crate::workbench::panes::{agent_badge, pane_block, Pane};
use crate::workbench::scroll::{self, wrap_hanging, Motion, Scroll, WHEEL_LINES};
use crate::workbench::theme::Theme;

/// What the pane says before the SKM has given any triple.
const NO_TRIPLES: &str =
    "No triples yet: the SKM's (subject, relation, object) lines appear here as a graph.";

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

/// The Knowledge Graph pane's state: the graph of the SKM's output, the
/// whole-graph view, the neighbourhood cursor and the list of triples.
#[derive(Debug, Clone, Default)]
pub struct GraphPane {
    /// The knowledge graph of the SKM output.
    pub kg: KnowledgeGraph,
    /// The neighbourhood view's position.
    pub cursor: GraphCursor,
    /// The whole-graph view: layouts, selection, zoom and what is in sight.
    pub view: GraphView,
    /// Which of the two drawings the pane shows.
    pub mode: GraphMode,
    /// Whether the pane lists the triples instead of drawing them (`T`):
    /// every triple, readable whatever the graph's shape.
    pub list: bool,
    /// How far the list of triples is scrolled.
    pub list_scroll: Scroll,
}

impl GraphPane {
    /// Rebuilds the graph from the SKM's output (whole or streaming).
    pub fn set_output(&mut self, skm_output: &str) {
        self.kg = KnowledgeGraph::from_triples(&parse_triples(skm_output).triples);
        if self.cursor.node >= self.kg.nodes.len() {
            self.cursor = GraphCursor::default();
        }
        self.view.set_graph(&self.kg);
    }

    /// The key context of the mode shown; the list of triples has no keys
    /// of its own (the panes' ↑↓ PgUp PgDn scroll it).
    pub fn context(&self) -> Context {
        match (self.list, self.mode) {
            (true, _) => Context::Panes,
            (false, GraphMode::Whole) => Context::WholeGraph,
            (false, GraphMode::Neighbourhood) => Context::Graph,
        }
    }

    /// `T`: in the focused pane, the list of triples instead of the drawing
    /// or the drawing again; from another pane, the list.
    pub fn toggle_list(&mut self, focused: bool) {
        self.list = !(focused && self.list);
    }

    /// The neighbours of the cursor's node in the order the view lists
    /// them: the sources of the edges into it, then the targets of the edges
    /// out of it (a neighbour joined both ways appears twice).
    pub fn neighbours(&self) -> Vec<usize> {
        let node = self.cursor.node;
        self.kg
            .incoming(node)
            .map(|e| e.from)
            .chain(self.kg.outgoing(node).map(|e| e.to))
            .collect()
    }

    /// Moves the highlighted neighbour by `delta`.
    pub fn move_neighbour(&mut self, delta: isize) {
        let last = self.neighbours().len().saturating_sub(1);
        self.cursor.neighbour = self.cursor.neighbour.saturating_add_signed(delta).min(last);
    }

    /// A key of the graph contexts, in a pane whose inside is `body`;
    /// other actions do nothing.
    pub fn on_action(&mut self, action: Action, body: Rect) {
        let (width, height) = (body.width, body.height);
        match action {
            Action::GraphEnter => {
                if let Some(&next) = self.neighbours().get(self.cursor.neighbour) {
                    let here = self.cursor.node;
                    self.cursor.back.push(here);
                    self.cursor.node = next;
                    self.cursor.neighbour = 0;
                }
            }
            Action::GraphBack => {
                if let Some(prev) = self.cursor.back.pop() {
                    self.cursor.node = prev;
                    self.cursor.neighbour = 0;
                }
            }
            Action::GraphNode(step) => {
                let n = self.kg.nodes.len().max(1) as isize;
                self.cursor = GraphCursor {
                    node: (self.cursor.node as isize + step).rem_euclid(n) as usize,
                    ..GraphCursor::default()
                };
            }
            Action::GraphSelect(step) if step > 0 => self.view.select_next(),
            Action::GraphSelect(_) => self.view.select_prev(),
            Action::GraphStep(direction) => {
                self.view.step(direction, width, height);
            }
            Action::GraphZoom(step) if step > 0 => self.view.zoom_in(width, height),
            Action::GraphZoom(_) => self.view.zoom_out(width, height),
            Action::GraphMode => {
                self.mode = match self.mode {
                    GraphMode::Whole => GraphMode::Neighbourhood,
                    GraphMode::Neighbourhood => GraphMode::Whole,
                };
            }
            _ => {}
        }
    }

    /// The panes' `Move(delta)` (↑↓ PgUp PgDn) in a pane whose inside is
    /// `body`: the next or previous neighbour, a line or page of the list,
    /// a row or page of the whole graph.
    pub fn on_move(&mut self, delta: isize, body: Rect) {
        let motion = Motion::of_move(delta);
        if self.list {
            let total = self
                .list_lines(usize::from(body.width), &Styles::default())
                .len();
            self.list_scroll
                .scroll(total, usize::from(body.height), motion);
            return;
        }
        match (self.mode, motion) {
            (GraphMode::Neighbourhood, _) => self.move_neighbour(delta),
            (GraphMode::Whole, Motion::Page(d)) => {
                let page = body.height.saturating_sub(2).max(1) as isize;
                self.view.scroll(0, d * page, body.width, body.height);
            }
            (GraphMode::Whole, _) => self.view.scroll(0, delta, body.width, body.height),
        }
    }

    /// A mouse event over the pane, whose inside is `body`: the wheel
    /// scrolls the list, pans the whole graph (sideways with Shift, or a
    /// tilted wheel) or moves along the neighbours; a click on a node of the
    /// graph selects it, on a neighbour highlights it.
    pub fn on_mouse(&mut self, mouse: MouseEvent, body: Rect) {
        let wheel = match mouse.kind {
            MouseEventKind::ScrollDown => (0, WHEEL_LINES),
            MouseEventKind::ScrollUp => (0, -WHEEL_LINES),
            MouseEventKind::ScrollRight => (WHEEL_LINES, 0),
            MouseEventKind::ScrollLeft => (-WHEEL_LINES, 0),
            MouseEventKind::Down(MouseButton::Left) => (0, 0),
            _ => return,
        };
        let wheel = if mouse.modifiers.contains(KeyModifiers::SHIFT) {
            (2 * wheel.1, wheel.0)
        } else {
            wheel
        };
        let inside = (
            mouse.column.checked_sub(body.x).filter(|&c| c < body.width),
            mouse.row.checked_sub(body.y).filter(|&r| r < body.height),
        );
        let (width, height) = (body.width, body.height);
        match (self.list, self.mode, wheel) {
            (true, _, (_, dy)) => {
                let total = self
                    .list_lines(usize::from(width), &Styles::default())
                    .len();
                self.list_scroll
                    .scroll(total, usize::from(height), Motion::Wheel(dy));
            }
            (false, GraphMode::Whole, (0, 0)) => {
                if let (Some(column), Some(row)) = inside {
                    if let Some(node) = self.view.node_at(column, row, width, height) {
                        self.view.select(node);
                    }
                }
            }
            (false, GraphMode::Whole, (dx, dy)) => self.view.scroll(dx, dy, width, height),
            (false, GraphMode::Neighbourhood, (0, 0)) => {
                if let Some(i) = self.neighbour_at(mouse.column, mouse.row, body) {
                    self.cursor.neighbour = i;
                }
            }
            (false, GraphMode::Neighbourhood, (_, dy)) => self.move_neighbour(dy.signum()),
        }
    }

    /// The neighbour listed at `column`, `row` of the neighbourhood drawn in
    /// `body`, by its place in [`GraphPane::neighbours`].
    fn neighbour_at(&self, column: u16, row: u16, body: Rect) -> Option<usize> {
        let [_, left, right, _] = neighbourhood_areas(body);
        let node = self.cursor.node;
        let (area, first, count) = if left.contains((column, row).into()) {
            (left, 0, self.kg.incoming(node).count())
        } else if right.contains((column, row).into()) {
            let before = self.kg.incoming(node).count();
            (right, before, self.kg.outgoing(node).count())
        } else {
            return None;
        };
        let selected = self.cursor.neighbour.checked_sub(first);
        let viewport = usize::from(area.height).saturating_sub(1);
        let offset = half_offset(count, selected, viewport);
        // The first row of each half is its heading.
        let k = usize::from(row - area.y).checked_sub(1)?;
        (k < viewport && offset + k < count).then_some(first + offset + k)
    }

    /// The triples as numbered lines `subject —relation→ object`, in the
    /// SKM's order, each wrapped by words to `width` columns under its
    /// number.
    fn list_lines(&self, width: usize, styles: &Styles) -> Vec<Line<'static>> {
        let digits = self.kg.edges.len().to_string().len();
        self.kg
            .edges
            .iter()
            .enumerate()
            .flat_map(|(i, e)| {
                let number = Span::styled(format!("{:>digits$}. ", i + 1), styles.muted);
                let body = [
                    Span::styled(self.kg.nodes[e.from].clone(), styles.name),
                    Span::styled(" —", styles.muted),
                    Span::styled(e.label.clone(), styles.relation),
                    Span::styled("→ ", styles.muted),
                    Span::styled(self.kg.nodes[e.to].clone(), styles.name),
                ];
                wrap_hanging(&[number], &body, width)
            })
            .collect()
    }

    /// `block` with `↑ N more` / `↓ N more` on its frame when the whole
    /// graph drawn in `body` goes on above or below the pane (N rows of the
    /// drawing), as on every scrolled pane.
    pub fn framed<'a>(&self, block: Block<'a>, body: Rect, marker_style: Style) -> Block<'a> {
        if self.list || self.mode != GraphMode::Whole || self.kg.nodes.is_empty() {
            return block;
        }
        let sight = self.view.sight(body.width, body.height);
        let rows = usize::from(sight.rows);
        scroll::framed(block, sight.origin.y, sight.extent.1, rows, marker_style)
    }

    /// Draws the list of triples in `block` over `area`, scrolled, with
    /// `↑ N more` / `↓ N more` on the frame when lines are out of sight.
    pub fn render_list(&self, frame: &mut Frame, area: Rect, block: Block<'_>, t: &Theme) {
        let width = usize::from(block.inner(area).width);
        let lines = if self.kg.edges.is_empty() {
            scroll::wrap_text(&[Line::styled(NO_TRIPLES, t.muted)], width)
        } else {
            self.list_lines(width, &Styles::of(t))
        };
        scroll::render(frame, area, block, &lines, self.list_scroll, t.accent);
    }
}

/// The styles of the list of triples.
#[derive(Debug, Default)]
struct Styles {
    name: Style,
    relation: Style,
    muted: Style,
}

impl Styles {
    fn of(t: &Theme) -> Styles {
        Styles {
            name: t.base,
            relation: t.accent,
            muted: t.muted,
        }
    }
}

/// The inside of the pane drawn over `area` (every pane is framed all
/// round): what its key and mouse handlers measure against.
pub(crate) fn body(area: Rect) -> Rect {
    Block::bordered().inner(area)
}

/// The neighbourhood's parts in the pane's inside `body`: the node's box,
/// the edges into it, the edges out of it, and the other nodes.
fn neighbourhood_areas(body: Rect) -> [Rect; 4] {
    let [header, middle, footer] = Layout::vertical([
        Constraint::Length(3),
        Constraint::Min(1),
        Constraint::Length(1),
    ])
    .areas(body);
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(middle);
    [header, left, right, footer]
}

/// How far one half of the neighbourhood, `count` neighbours under its
/// heading in `viewport` rows, is scrolled: enough to show the highlighted
/// one (`selected`, counted within the half), if it is in this half.
fn half_offset(count: usize, selected: Option<usize>, viewport: usize) -> usize {
    let mut scroll = Scroll::default();
    match selected.filter(|&i| i < count) {
        Some(i) => scroll.reveal(i..i + 1, count, viewport),
        None => scroll.scroll(count, viewport, Motion::Line(0)),
    }
    scroll.offset()
}

/// One half of the neighbourhood drawn in `area`: its heading, saying how
/// many neighbours are above or below, then the neighbours' `lines` that
/// fit, scrolled to the highlighted one and cut with `…` at the half's
/// width.
fn half_lines(
    heading: &str,
    lines: Vec<Line<'static>>,
    selected: Option<usize>,
    area: Rect,
    muted: Style,
) -> Vec<Line<'static>> {
    let viewport = usize::from(area.height).saturating_sub(1);
    let offset = half_offset(lines.len(), selected, viewport);
    let (up, down) = scroll::markers(offset, lines.len(), viewport);
    let title = [Some(heading.to_string()), up, down]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>()
        .join(" · ");
    std::iter::once(Line::styled(title, muted))
        .chain(lines.into_iter().skip(offset).take(viewport))
        .map(|line| scroll::cut_line(line, usize::from(area.width)))
        .collect()
}

/// Draws the Knowledge Graph pane.
pub(crate) fn draw(frame: &mut Frame, app: &Shared, area: Rect) {
    let t = app.theme;
    let g = &app.panes.graph.kg;
    let block = pane_block(
        app,
        Pane::Graph,
        Some(agent_badge(app, AgentRole::Skm)),
        area.width,
    );
    let inner = block.inner(area);
    if app.panes.graph.list {
        app.panes.graph.render_list(frame, area, block, t);
        return;
    }
    let block = app.panes.graph.framed(block, inner, t.accent);
    frame.render_widget(block, area);
    if g.nodes.is_empty() {
        frame.render_widget(
            Paragraph::new(Span::styled(NO_TRIPLES, t.muted)).wrap(Wrap { trim: true }),
            inner,
        );
        return;
    }
    if app.panes.graph.mode == GraphMode::Whole {
        let widget = GraphWidget::new(&app.panes.graph.view, t).focused(app.focus == Pane::Graph);
        frame.render_widget(widget, inner);
        return;
    }
    let node = app.panes.graph.cursor.node.min(g.nodes.len() - 1);
    let incoming: Vec<(&str, usize)> = g
        .incoming(node)
        .map(|e| (e.label.as_str(), e.from))
        .collect();
    let outgoing: Vec<(&str, usize)> = g.outgoing(node).map(|e| (e.label.as_str(), e.to)).collect();
    let selected = app.panes.graph.cursor.neighbour;
    let [header, left, right, footer] = neighbourhood_areas(inner);
    let name = scroll::truncate(&g.nodes[node], usize::from(header.width).saturating_sub(4));
    let box_width = scroll::text_width(&name) + 4;
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
    let header_lines: Vec<Line> = header_lines
        .into_iter()
        .map(|line| scroll::cut_line(line, usize::from(header.width)))
        .collect();
    frame.render_widget(Paragraph::new(header_lines), header);
    let style_for = |i: usize| {
        if i == selected && app.focus == Pane::Graph {
            t.selection
        } else {
            t.base
        }
    };
    let mut in_lines = Vec::new();
    for (i, (relation, from)) in incoming.iter().enumerate() {
        in_lines.push(Line::from(vec![
            Span::styled(g.nodes[*from].clone(), style_for(i)),
            Span::styled(format!(" ─{relation}─▶ ●"), t.muted),
        ]));
    }
    let mut out_lines = Vec::new();
    for (k, (relation, to)) in outgoing.iter().enumerate() {
        out_lines.push(Line::from(vec![
            Span::styled(format!("● ─{relation}─▶ "), t.muted),
            Span::styled(g.nodes[*to].clone(), style_for(incoming.len() + k)),
        ]));
    }
    let (into, out) = (Some(selected), selected.checked_sub(incoming.len()));
    let in_lines = half_lines("◀ into it", in_lines, into, left, t.muted);
    frame.render_widget(Paragraph::new(in_lines), left);
    let out_lines = half_lines("out of it ▶", out_lines, out, right, t.muted);
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
    let others = scroll::cut_line(Line::from(others), usize::from(footer.width));
    frame.render_widget(Paragraph::new(others), footer);
}
