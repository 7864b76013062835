//! The whole knowledge graph laid out in terminal cells, Sugiyama style:
//! cycles broken by reversing back edges, nodes put in layers (columns, left
//! to right), long edges split by dummy vertices, layers reordered by
//! barycentre sweeps to cut crossings, rows chosen close to the neighbours'
//! ports, and every edge routed orthogonally through its own channel with
//! its relation label on the run leaving its leftmost end.
//!
//! Pure and deterministic: the same graph and zoom give the same layout.
//! The work is bounded: at most [`MAX_NODES`] nodes and [`MAX_EDGES`] edges
//! are laid out (the rest are counted as omitted), and the crossing sweeps
//! shrink as the graph grows. Layout crates were weighed and left: the ones
//! kept up compute floating-point positions for pixels, without edge routes
//! or label places in character cells.

mod layering;
mod place;

use crate::agents::graph::KnowledgeGraph;
use crate::workbench::scroll::{text_width, truncate};

/// The most nodes laid out; the rest are counted in [`GraphLayout::omitted_nodes`].
pub const MAX_NODES: usize = 400;
/// The most edges laid out; the rest are counted in [`GraphLayout::omitted_edges`].
pub const MAX_EDGES: usize = 800;

/// How much room the drawing takes and how much text it shows: compact for
/// an overview of a small pane, wide for reading long names and relations.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Zoom {
    /// Borderless one-row nodes and no blank rows; names and labels as at
    /// normal zoom.
    Compact,
    /// Boxed nodes, relation labels up to a dozen columns.
    #[default]
    Normal,
    /// Boxed nodes with long names and labels, more room between layers.
    Wide,
}

impl Zoom {
    /// The levels from the most compact to the widest.
    pub const ALL: [Zoom; 3] = [Zoom::Compact, Zoom::Normal, Zoom::Wide];

    /// The next wider level (the widest stays).
    pub fn zoom_in(self) -> Zoom {
        match self {
            Zoom::Compact => Zoom::Normal,
            Zoom::Normal | Zoom::Wide => Zoom::Wide,
        }
    }

    /// The next more compact level (the most compact stays).
    pub fn zoom_out(self) -> Zoom {
        match self {
            Zoom::Wide => Zoom::Normal,
            Zoom::Normal | Zoom::Compact => Zoom::Compact,
        }
    }

    /// The level's name, for a status line.
    pub fn name(self) -> &'static str {
        match self {
            Zoom::Compact => "compact",
            Zoom::Normal => "normal",
            Zoom::Wide => "wide",
        }
    }

    fn spacing(self) -> Spacing {
        match self {
            Zoom::Compact => Spacing {
                name_width: 20,
                label_width: 12,
                row_gap: 0,
                gap_pad: 0,
                bordered: false,
            },
            Zoom::Normal => Spacing {
                name_width: 20,
                label_width: 12,
                row_gap: 1,
                gap_pad: 0,
                bordered: true,
            },
            Zoom::Wide => Spacing {
                name_width: 32,
                label_width: 24,
                row_gap: 1,
                gap_pad: 2,
                bordered: true,
            },
        }
    }
}

/// The sizes one zoom level draws with.
#[derive(Debug, Clone, Copy)]
struct Spacing {
    /// The widest node name, in columns, before it is cut with `…`.
    name_width: usize,
    /// The widest relation label, before it is cut with `…`.
    label_width: usize,
    /// Blank rows between vertices of one layer.
    row_gap: usize,
    /// Extra columns in every gap between layers.
    gap_pad: usize,
    /// Whether nodes are drawn in boxes (else as `[name]`).
    bordered: bool,
}

/// A cell of the drawing: `x` columns from the left, `y` rows from the top.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Point {
    /// Column.
    pub x: usize,
    /// Row.
    pub y: usize,
}

/// Where one node is drawn.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeBox {
    /// The node's index in [`KnowledgeGraph::nodes`].
    pub node: usize,
    /// Its layer (column), counted from the left within its component.
    pub layer: usize,
    /// The left column.
    pub x: usize,
    /// The top row.
    pub y: usize,
    /// Width in columns, borders included.
    pub width: usize,
    /// Height in rows, borders included; taller than 3 when it has more
    /// edges on one side than one row holds.
    pub height: usize,
    /// The name as drawn: cut to the zoom's width with `…`.
    pub text: String,
    /// Drawn in a box (else as `[name]` on its first row).
    pub bordered: bool,
}

impl NodeBox {
    /// Whether the cell `p` is inside the box.
    pub fn contains(&self, p: Point) -> bool {
        (self.x..self.x + self.width).contains(&p.x)
            && (self.y..self.y + self.height).contains(&p.y)
    }

    /// The row the name is written on.
    pub fn text_row(&self) -> usize {
        self.y + usize::from(self.bordered)
    }

    /// The box's middle cell, for moving between boxes.
    pub fn centre(&self) -> Point {
        Point {
            x: self.x + self.width / 2,
            y: self.y + self.height / 2,
        }
    }
}

/// A relation label and where it is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EdgeLabel {
    /// The first cell.
    pub at: Point,
    /// The relation as drawn: cut to the zoom's width with `…`.
    pub text: String,
}

/// How one edge is drawn.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EdgeRoute {
    /// The edge's index in [`KnowledgeGraph::edges`].
    pub edge: usize,
    /// The subject's node.
    pub from: usize,
    /// The object's node.
    pub to: usize,
    /// The corners of the line, from the cell beside the subject's box to
    /// the cell beside the object's box (where the arrowhead goes); each
    /// step is horizontal or vertical.
    pub points: Vec<Point>,
    /// The relation label, unless the zoom hides labels.
    pub label: Option<EdgeLabel>,
}

/// A knowledge graph laid out for drawing.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GraphLayout {
    /// The zoom it was laid out for.
    pub zoom: Zoom,
    /// Columns the drawing spans.
    pub width: usize,
    /// Rows the drawing spans.
    pub height: usize,
    /// One box per node laid out, in node order.
    pub nodes: Vec<NodeBox>,
    /// One route per edge laid out, in edge order.
    pub edges: Vec<EdgeRoute>,
    /// Nodes past [`MAX_NODES`], not laid out.
    pub omitted_nodes: usize,
    /// Edges past [`MAX_EDGES`] or touching an omitted node, not laid out.
    pub omitted_edges: usize,
}

impl GraphLayout {
    /// The box of `node`, if it was laid out.
    pub fn node_box(&self, node: usize) -> Option<&NodeBox> {
        self.nodes
            .binary_search_by_key(&node, |b| b.node)
            .ok()
            .map(|i| &self.nodes[i])
    }
}

/// An edge of the graph as the layout sees it.
#[derive(Debug, Clone, Copy)]
struct InputEdge {
    /// Index in the graph's edges.
    index: usize,
    from: usize,
    to: usize,
}

/// Lays out every node and edge of `graph` (up to the bounds) for `zoom`.
/// Connected components are laid out on their own and stacked top to
/// bottom in order of their first node.
pub fn layout(graph: &KnowledgeGraph, zoom: Zoom) -> GraphLayout {
    Layering::of(graph).place(graph, zoom)
}

/// The layouts of `graph` at every level of [`Zoom::ALL`], in that order:
/// the graph is layered once (the costly part, the same at every zoom) and
/// placed three times, so that a view can pick the level that fits its
/// pane when it is drawn.
pub fn layouts(graph: &KnowledgeGraph) -> [GraphLayout; 3] {
    let layering = Layering::of(graph);
    Zoom::ALL.map(|zoom| layering.place(graph, zoom))
}

/// A graph's components layered and ordered, before any zoom's sizes.
struct Layering {
    /// Each component, in order of its first node.
    components: Vec<layering::Layered>,
    /// Nodes past [`MAX_NODES`].
    omitted_nodes: usize,
    /// Edges past [`MAX_EDGES`] or touching an omitted node.
    omitted_edges: usize,
}

impl Layering {
    fn of(graph: &KnowledgeGraph) -> Layering {
        let nodes = graph.nodes.len().min(MAX_NODES);
        let mut edges = Vec::new();
        let mut omitted_edges = 0;
        for (index, e) in graph.edges.iter().enumerate() {
            if e.from < nodes && e.to < nodes && edges.len() < MAX_EDGES {
                edges.push(InputEdge {
                    index,
                    from: e.from,
                    to: e.to,
                });
            } else {
                omitted_edges += 1;
            }
        }
        let components = components(nodes, &edges)
            .into_iter()
            .map(|component| {
                let component_edges: Vec<InputEdge> = edges
                    .iter()
                    .filter(|e| component.binary_search(&e.from).is_ok())
                    .copied()
                    .collect();
                layering::layer(&component, &component_edges)
            })
            .collect();
        Layering {
            components,
            omitted_nodes: graph.nodes.len() - nodes,
            omitted_edges,
        }
    }

    /// The components placed with `zoom`'s sizes and stacked, one blank row
    /// between two.
    fn place(&self, graph: &KnowledgeGraph, zoom: Zoom) -> GraphLayout {
        let spacing = zoom.spacing();
        let laid = graph.nodes.len() - self.omitted_nodes;
        let names: Vec<String> = graph.nodes[..laid]
            .iter()
            .map(|n| truncate(n, spacing.name_width))
            .collect();
        let labels: Vec<String> = graph
            .edges
            .iter()
            .map(|e| truncate(&e.label, spacing.label_width))
            .collect();
        let mut out = GraphLayout {
            zoom,
            omitted_nodes: self.omitted_nodes,
            omitted_edges: self.omitted_edges,
            ..GraphLayout::default()
        };
        let mut top = 0;
        for layered in &self.components {
            let drawn = place::place(layered, &names, &labels, spacing);
            if top > 0 {
                top += 1;
            }
            for mut b in drawn.nodes {
                b.y += top;
                out.nodes.push(b);
            }
            for mut r in drawn.edges {
                for p in &mut r.points {
                    p.y += top;
                }
                if let Some(label) = &mut r.label {
                    label.at.y += top;
                }
                out.edges.push(r);
            }
            out.width = out.width.max(drawn.width);
            top += drawn.height;
        }
        out.height = top;
        out.nodes.sort_by_key(|b| b.node);
        out.edges.sort_by_key(|r| r.edge);
        out
    }
}

/// The connected components of `nodes` nodes joined by `edges`, each a
/// sorted list of nodes, in order of their smallest node.
fn components(nodes: usize, edges: &[InputEdge]) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..nodes).collect();
    fn root(parent: &mut [usize], mut n: usize) -> usize {
        while parent[n] != n {
            parent[n] = parent[parent[n]];
            n = parent[n];
        }
        n
    }
    for e in edges {
        let (a, b) = (root(&mut parent, e.from), root(&mut parent, e.to));
        if a != b {
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of_root = vec![usize::MAX; nodes];
    for n in 0..nodes {
        let r = root(&mut parent, n);
        if group_of_root[r] == usize::MAX {
            group_of_root[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of_root[r]].push(n);
    }
    groups
}

#[cfg(test)]
mod tests;
