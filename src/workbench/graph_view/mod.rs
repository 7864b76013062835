//! The whole knowledge graph as a pane's content: [`GraphView`] holds the
//! graph, its cached layouts (one per [`Zoom`]), the selected node, the
//! zoom chosen (or none: the widest that fits the pane) and the part of
//! the drawing in sight; [`GraphWidget`] draws it with the theme, the
//! selected node and its neighbours highlighted, and says what is hidden.
//! The pane's size is known only when drawing, so [`GraphView::sight`]
//! works out what a pane of a given size shows, a pure function of the
//! state that drawing, clicks and keys share; drawing brings the selection
//! into view on a copy, as [`Scroll::following`] does for a list.
//!
//! It knows nothing of the workbench: a pane calls its methods from its key
//! and mouse handlers with its size, and [`GraphView::set_graph`] when
//! SKM's graph changes.

mod draw;

pub use draw::GraphWidget;

use crate::agents::graph::KnowledgeGraph;
use crate::workbench::graph_layout::{layouts, GraphLayout, NodeBox, Point, Zoom};
use crate::workbench::scroll::{text_width, Motion, Scroll};

/// A direction to move the selection in, to the nearest box that way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Towards the left (the subjects' side).
    Left,
    /// Towards the right (the objects' side).
    Right,
    /// Up.
    Up,
    /// Down.
    Down,
}

/// The whole-graph view's state: what is drawn, which node is selected, the
/// zoom and the part of the drawing in sight.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphView {
    graph: KnowledgeGraph,
    /// The layout at each level of [`Zoom::ALL`], in that order.
    layouts: [GraphLayout; 3],
    /// The zoom the user chose; `None` fits the pane.
    zoom: Option<Zoom>,
    selected: usize,
    /// Whether the user picked the selected node (else it is the node drawn
    /// first, whatever the graph becomes while the SKM writes).
    picked: bool,
    /// The drawing's column and row at the top-left of the pane.
    origin: (Scroll, Scroll),
    /// Whether drawing brings the selected box into view (until the user
    /// pans away from it).
    follow: bool,
}

impl Default for GraphView {
    fn default() -> Self {
        Self::fitting(&KnowledgeGraph::default())
    }
}

/// What a pane of a given size shows of a [`GraphView`]: the zoom drawn,
/// the part of the drawing in sight and what is hidden.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sight {
    /// The zoom drawn.
    pub zoom: Zoom,
    /// The drawing's cell at the top-left of the pane.
    pub origin: Point,
    /// Columns of the drawing shown (the pane's width).
    pub width: u16,
    /// Rows of the drawing shown: the pane's height, less the row that says
    /// what is hidden when something is.
    pub rows: u16,
    /// Nodes not wholly in sight, or past the layout's bound.
    pub hidden_nodes: usize,
    /// Edges not wholly in sight (line and label), or not laid out.
    pub hidden_edges: usize,
    /// The whole drawing's width and height.
    pub extent: (usize, usize),
}

impl Sight {
    /// Whether the drawing's cell `p` is in sight.
    pub fn shows(&self, p: Point) -> bool {
        (self.origin.x..self.origin.x + usize::from(self.width)).contains(&p.x)
            && (self.origin.y..self.origin.y + usize::from(self.rows)).contains(&p.y)
    }

    /// Whether anything is hidden, so that the pane says so.
    pub fn hides(&self) -> bool {
        self.hidden_nodes + self.hidden_edges > 0
    }

    /// Whether the drawing goes on past the pane's left and right edges.
    pub fn more_across(&self) -> (bool, bool) {
        (
            self.origin.x > 0,
            self.origin.x + usize::from(self.width) < self.extent.0,
        )
    }
}

impl GraphView {
    /// A view of `graph` at `zoom` whatever the pane's size, with its
    /// first node selected.
    pub fn new(graph: &KnowledgeGraph, zoom: Zoom) -> Self {
        Self {
            zoom: Some(zoom),
            ..Self::fitting(graph)
        }
    }

    /// A view of `graph` at the widest zoom that fits the pane, with the
    /// node drawn first (top left) selected: how the workbench shows it
    /// first, from the drawing's start.
    pub fn fitting(graph: &KnowledgeGraph) -> Self {
        let layouts = layouts(graph);
        Self {
            graph: graph.clone(),
            selected: first_drawn(&layouts),
            layouts,
            picked: false,
            zoom: None,
            origin: (Scroll::default(), Scroll::default()),
            follow: true,
        }
    }

    /// Shows `graph` instead, laid out again only if it changed; the node
    /// the user selected stays selected if the new graph has a node of that
    /// name (else the node drawn first is), and is brought into view.
    pub fn set_graph(&mut self, graph: &KnowledgeGraph) {
        if *graph == self.graph {
            return;
        }
        let keep = self
            .graph
            .nodes
            .get(self.selected)
            .filter(|_| self.picked)
            .and_then(|name| graph.find(name));
        self.picked = keep.is_some();
        self.graph = graph.clone();
        self.layouts = layouts(graph);
        self.selected = keep.unwrap_or_else(|| first_drawn(&self.layouts));
        self.follow = true;
    }

    /// The graph shown.
    pub fn graph(&self) -> &KnowledgeGraph {
        &self.graph
    }

    /// The layout at `zoom`.
    pub fn layout(&self, zoom: Zoom) -> &GraphLayout {
        &self.layouts[match zoom {
            Zoom::Compact => 0,
            Zoom::Normal => 1,
            Zoom::Wide => 2,
        }]
    }

    /// The zoom the user chose, or `None` when the view fits the pane.
    pub fn zoom(&self) -> Option<Zoom> {
        self.zoom
    }

    /// The zoom a `width` × `height` pane draws: the one chosen, else the
    /// widest whose drawing fits whole (with a row for the note on nodes
    /// past the layout's bound), else the most compact.
    pub fn zoom_for(&self, width: u16, height: u16) -> Zoom {
        self.zoom.unwrap_or_else(|| self.fitted(width, height))
    }

    fn fitted(&self, width: u16, height: u16) -> Zoom {
        Zoom::ALL
            .into_iter()
            .rev()
            .find(|&z| {
                let l = self.layout(z);
                let note = usize::from(l.omitted_nodes + l.omitted_edges > 0);
                l.width <= usize::from(width) && l.height + note <= usize::from(height)
            })
            .unwrap_or(Zoom::Compact)
    }

    /// What a `width` × `height` pane shows: the zoom drawn, the part of
    /// the drawing in sight (the selected box brought into view unless the
    /// user panned away) and what is hidden.
    pub fn sight(&self, width: u16, height: u16) -> Sight {
        let zoom = self.zoom_for(width, height);
        let layout = self.layout(zoom);
        let whole = layout.width <= usize::from(width)
            && layout.height <= usize::from(height)
            && layout.omitted_nodes + layout.omitted_edges == 0;
        let rows = if whole || height < 2 {
            height
        } else {
            height - 1
        };
        let (mut x, mut y) = self.origin;
        let selected = self.selected_box(zoom);
        for (scroll, total, room, span) in [
            (
                &mut x,
                layout.width,
                width,
                selected.map(|b| b.x..b.x + b.width),
            ),
            (
                &mut y,
                layout.height,
                rows,
                selected.map(|b| b.y..b.y + b.height),
            ),
        ] {
            match span.filter(|_| self.follow) {
                Some(span) => scroll.reveal(span, total, usize::from(room)),
                None => scroll.scroll(total, usize::from(room), Motion::Line(0)),
            }
        }
        let mut sight = Sight {
            zoom,
            origin: Point {
                x: x.offset(),
                y: y.offset(),
            },
            width,
            rows,
            hidden_nodes: layout.omitted_nodes,
            hidden_edges: layout.omitted_edges,
            extent: (layout.width, layout.height),
        };
        // A node is in sight when its name is: the box's columns and the
        // name's row (a tall box's ports may go on below the pane).
        let named = |b: &NodeBox| {
            sight.shows(Point {
                x: b.x,
                y: b.text_row(),
            }) && sight.shows(Point {
                x: b.x + b.width - 1,
                y: b.text_row(),
            })
        };
        sight.hidden_nodes += layout.nodes.iter().filter(|b| !named(b)).count();
        sight.hidden_edges += layout
            .edges
            .iter()
            .filter(|r| {
                let label = r.label.iter().flat_map(|l| {
                    let end = l.at.x + text_width(&l.text);
                    [
                        l.at,
                        Point {
                            x: end.saturating_sub(1),
                            y: l.at.y,
                        },
                    ]
                });
                !r.points
                    .iter()
                    .copied()
                    .chain(label)
                    .all(|p| sight.shows(p))
            })
            .count();
        sight
    }

    /// The selected node, if the graph has any.
    pub fn selected(&self) -> Option<usize> {
        (self.selected < self.graph.nodes.len()).then_some(self.selected)
    }

    /// Selects `node` (ignored if there is no such node) and brings it
    /// into view.
    pub fn select(&mut self, node: usize) {
        if node < self.graph.nodes.len() {
            self.selected = node;
            self.picked = true;
            self.follow = true;
        }
    }

    /// Selects the next node in node order, wrapping around.
    pub fn select_next(&mut self) {
        let n = self.graph.nodes.len().max(1);
        self.select((self.selected + 1) % n);
    }

    /// Selects the previous node in node order, wrapping around.
    pub fn select_prev(&mut self) {
        let n = self.graph.nodes.len().max(1);
        self.select((self.selected + n - 1) % n);
    }

    /// Selects the nearest box lying wholly in `direction` (distance
    /// across the direction counting double) in the drawing a `width` ×
    /// `height` pane shows; returns whether the selection moved.
    pub fn step(&mut self, direction: Direction, width: u16, height: u16) -> bool {
        let zoom = self.zoom_for(width, height);
        let Some(here) = self.selected_box(zoom).cloned() else {
            return false;
        };
        let centre = here.centre();
        let distance = |b: &NodeBox| {
            let c = b.centre();
            let gap = |near: usize, far: usize| far.checked_sub(near);
            let (along, across) = match direction {
                Direction::Left => (gap(b.x + b.width, here.x), c.y.abs_diff(centre.y)),
                Direction::Right => (gap(here.x + here.width, b.x), c.y.abs_diff(centre.y)),
                Direction::Up => (gap(b.y + b.height, here.y), c.x.abs_diff(centre.x)),
                Direction::Down => (gap(here.y + here.height, b.y), c.x.abs_diff(centre.x)),
            };
            along.map(|along| along + 2 * across)
        };
        let best = self
            .layout(zoom)
            .nodes
            .iter()
            .filter_map(|b| Some((distance(b)?, b.node)))
            .min();
        match best {
            Some((_, node)) => {
                self.select(node);
                true
            }
            None => false,
        }
    }

    /// Pans the drawing a `width` × `height` pane shows by `dx` columns and
    /// `dy` rows (positive: right, down), within the drawing; the selection
    /// is no longer followed until it moves.
    pub fn scroll(&mut self, dx: isize, dy: isize, width: u16, height: u16) {
        let sight = self.sight(width, height);
        let layout = self.layout(sight.zoom);
        let (mut x, mut y) = (Scroll::at(sight.origin.x), Scroll::at(sight.origin.y));
        x.scroll(layout.width, usize::from(width), Motion::Line(dx));
        y.scroll(layout.height, usize::from(sight.rows), Motion::Line(dy));
        self.origin = (x, y);
        self.follow = false;
    }

    /// The node drawn at `column`, `row` of a `width` × `height` pane (its
    /// top-left is 0, 0), if any.
    pub fn node_at(&self, column: u16, row: u16, width: u16, height: u16) -> Option<usize> {
        let sight = self.sight(width, height);
        if column >= width || row >= sight.rows {
            return None;
        }
        let p = Point {
            x: sight.origin.x + usize::from(column),
            y: sight.origin.y + usize::from(row),
        };
        self.layout(sight.zoom)
            .nodes
            .iter()
            .find(|b| b.contains(p))
            .map(|b| b.node)
    }

    /// Shows more (longer names and labels, more room) than a `width` ×
    /// `height` pane shows now.
    pub fn zoom_in(&mut self, width: u16, height: u16) {
        let shown = self.zoom_for(width, height);
        self.set_zoom(shown.zoom_in(), width, height);
    }

    /// Shows less (borderless nodes, no blank rows, less room) than a
    /// `width` × `height` pane shows now.
    pub fn zoom_out(&mut self, width: u16, height: u16) {
        let shown = self.zoom_for(width, height);
        self.set_zoom(shown.zoom_out(), width, height);
    }

    /// Draws at `zoom` from now on, or fits the pane again when `zoom` is
    /// the level a `width` × `height` pane fits; the selection is brought
    /// into view.
    pub fn set_zoom(&mut self, zoom: Zoom, width: u16, height: u16) {
        if zoom != self.zoom_for(width, height) {
            self.origin = (Scroll::default(), Scroll::default());
        }
        self.zoom = (zoom != self.fitted(width, height)).then_some(zoom);
        self.follow = true;
    }

    /// The nodes joined to the selected one, which are highlighted.
    pub fn neighbours(&self) -> Vec<usize> {
        self.selected()
            .map(|n| self.graph.neighbours(n))
            .unwrap_or_default()
    }

    fn selected_box(&self, zoom: Zoom) -> Option<&NodeBox> {
        self.selected().and_then(|n| self.layout(zoom).node_box(n))
    }
}

/// The node drawn first, reading from the top left (the same at every
/// zoom: the first component's topmost node of its first layer); 0 when
/// there is none.
fn first_drawn(layouts: &[GraphLayout; 3]) -> usize {
    layouts[0]
        .nodes
        .iter()
        .min_by_key(|b| (b.y, b.x))
        .map_or(0, |b| b.node)
}

#[cfg(test)]
mod tests;
