use std::collections::BTreeMap;

use proptest::prelude::*;

use super::*;
use crate::agents::graph::{parse_triples, Edge};

fn graph(nodes: &[&str], edges: &[(usize, &str, usize)]) -> KnowledgeGraph {
    KnowledgeGraph {
        nodes: nodes.iter().map(|n| n.to_string()).collect(),
        edges: edges
            .iter()
            .map(|&(from, label, to)| Edge {
                from,
                label: label.to_string(),
                to,
            })
            .collect(),
    }
}

fn demo() -> KnowledgeGraph {
    let parsed = parse_triples(include_str!("../../demo/skm.txt"));
    KnowledgeGraph::from_triples(&parsed.triples)
}

/// The cells a route passes through, each with whether the line runs
/// horizontally there.
fn cells(route: &EdgeRoute) -> Vec<(Point, bool)> {
    let mut out = Vec::new();
    for pair in route.points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let horizontal = a.y == b.y;
        let steps = a.x.abs_diff(b.x) + a.y.abs_diff(b.y);
        for k in 0..=steps {
            let p = Point {
                x: if b.x >= a.x {
                    a.x + k.min(b.x - a.x)
                } else {
                    a.x - k
                },
                y: if b.y >= a.y {
                    a.y + k.min(b.y - a.y)
                } else {
                    a.y - k
                },
            };
            let p = if horizontal {
                Point { x: p.x, y: a.y }
            } else {
                Point { x: a.x, y: p.y }
            };
            out.push((p, horizontal));
        }
    }
    out
}

fn beside(b: &NodeBox, p: Point) -> bool {
    (b.y..b.y + b.height).contains(&p.y) && (p.x == b.x + b.width || p.x + 1 == b.x)
}

/// Checks what every layout must hold, whatever the graph.
fn check_sound(g: &KnowledgeGraph, l: &GraphLayout) {
    let laid = g.nodes.len().min(MAX_NODES);
    let placed: Vec<usize> = l.nodes.iter().map(|b| b.node).collect();
    assert_eq!(placed, (0..laid).collect::<Vec<_>>(), "every node once");
    assert_eq!(l.omitted_nodes, g.nodes.len() - laid);
    assert_eq!(l.edges.len() + l.omitted_edges, g.edges.len());
    for (i, a) in l.nodes.iter().enumerate() {
        assert!(
            a.x + a.width <= l.width && a.y + a.height <= l.height,
            "{a:?} inside"
        );
        for b in &l.nodes[i + 1..] {
            let apart = a.x + a.width <= b.x
                || b.x + b.width <= a.x
                || a.y + a.height <= b.y
                || b.y + b.height <= a.y;
            assert!(apart, "{a:?} overlaps {b:?}");
        }
    }
    for r in &l.edges {
        let e = &g.edges[r.edge];
        assert_eq!((r.from, r.to), (e.from, e.to));
        assert!(r.points.len() >= 2, "{r:?}");
        for pair in r.points.windows(2) {
            assert!(pair[0] != pair[1] && (pair[0].x == pair[1].x || pair[0].y == pair[1].y));
        }
        let (from, to) = (l.node_box(r.from).unwrap(), l.node_box(r.to).unwrap());
        assert!(beside(from, r.points[0]), "{r:?} starts beside {from:?}");
        assert!(
            beside(to, *r.points.last().unwrap()),
            "{r:?} ends beside {to:?}"
        );
        for (p, _) in cells(r) {
            assert!(p.x < l.width && p.y < l.height, "{p:?} inside the drawing");
            assert!(
                !l.nodes.iter().any(|b| b.contains(p)),
                "{r:?} crosses a box at {p:?}"
            );
        }
        if let Some(label) = &r.label {
            let on_route: Vec<Point> = cells(r).into_iter().map(|(p, _)| p).collect();
            for k in 0..text_width(&label.text) {
                let p = Point {
                    x: label.at.x + k,
                    y: label.at.y,
                };
                assert!(on_route.contains(&p), "label {label:?} lies on its line");
            }
        }
    }
}

/// Cells where two lines run the same way (they would look like one).
fn shared_runs(l: &GraphLayout) -> Vec<Point> {
    let mut seen: BTreeMap<(Point, bool), usize> = BTreeMap::new();
    let mut shared = Vec::new();
    for r in &l.edges {
        let mut mine: Vec<(Point, bool)> = cells(r);
        mine.sort();
        mine.dedup();
        for cell in mine {
            if let Some(&other) = seen.get(&cell) {
                if other != r.edge {
                    shared.push(cell.0);
                }
            }
            seen.insert(cell, r.edge);
        }
    }
    shared
}

#[test]
fn the_demo_graph_is_drawn_whole_in_layers() {
    let g = demo();
    for zoom in Zoom::ALL {
        let l = layout(&g, zoom);
        check_sound(&g, &l);
        assert!(
            shared_runs(&l).is_empty(),
            "{zoom:?}: {:?}",
            shared_runs(&l)
        );
        for r in &l.edges {
            let (a, b) = (l.node_box(r.from).unwrap(), l.node_box(r.to).unwrap());
            assert!(a.layer < b.layer, "{r:?}: the demo graph has no cycle");
        }
        assert_eq!(
            l.edges.iter().filter(|r| r.label.is_some()).count(),
            g.edges.len(),
            "{zoom:?}: every relation labelled"
        );
    }
}

#[test]
fn layers_follow_edge_direction_in_a_dag() {
    let g = graph(
        &["a", "b", "c", "d", "e"],
        &[
            (0, "x", 1),
            (1, "x", 2),
            (0, "y", 2),
            (3, "z", 2),
            (2, "w", 4),
        ],
    );
    let l = layout(&g, Zoom::Normal);
    check_sound(&g, &l);
    let layer = |n: usize| l.node_box(n).unwrap().layer;
    assert_eq!([layer(0), layer(1), layer(2), layer(4)], [0, 1, 2, 3]);
    assert_eq!(layer(3), 1, "a source sits just before its successor");
}

#[test]
fn cycles_self_loops_and_multi_edges_are_all_drawn() {
    let g = graph(
        &["a", "b", "c"],
        &[
            (0, "to", 1),
            (1, "to", 2),
            (2, "back to", 0),
            (1, "itself", 1),
            (0, "to", 1),
            (1, "from", 0),
        ],
    );
    let l = layout(&g, Zoom::Normal);
    check_sound(&g, &l);
    assert_eq!(l.edges.len(), 6);
    let looped = &l.edges[3];
    assert_eq!(
        looped.points.first().map(|p| p.x),
        looped.points.last().map(|p| p.x)
    );
    let mut starts: Vec<Point> = l.edges.iter().map(|r| r.points[0]).collect();
    starts.sort();
    starts.dedup();
    assert_eq!(starts.len(), 6, "each edge leaves from its own cell");
}

#[test]
fn disconnected_parts_are_stacked_without_overlap() {
    let g = graph(&["a", "b", "c", "d", "lonely"], &[(0, "r", 1), (2, "s", 3)]);
    let l = layout(&g, Zoom::Normal);
    check_sound(&g, &l);
    let (first, second) = (l.node_box(0).unwrap(), l.node_box(2).unwrap());
    assert!(first.y + first.height < second.y);
    assert_eq!(l.node_box(4).unwrap().layer, 0);
}

#[test]
fn long_and_wide_text_is_cut_by_columns() {
    let name = "a very long name for an object that goes on and on";
    let g = graph(
        &[name, "水槽の蛇口"],
        &[(0, "is somewhere quite near to", 1)],
    );
    let l = layout(&g, Zoom::Normal);
    check_sound(&g, &l);
    let long = l.node_box(0).unwrap();
    assert_eq!(long.text, "a very long name fo…");
    assert_eq!(long.width, 24);
    let wide = l.node_box(1).unwrap();
    assert_eq!((wide.text.as_str(), wide.width), ("水槽の蛇口", 14));
    let label = l.edges[0].label.as_ref().unwrap();
    assert_eq!(label.text, "is somewher…");
    assert_eq!(truncate("水槽の蛇口", 5), "水槽…");
    assert_eq!(truncate("tab\there", 20), "tab here");
    assert_eq!(truncate("anything", 0), "");
    assert_eq!(truncate("a rinsed mug", 10), "a rinsed…");
}

#[test]
fn an_empty_graph_is_an_empty_layout() {
    let l = layout(&KnowledgeGraph::default(), Zoom::Normal);
    assert_eq!(
        (l.width, l.height, l.nodes.len(), l.edges.len()),
        (0, 0, 0, 0)
    );
}

#[test]
fn the_same_graph_gives_the_same_layout() {
    let g = demo();
    assert_eq!(layout(&g, Zoom::Wide), layout(&g.clone(), Zoom::Wide));
}

#[test]
fn zoom_changes_the_room_taken() {
    let g = demo();
    let [compact, normal, wide] = Zoom::ALL.map(|z| layout(&g, z));
    assert!(compact.width < normal.width && normal.width < wide.width);
    assert!(compact.height < normal.height);
    assert_eq!(Zoom::Compact.zoom_out(), Zoom::Compact);
    assert_eq!(Zoom::Compact.zoom_in().zoom_in(), Zoom::Wide);
    assert_eq!(Zoom::Wide.zoom_in(), Zoom::Wide);
}

#[test]
fn crossings_are_reduced_where_an_order_avoids_them() {
    // a→d and b→c given crosswise: the sweep puts c and d in the order of
    // their sources, so the two straight edges do not cross.
    let g = graph(
        &["a", "b", "d", "c"],
        &[(0, "r", 2), (1, "r", 3), (0, "s", 3)],
    );
    let l = layout(&g, Zoom::Normal);
    check_sound(&g, &l);
    assert!(l.node_box(0).unwrap().y < l.node_box(1).unwrap().y);
    assert!(l.node_box(2).unwrap().y < l.node_box(3).unwrap().y);
    assert!(shared_runs(&l).is_empty());
}

#[test]
fn hundreds_of_nodes_are_bounded() {
    let names: Vec<String> = (0..MAX_NODES + 50).map(|i| format!("n{i}")).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let edges: Vec<(usize, &str, usize)> = (0..MAX_EDGES + 100)
        .map(|i| ((i * 7) % refs.len(), "r", (i * 13 + 1) % refs.len()))
        .collect();
    let g = graph(&refs, &edges);
    let l = layout(&g, Zoom::Compact);
    assert_eq!(l.omitted_nodes, 50);
    assert_eq!(l.nodes.len(), MAX_NODES);
    assert!(l.edges.len() <= MAX_EDGES);
    check_sound(&g, &l);
}

fn random_graph() -> impl Strategy<Value = KnowledgeGraph> {
    (1usize..30).prop_flat_map(|n| {
        let names = proptest::collection::vec("[a-zé水 ]{0,14}", n);
        let edges = proptest::collection::vec((0..n, "[a-z ]{0,20}", 0..n), 0..(3 * n));
        (names, edges).prop_map(|(nodes, edges)| KnowledgeGraph {
            nodes,
            edges: edges
                .into_iter()
                .map(|(from, label, to)| Edge { from, label, to })
                .collect(),
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn random_graphs_lay_out_soundly(g in random_graph(), z in 0usize..3) {
        let l = layout(&g, Zoom::ALL[z]);
        check_sound(&g, &l);
        let boxes: usize = l.nodes.iter().map(|b| b.width + b.height).sum();
        prop_assert!(l.width + l.height <= 4 * boxes + 40 * (g.edges.len() + 1));
        prop_assert_eq!(&l, &layout(&g, Zoom::ALL[z]));
    }
}
