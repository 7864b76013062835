//! How long the whole knowledge graph takes to lay out (60 nodes, the size
//! the workbench's budget names: under 20 ms) and to draw into a pane.

use criterion::{criterion_group, criterion_main, Criterion};
use mapvlm::agents::graph::{Edge, KnowledgeGraph};
use mapvlm::workbench::graph_layout::{layout, Zoom};
use mapvlm::workbench::graph_view::{GraphView, GraphWidget};
use mapvlm::workbench::theme::load_themes;
use ratatui::backend::TestBackend;
use ratatui::Terminal;

const RELATIONS: [&str; 8] = [
    "on", "left of", "right of", "under", "behind", "next to", "part of", "holds",
];

/// A scene-like graph of `nodes` objects and twice as many relations,
/// chosen by a fixed linear congruential sequence (with cycles, multi-edges
/// and a few self-loops).
fn scene_graph(nodes: usize) -> KnowledgeGraph {
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = |below: usize| {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        ((state >> 33) as usize) % below
    };
    let names = (0..nodes).map(|i| format!("object {i}")).collect();
    let edges = (0..2 * nodes)
        .map(|i| {
            let from = next(nodes);
            let to = if i % 17 == 0 { from } else { next(nodes) };
            Edge {
                from,
                label: RELATIONS[next(RELATIONS.len())].to_string(),
                to,
            }
        })
        .collect();
    KnowledgeGraph {
        nodes: names,
        edges,
    }
}

fn bench(c: &mut Criterion) {
    let graph = scene_graph(60);
    c.bench_function("layout 60-node graph (normal zoom)", |b| {
        b.iter(|| layout(&graph, Zoom::Normal))
    });
    let view = GraphView::new(&graph, Zoom::Normal);
    let theme = load_themes(None).0.remove(0);
    let mut terminal = Terminal::new(TestBackend::new(80, 20)).unwrap_or_else(|e| panic!("{e}"));
    c.bench_function("draw 60-node graph view 80x20", |b| {
        b.iter(|| {
            terminal
                .draw(|f| f.render_widget(GraphWidget::new(&view, &theme), f.area()))
                .unwrap_or_else(|e| panic!("{e}"));
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
