//! The whole knowledge graph as a pane's content: [`GraphView`] holds the
//! graph, its cached [`GraphLayout`], the selected node, the zoom and how far
//! the user has panned; [`GraphWidget`] draws it with the theme, the
//! selected node and its neighbours highlighted. The view follows the
//! selection (it is centred unless panned away), so drawing stays a pure
//! function of the state and the pane's size.
//!
//! It knows nothing of the workbench: a pane calls its methods from its key
//! handler and [`GraphView::set_graph`] when SKM's graph changes.

mod draw;

pub use draw::GraphWidget;

use crate::agents::graph::KnowledgeGraph;
use crate::workbench::graph_layout::{layout, GraphLayout, NodeBox, Zoom};

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
/// zoom and the pan away from the selection.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GraphView {
    graph: KnowledgeGraph,
    layout: GraphLayout,
    selected: usize,
    pan: (isize, isize),
}

impl GraphView {
    /// A view of `graph` at `zoom`, with its first node selected.
    pub fn new(graph: &KnowledgeGraph, zoom: Zoom) -> Self {
        Self {
            graph: graph.clone(),
            layout: layout(graph, zoom),
            selected: 0,
            pan: (0, 0),
        }
    }

    /// Shows `graph` instead, laid out again only if it changed; the
    /// selected node stays selected if the new graph has a node of that name.
    pub fn set_graph(&mut self, graph: &KnowledgeGraph) {
        if *graph == self.graph {
            return;
        }
        let keep = self
            .graph
            .nodes
            .get(self.selected)
            .and_then(|name| graph.find(name));
        self.graph = graph.clone();
        self.layout = layout(graph, self.layout.zoom);
        self.selected = keep.unwrap_or(0);
        self.pan = (0, 0);
    }

    /// The graph shown.
    pub fn graph(&self) -> &KnowledgeGraph {
        &self.graph
    }

    /// Its layout at the current zoom.
    pub fn layout(&self) -> &GraphLayout {
        &self.layout
    }

    /// The zoom level.
    pub fn zoom(&self) -> Zoom {
        self.layout.zoom
    }

    /// The selected node, if the graph has any.
    pub fn selected(&self) -> Option<usize> {
        (self.selected < self.graph.nodes.len()).then_some(self.selected)
    }

    /// Selects `node` (ignored if there is no such node) and centres it.
    pub fn select(&mut self, node: usize) {
        if node < self.graph.nodes.len() {
            self.selected = node;
            self.pan = (0, 0);
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
    /// across the direction counting double); returns whether the
    /// selection moved.
    pub fn step(&mut self, direction: Direction) -> bool {
        let Some(here) = self.selected_box().cloned() else {
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
            .layout
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

    /// Pans the view by `dx` columns and `dy` rows (positive: right, down),
    /// within the drawing's size.
    pub fn scroll(&mut self, dx: isize, dy: isize) {
        let (w, h) = (self.layout.width as isize, self.layout.height as isize);
        self.pan = (
            (self.pan.0 + dx).clamp(-w, w),
            (self.pan.1 + dy).clamp(-h, h),
        );
    }

    /// Centres the selected node again, undoing any pan.
    pub fn recentre(&mut self) {
        self.pan = (0, 0);
    }

    /// Shows more: longer names and labels, more room.
    pub fn zoom_in(&mut self) {
        self.set_zoom(self.zoom().zoom_in());
    }

    /// Shows less: borderless nodes, no blank rows, shorter labels.
    pub fn zoom_out(&mut self) {
        self.set_zoom(self.zoom().zoom_out());
    }

    /// Lays the graph out again at `zoom`, if it is a different level.
    pub fn set_zoom(&mut self, zoom: Zoom) {
        if zoom != self.zoom() {
            self.layout = layout(&self.graph, zoom);
            self.pan = (0, 0);
        }
    }

    /// Picks the widest zoom whose drawing fits `width` × `height` cells,
    /// else the most compact.
    pub fn fit(&mut self, width: u16, height: u16) {
        let fits =
            |l: &GraphLayout| l.width <= usize::from(width) && l.height <= usize::from(height);
        let chosen = Zoom::ALL
            .into_iter()
            .rev()
            .find(|&z| {
                if z == self.zoom() {
                    fits(&self.layout)
                } else {
                    fits(&layout(&self.graph, z))
                }
            })
            .unwrap_or(Zoom::Compact);
        self.set_zoom(chosen);
    }

    /// The nodes joined to the selected one, which are highlighted.
    pub fn neighbours(&self) -> Vec<usize> {
        self.selected()
            .map(|n| self.graph.neighbours(n))
            .unwrap_or_default()
    }

    /// The drawing's cell shown at the top-left of a `width` × `height`
    /// pane: the selected box centred, moved by the pan, kept within the
    /// drawing.
    pub fn offset(&self, width: u16, height: u16) -> (usize, usize) {
        let centre = self.selected_box().map(NodeBox::centre);
        let axis = |centre: Option<usize>, pan: isize, size: usize, room: u16| {
            let room = usize::from(room);
            let start = centre.map_or(0, |c| c as isize - (room / 2) as isize) + pan;
            start.clamp(0, size.saturating_sub(room) as isize) as usize
        };
        (
            axis(centre.map(|c| c.x), self.pan.0, self.layout.width, width),
            axis(centre.map(|c| c.y), self.pan.1, self.layout.height, height),
        )
    }

    fn selected_box(&self) -> Option<&NodeBox> {
        self.selected().and_then(|n| self.layout.node_box(n))
    }
}

#[cfg(test)]
mod tests;
