//! The combinatorial half of the layout: back edges reversed (depth-first,
//! in node order), layers by longest path with sources pulled next to their
//! successors, long edges split into dummy vertices, and the order within
//! each layer improved by barycentre sweeps, keeping the order with the
//! fewest crossings.

use std::collections::BTreeSet;

use super::InputEdge;

/// Crossing sweeps stop after this many vertex visits in all.
const SWEEP_BUDGET: usize = 200_000;
/// The most down-and-up sweep pairs.
const MAX_SWEEPS: usize = 12;

/// A vertex of the layered graph: a node, or a dummy on a long edge.
#[derive(Debug, Clone)]
pub(super) struct Vertex {
    /// The node, or `None` for a dummy.
    pub node: Option<usize>,
    /// Its layer.
    pub layer: usize,
    /// Segments arriving from the layer on the left.
    pub ins: Vec<usize>,
    /// Segments leaving to the layer on the right.
    pub outs: Vec<usize>,
}

impl Vertex {
    /// The segments towards the layer on the left (`from_left`) or right.
    pub fn across(&self, from_left: bool) -> &[usize] {
        if from_left {
            &self.ins
        } else {
            &self.outs
        }
    }
}

/// The mean of `values`, or `fallback` when there are none.
pub(super) fn mean_or(values: impl Iterator<Item = f64>, fallback: f64) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(sum, n), v| (sum + v, n + 1));
    if n == 0 {
        fallback
    } else {
        sum / n as f64
    }
}

/// One step of an edge, between vertices of adjacent layers.
#[derive(Debug, Clone, Copy)]
pub(super) struct Segment {
    /// The vertex on the left.
    pub from: usize,
    /// The vertex on the right.
    pub to: usize,
}

/// An edge as a run of segments from left to right.
#[derive(Debug, Clone)]
pub(super) struct Chain {
    /// The edge.
    pub edge: InputEdge,
    /// Whether it was reversed to break a cycle (its object is on the left).
    pub reversed: bool,
    /// Its segments, left to right.
    pub segments: Vec<usize>,
}

/// A component as layers of ordered vertices.
#[derive(Debug, Clone, Default)]
pub(super) struct Layered {
    /// All vertices; the component's nodes come first, in node order.
    pub vertices: Vec<Vertex>,
    /// Vertex ids of each layer, in drawing order (top to bottom).
    pub layers: Vec<Vec<usize>>,
    /// All segments.
    pub segments: Vec<Segment>,
    /// The edges between distinct nodes.
    pub chains: Vec<Chain>,
    /// Self-loops: the edge and its node's vertex.
    pub loops: Vec<(InputEdge, usize)>,
}

/// Layers and orders one connected component (`nodes` sorted, `edges`
/// among them).
pub(super) fn layer(nodes: &[usize], edges: &[InputEdge]) -> Layered {
    let local = |n: usize| nodes.binary_search(&n).unwrap_or(0);
    let count = nodes.len();
    let mut out = Layered::default();
    let mut dag: Vec<(usize, usize, InputEdge, bool)> = Vec::new();
    let mut adjacency: Vec<Vec<(usize, usize)>> = vec![Vec::new(); count];
    for (i, e) in edges.iter().enumerate() {
        if e.from == e.to {
            out.loops.push((*e, local(e.from)));
        } else {
            adjacency[local(e.from)].push((local(e.to), i));
        }
    }
    let back = back_edges(&adjacency);
    for (i, e) in edges.iter().enumerate() {
        if e.from != e.to {
            let (a, b) = (local(e.from), local(e.to));
            let reversed = back.contains(&i);
            let (tail, head) = if reversed { (b, a) } else { (a, b) };
            dag.push((tail, head, *e, reversed));
        }
    }
    let layer_of = longest_path(count, &dag);
    for (i, &n) in nodes.iter().enumerate() {
        out.vertices.push(Vertex {
            node: Some(n),
            layer: layer_of[i],
            ins: Vec::new(),
            outs: Vec::new(),
        });
    }
    for (tail, head, edge, reversed) in dag {
        let mut chain = Chain {
            edge,
            reversed,
            segments: Vec::new(),
        };
        let mut at = tail;
        for l in layer_of[tail] + 1..=layer_of[head] {
            let next = if l == layer_of[head] {
                head
            } else {
                out.vertices.push(Vertex {
                    node: None,
                    layer: l,
                    ins: Vec::new(),
                    outs: Vec::new(),
                });
                out.vertices.len() - 1
            };
            let s = out.segments.len();
            out.segments.push(Segment { from: at, to: next });
            out.vertices[at].outs.push(s);
            out.vertices[next].ins.push(s);
            chain.segments.push(s);
            at = next;
        }
        out.chains.push(chain);
    }
    let depth = out.vertices.iter().map(|v| v.layer + 1).max().unwrap_or(0);
    out.layers = vec![Vec::new(); depth];
    for (id, v) in out.vertices.iter().enumerate() {
        out.layers[v.layer].push(id);
    }
    reduce_crossings(&mut out);
    out
}

/// The edges (by index) that close a cycle in a depth-first search that
/// starts from each unvisited node in order and follows edges in order.
fn back_edges(adjacency: &[Vec<(usize, usize)>]) -> BTreeSet<usize> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let mut mark = vec![Mark::New; adjacency.len()];
    let mut back = BTreeSet::new();
    for start in 0..adjacency.len() {
        if mark[start] != Mark::New {
            continue;
        }
        let mut stack = vec![(start, 0usize)];
        mark[start] = Mark::Open;
        while let Some((node, next)) = stack.pop() {
            let Some(&(to, edge)) = adjacency[node].get(next) else {
                mark[node] = Mark::Done;
                continue;
            };
            stack.push((node, next + 1));
            match mark[to] {
                Mark::Open => {
                    back.insert(edge);
                }
                Mark::New => {
                    mark[to] = Mark::Open;
                    stack.push((to, 0));
                }
                Mark::Done => {}
            }
        }
    }
    back
}

/// Each node's layer: one more than its furthest predecessor, then sources
/// moved up to just before their nearest successor.
fn longest_path(count: usize, dag: &[(usize, usize, InputEdge, bool)]) -> Vec<usize> {
    let mut indegree = vec![0usize; count];
    let mut successors: Vec<Vec<usize>> = vec![Vec::new(); count];
    for &(tail, head, ..) in dag {
        indegree[head] += 1;
        successors[tail].push(head);
    }
    let sources: Vec<bool> = indegree.iter().map(|&d| d == 0).collect();
    let mut ready: BTreeSet<usize> = (0..count).filter(|&n| indegree[n] == 0).collect();
    let mut layer = vec![0usize; count];
    while let Some(n) = ready.pop_first() {
        for &s in &successors[n] {
            layer[s] = layer[s].max(layer[n] + 1);
            indegree[s] -= 1;
            if indegree[s] == 0 {
                ready.insert(s);
            }
        }
    }
    for n in 0..count {
        if sources[n] {
            if let Some(nearest) = successors[n].iter().map(|&s| layer[s]).min() {
                layer[n] = nearest.saturating_sub(1);
            }
        }
    }
    layer
}

/// Reorders each layer by the mean position of its neighbours, sweeping
/// right then left, and keeps the order with the fewest crossings.
fn reduce_crossings(g: &mut Layered) {
    let mut position = vec![0usize; g.vertices.len()];
    let index = |layers: &[Vec<usize>], position: &mut [usize]| {
        for layer in layers {
            for (p, &v) in layer.iter().enumerate() {
                position[v] = p;
            }
        }
    };
    index(&g.layers, &mut position);
    let mut best = g.layers.clone();
    let mut best_crossings = crossings(g, &position);
    let work = g.vertices.len() + g.segments.len();
    let sweeps = (SWEEP_BUDGET / work.max(1)).clamp(1, MAX_SWEEPS);
    for _ in 0..sweeps {
        if best_crossings == 0 {
            break;
        }
        for l in 1..g.layers.len() {
            sort_by_barycentre(g, l, &mut position, true);
        }
        for l in (0..g.layers.len().saturating_sub(1)).rev() {
            sort_by_barycentre(g, l, &mut position, false);
        }
        let now = crossings(g, &position);
        if now < best_crossings {
            best_crossings = now;
            best = g.layers.clone();
        }
    }
    g.layers = best;
}

/// Sorts layer `l` by the mean position of each vertex's neighbours on the
/// left (`from_left`) or right; a vertex without such neighbours keeps its
/// place as its key.
fn sort_by_barycentre(g: &mut Layered, l: usize, position: &mut [usize], from_left: bool) {
    let mut keyed: Vec<(f64, usize, usize)> = g.layers[l]
        .iter()
        .map(|&v| {
            let others = g.vertices[v].across(from_left).iter().map(|&s| {
                let seg = g.segments[s];
                position[if from_left { seg.from } else { seg.to }] as f64
            });
            (mean_or(others, position[v] as f64), position[v], v)
        })
        .collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    g.layers[l] = keyed.into_iter().map(|(_, _, v)| v).collect();
    for (p, &v) in g.layers[l].iter().enumerate() {
        position[v] = p;
    }
}

/// How many pairs of segments cross, over all adjacent layers (counted by
/// inversions with a Fenwick tree).
fn crossings(g: &Layered, position: &[usize]) -> usize {
    let mut total = 0;
    for l in 0..g.layers.len().saturating_sub(1) {
        let mut pairs: Vec<(usize, usize)> = g.layers[l]
            .iter()
            .flat_map(|&v| g.vertices[v].outs.iter())
            .map(|&s| (position[g.segments[s].from], position[g.segments[s].to]))
            .collect();
        pairs.sort_unstable();
        let size = g.layers[l + 1].len();
        let mut tree = vec![0usize; size + 1];
        for (seen, &(_, to)) in pairs.iter().enumerate() {
            let mut not_above = 0;
            let mut i = to + 1;
            while i > 0 {
                not_above += tree[i];
                i &= i - 1;
            }
            total += seen - not_above;
            let mut i = to + 1;
            while i <= size {
                tree[i] += 1;
                i += i & i.wrapping_neg();
            }
        }
    }
    total
}
