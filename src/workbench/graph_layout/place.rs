//! The geometric half of the layout: every edge gets a port (a row on its
//! node's side), rows are chosen by isotonic regression towards the
//! neighbours' ports, layers become columns, and each edge that changes row
//! between two columns turns in a channel of its own, so that no two lines
//! share a cell except where they cross.

use std::collections::BTreeSet;

use super::layering::{mean_or, Layered};
use super::{text_width, EdgeLabel, EdgeRoute, NodeBox, Point, Spacing};

/// Row sweeps (alternately from the left and from the right) when placing.
const ROW_SWEEPS: usize = 4;

/// One component drawn in its own coordinates.
#[derive(Debug, Default)]
pub(super) struct Drawn {
    pub nodes: Vec<NodeBox>,
    pub edges: Vec<EdgeRoute>,
    pub width: usize,
    pub height: usize,
}

/// Each vertex's size and the port of each segment end.
struct Ports {
    /// Port index of each segment on its left vertex's right side.
    out: Vec<usize>,
    /// Port index of each segment on its right vertex's left side.
    into: Vec<usize>,
    /// First of the two right-side ports of each self-loop.
    looped: Vec<usize>,
    /// Rows each vertex takes.
    height: Vec<usize>,
    /// Rows above each vertex's first port (its top border).
    top: Vec<usize>,
}

/// Places a layered component: boxes, rows, columns and routes.
pub(super) fn place(g: &Layered, names: &[String], labels: &[String], s: Spacing) -> Drawn {
    let mut position = vec![0usize; g.vertices.len()];
    for layer in &g.layers {
        for (p, &v) in layer.iter().enumerate() {
            position[v] = p;
        }
    }
    let ports = ports(g, &position, s);
    let y = rows(g, &ports, s);
    let row_out =
        |seg: usize| y[g.segments[seg].from] + ports.top[g.segments[seg].from] + ports.out[seg];
    let row_in =
        |seg: usize| y[g.segments[seg].to] + ports.top[g.segments[seg].to] + ports.into[seg];
    let box_width = |v: usize| {
        g.vertices[v].node.map_or(0, |n| {
            text_width(&names[n]) + if s.bordered { 4 } else { 2 }
        })
    };
    let gaps = g.layers.len();
    let mut column_width: Vec<usize> = g
        .layers
        .iter()
        .map(|layer| {
            layer
                .iter()
                .map(|&v| box_width(v))
                .max()
                .unwrap_or(0)
                .max(1)
        })
        .collect();
    column_width.truncate(gaps);
    let label_of = |edge: usize| labels.get(edge).filter(|l| !l.is_empty());
    let mut label_zone = vec![0usize; gaps];
    let mut items: Vec<Vec<Turn>> = vec![Vec::new(); gaps];
    for chain in &g.chains {
        let first = g.segments[chain.segments[0]].from;
        if let Some(label) = label_of(chain.edge.index) {
            let zone = &mut label_zone[g.vertices[first].layer];
            *zone = (*zone).max(text_width(label) + 1);
        }
        for &seg in &chain.segments {
            let (a, b) = (row_out(seg), row_in(seg));
            if a != b {
                items[g.vertices[g.segments[seg].from].layer].push(Turn {
                    left: vec![a],
                    right: vec![b],
                    owner: Owner::Segment(seg),
                });
            }
        }
    }
    for (i, &(edge, v)) in g.loops.iter().enumerate() {
        let layer = g.vertices[v].layer;
        if let Some(label) = label_of(edge.index) {
            label_zone[layer] = label_zone[layer].max(text_width(label) + 1);
        }
        let a = y[v] + ports.top[v] + ports.looped[i];
        items[layer].push(Turn {
            left: vec![a, a + 1],
            right: Vec::new(),
            owner: Owner::Loop(i),
        });
    }
    let mut segment_channel = vec![0usize; g.segments.len()];
    let mut loop_channel = vec![0usize; g.loops.len()];
    let mut column_x = Vec::with_capacity(gaps);
    let mut x = 0;
    for l in 0..gaps {
        column_x.push(x);
        x += column_width[l];
        let channels = assign_channels(&items[l]);
        let used = channels.iter().map(|c| c + 1).max().unwrap_or(0);
        let channel_x = x + 1 + label_zone[l];
        for (turn, c) in items[l].iter().zip(&channels) {
            match turn.owner {
                Owner::Segment(seg) => segment_channel[seg] = channel_x + c,
                Owner::Loop(i) => loop_channel[i] = channel_x + c,
            }
        }
        let last = l + 1 == gaps;
        if !last || used > 0 {
            x += 1 + label_zone[l] + used + 2 + s.gap_pad;
        }
    }
    let mut out = Drawn {
        width: x,
        ..Drawn::default()
    };
    for (v, vertex) in g.vertices.iter().enumerate() {
        if let Some(node) = vertex.node {
            out.nodes.push(NodeBox {
                node,
                layer: vertex.layer,
                x: column_x[vertex.layer],
                y: y[v],
                width: box_width(v),
                height: ports.height[v],
                text: names[node].clone(),
                bordered: s.bordered,
            });
        }
        out.height = out.height.max(y[v] + ports.height[v]);
    }
    let label_at = |edge: usize, start: Point| {
        label_of(edge).map(|text| EdgeLabel {
            at: Point {
                x: start.x + 1,
                y: start.y,
            },
            text: text.clone(),
        })
    };
    for chain in &g.chains {
        let first = chain.segments[0];
        let from = g.segments[first].from;
        let start_row = row_out(first);
        let mut points = vec![Point {
            x: column_x[g.vertices[from].layer] + box_width(from),
            y: start_row,
        }];
        let mut row = start_row;
        for &seg in &chain.segments {
            let (a, b) = (row_out(seg), row_in(seg));
            if a != b {
                let x = segment_channel[seg];
                points.push(Point { x, y: a });
                points.push(Point { x, y: b });
            }
            row = b;
        }
        let end = g.segments[chain.segments[chain.segments.len() - 1]].to;
        points.push(Point {
            x: column_x[g.vertices[end].layer].saturating_sub(1),
            y: row,
        });
        let mut points = simplify(points);
        let label = label_at(chain.edge.index, points[0]);
        if chain.reversed {
            points.reverse();
        }
        out.edges.push(EdgeRoute {
            edge: chain.edge.index,
            from: chain.edge.from,
            to: chain.edge.to,
            points,
            label,
        });
    }
    for (i, &(edge, v)) in g.loops.iter().enumerate() {
        let layer = g.vertices[v].layer;
        let a = y[v] + ports.top[v] + ports.looped[i];
        let side = column_x[layer] + box_width(v);
        let x = loop_channel[i];
        let start = Point { x: side, y: a };
        out.edges.push(EdgeRoute {
            edge: edge.index,
            from: edge.from,
            to: edge.to,
            points: vec![
                start,
                Point { x, y: a },
                Point { x, y: a + 1 },
                Point { x: side, y: a + 1 },
            ],
            label: label_at(edge.index, start),
        });
    }
    out
}

/// Assigns ports: on a vertex's right side its outgoing segments in the
/// order of their targets, then two rows per self-loop; on its left side
/// its incoming segments in the order of their sources.
fn ports(g: &Layered, position: &[usize], s: Spacing) -> Ports {
    let mut p = Ports {
        out: vec![0; g.segments.len()],
        into: vec![0; g.segments.len()],
        looped: vec![0; g.loops.len()],
        height: vec![1; g.vertices.len()],
        top: vec![0; g.vertices.len()],
    };
    let mut loops_at = vec![Vec::new(); g.vertices.len()];
    for (i, &(_, v)) in g.loops.iter().enumerate() {
        loops_at[v].push(i);
    }
    for (v, vertex) in g.vertices.iter().enumerate() {
        let mut outs = vertex.outs.clone();
        outs.sort_by_key(|&seg| (position[g.segments[seg].to], seg));
        for (k, &seg) in outs.iter().enumerate() {
            p.out[seg] = k;
        }
        for (k, &i) in loops_at[v].iter().enumerate() {
            p.looped[i] = outs.len() + 2 * k;
        }
        let mut ins = vertex.ins.clone();
        ins.sort_by_key(|&seg| (position[g.segments[seg].from], seg));
        for (k, &seg) in ins.iter().enumerate() {
            p.into[seg] = k;
        }
        if vertex.node.is_some() {
            let right = outs.len() + 2 * loops_at[v].len();
            let border = usize::from(s.bordered);
            p.top[v] = border;
            p.height[v] = right.max(ins.len()).max(1) + 2 * border;
        }
    }
    p
}

/// Each vertex's top row: layers stacked with `row_gap` between vertices,
/// then moved, sweep by sweep, as close as their order allows to the rows
/// that would line their ports up with their neighbours' (least squares
/// under the order, by pool-adjacent-violators).
fn rows(g: &Layered, ports: &Ports, s: Spacing) -> Vec<usize> {
    let mut y = vec![0i64; g.vertices.len()];
    for layer in &g.layers {
        let mut at = 0;
        for &v in layer {
            y[v] = at;
            at += (ports.height[v] + s.row_gap) as i64;
        }
    }
    let count = g.layers.len();
    for sweep in 0..ROW_SWEEPS {
        let from_left = sweep % 2 == 0;
        let order: Vec<usize> = if from_left {
            (1..count).collect()
        } else {
            (0..count.saturating_sub(1)).rev().collect()
        };
        for l in order {
            let desired: Vec<f64> = g.layers[l]
                .iter()
                .map(|&v| {
                    let wanted = g.vertices[v].across(from_left).iter().map(|&seg| {
                        let sg = g.segments[seg];
                        let (other, other_port, own_port) = if from_left {
                            (sg.from, ports.out[seg], ports.into[seg])
                        } else {
                            (sg.to, ports.into[seg], ports.out[seg])
                        };
                        let other_row = y[other] + (ports.top[other] + other_port) as i64;
                        (other_row - (ports.top[v] + own_port) as i64) as f64
                    });
                    mean_or(wanted, y[v] as f64)
                })
                .collect();
            let heights: Vec<i64> = g.layers[l]
                .iter()
                .map(|&v| (ports.height[v] + s.row_gap) as i64)
                .collect();
            for (&v, row) in g.layers[l].iter().zip(ordered_fit(&desired, &heights)) {
                y[v] = row;
            }
        }
    }
    let lowest = y.iter().copied().min().unwrap_or(0);
    y.into_iter().map(|r| (r - lowest) as usize).collect()
}

/// Rows as close as possible (least squares) to `desired`, in order, each
/// at least the previous one's `heights` below it.
fn ordered_fit(desired: &[f64], heights: &[i64]) -> Vec<i64> {
    let mut offset = Vec::with_capacity(desired.len());
    let mut at = 0i64;
    for h in heights {
        offset.push(at);
        at += h;
    }
    // Blocks of (sum, count) whose means must not decrease.
    let mut blocks: Vec<(f64, usize)> = Vec::new();
    for (d, o) in desired.iter().zip(&offset) {
        blocks.push((d - *o as f64, 1));
        while blocks.len() > 1 {
            let (sum, n) = blocks[blocks.len() - 1];
            let (prev_sum, prev_n) = blocks[blocks.len() - 2];
            if prev_sum / prev_n as f64 <= sum / n as f64 {
                break;
            }
            blocks.pop();
            let last = blocks.len() - 1;
            blocks[last] = (prev_sum + sum, prev_n + n);
        }
    }
    let mut rows = Vec::with_capacity(desired.len());
    for (sum, n) in blocks {
        let value = (sum / n as f64).round() as i64;
        rows.extend(std::iter::repeat_n(value, n));
    }
    rows.iter().zip(&offset).map(|(r, o)| r + o).collect()
}

/// What turns in a channel of a gap.
#[derive(Debug, Clone, Copy)]
enum Owner {
    Segment(usize),
    Loop(usize),
}

/// A line that turns in a gap: it runs along its `left` rows from the left
/// of the gap to its channel, down or up the channel, and along its `right`
/// rows from the channel to the right of the gap.
#[derive(Debug, Clone)]
struct Turn {
    left: Vec<usize>,
    right: Vec<usize>,
    owner: Owner,
}

impl Turn {
    fn span(&self) -> (usize, usize) {
        let rows = self.left.iter().chain(&self.right);
        let lo = rows.clone().copied().min().unwrap_or(0);
        let hi = rows.copied().max().unwrap_or(0);
        (lo, hi)
    }
}

/// The channel (0 = leftmost) of each turn: turns whose vertical spans
/// overlap get different channels, and a turn leaving along a row that
/// another enters along gets a channel left of that one, so their runs on
/// the row do not meet. (Where such turns form a cycle one of them runs
/// along the other for a few cells; the cycle is broken at its topmost.)
fn assign_channels(turns: &[Turn]) -> Vec<usize> {
    let mut entering = std::collections::BTreeMap::new();
    for (i, t) in turns.iter().enumerate() {
        for &r in &t.right {
            entering.insert(r, i);
        }
    }
    let mut before: Vec<Vec<usize>> = vec![Vec::new(); turns.len()];
    let mut waiting = vec![0usize; turns.len()];
    for (i, t) in turns.iter().enumerate() {
        for r in &t.left {
            if let Some(&j) = entering.get(r) {
                if j != i {
                    before[i].push(j);
                    waiting[j] += 1;
                }
            }
        }
    }
    // Self-loops first: their runs all end at their own channel, so the
    // leftmost channels cross nothing for them.
    let key = |i: usize| (!turns[i].right.is_empty(), turns[i].span().0, i);
    let mut ready: BTreeSet<(bool, usize, usize)> = (0..turns.len())
        .filter(|&i| waiting[i] == 0)
        .map(key)
        .collect();
    let mut pending: BTreeSet<(bool, usize, usize)> = (0..turns.len())
        .filter(|&i| waiting[i] > 0)
        .map(key)
        .collect();
    let mut floor = vec![0usize; turns.len()];
    let mut channel = vec![usize::MAX; turns.len()];
    let mut occupied: Vec<Vec<(usize, usize)>> = Vec::new();
    while let Some((_, _, i)) = ready.pop_first().or_else(|| pending.pop_first()) {
        if channel[i] != usize::MAX {
            continue;
        }
        pending.remove(&key(i));
        let (lo, hi) = turns[i].span();
        let mut c = floor[i];
        while occupied
            .get(c)
            .is_some_and(|spans| spans.iter().any(|&(a, b)| lo <= b && a <= hi))
        {
            c += 1;
        }
        if c == occupied.len() {
            occupied.push(Vec::new());
        }
        occupied[c].push((lo, hi));
        channel[i] = c;
        for &j in &before[i] {
            floor[j] = floor[j].max(c + 1);
            waiting[j] = waiting[j].saturating_sub(1);
            if waiting[j] == 0 && channel[j] == usize::MAX {
                pending.remove(&key(j));
                ready.insert(key(j));
            }
        }
    }
    channel
}

/// `points` without repeats and without corners that do not turn.
fn simplify(points: Vec<Point>) -> Vec<Point> {
    let mut out: Vec<Point> = Vec::with_capacity(points.len());
    for p in points {
        if out.last() == Some(&p) {
            continue;
        }
        if out.len() >= 2 {
            let (a, b) = (out[out.len() - 2], out[out.len() - 1]);
            if (a.x == b.x && b.x == p.x) || (a.y == b.y && b.y == p.y) {
                out.pop();
            }
        }
        out.push(p);
    }
    out
}
