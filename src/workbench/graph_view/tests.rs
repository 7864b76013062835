use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::Terminal;

use super::*;
use crate::agents::graph::{parse_triples, Edge};
use crate::workbench::theme::load_themes;

fn demo() -> KnowledgeGraph {
    let parsed = parse_triples(include_str!("../../demo/skm.txt"));
    KnowledgeGraph::from_triples(&parsed.triples)
}

fn small() -> KnowledgeGraph {
    let parsed = parse_triples(
        "(mug, on, table)\n(lamp, on, table)\n(mug, left of, lamp)\n(table, near, mug)\n(lamp, lights, lamp)",
    );
    KnowledgeGraph::from_triples(&parsed.triples)
}

fn draw(view: &GraphView, width: u16, height: u16, focused: bool) -> Buffer {
    let theme = load_themes(None).0.remove(0);
    let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
    terminal
        .draw(|f| {
            f.render_widget(GraphWidget::new(view, &theme).focused(focused), f.area());
        })
        .unwrap();
    terminal.backend().buffer().clone()
}

fn text(buf: &Buffer) -> String {
    let area = buf.area;
    (0..area.height)
        .map(|y| {
            let line: String = (0..area.width)
                .map(|x| buf[(x, y)].symbol().to_string())
                .collect();
            line.trim_end().to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_small_graph_whole() {
    let view = GraphView::new(&small(), Zoom::Normal);
    insta::assert_snapshot!("small_normal", text(&draw(&view, 60, 14, true)));
}

#[test]
fn the_demo_graph_in_each_zoom() {
    let mut view = GraphView::new(&demo(), Zoom::Wide);
    insta::assert_snapshot!("demo_wide", text(&draw(&view, 140, 40, true)));
    view.zoom_out();
    insta::assert_snapshot!("demo_normal", text(&draw(&view, 120, 34, true)));
    view.zoom_out();
    insta::assert_snapshot!("demo_compact", text(&draw(&view, 78, 15, true)));
}

#[test]
fn a_narrow_pane_shows_the_selection_and_scrolls() {
    let mut view = GraphView::new(&demo(), Zoom::Normal);
    let robot = view.graph().find("robot").unwrap();
    view.select(robot);
    let shown = text(&draw(&view, 36, 12, true));
    insta::assert_snapshot!("demo_narrow_robot", shown);
    assert!(shown.contains("robot"));
    view.scroll(-200, -200);
    assert_eq!(view.offset(36, 12), (0, 0));
    let top_left = text(&draw(&view, 36, 12, true));
    assert!(top_left.contains("blue mug"), "{top_left}");
    view.recentre();
    assert_eq!(text(&draw(&view, 36, 12, true)), shown);
}

#[test]
fn the_selection_and_its_neighbours_are_highlighted() {
    let theme = load_themes(None).0.remove(0);
    let mut view = GraphView::new(&small(), Zoom::Normal);
    let lamp = view.graph().find("lamp").unwrap();
    view.select(lamp);
    let buf = draw(&view, 60, 14, true);
    let style_at = |name: &str| {
        let b = view
            .layout()
            .node_box(view.graph().find(name).unwrap())
            .unwrap();
        let (ox, oy) = view.offset(60, 14);
        let at = ((b.x + 2 - ox) as u16, (b.text_row() - oy) as u16);
        (buf[at].fg, buf[(at.0 - 2, at.1)].fg)
    };
    assert_eq!(style_at("lamp").0, theme.selection.fg.unwrap());
    assert_eq!(
        style_at("mug").1,
        theme.accent.fg.unwrap(),
        "a neighbour's frame"
    );
    assert_eq!(style_at("table").1, theme.accent.fg.unwrap());
    let unfocused = draw(&view, 60, 14, false);
    let b = view.layout().node_box(lamp).unwrap();
    let (ox, oy) = view.offset(60, 14);
    let at = ((b.x + 2 - ox) as u16, (b.text_row() - oy) as u16);
    assert_eq!(unfocused[at].fg, theme.title.fg.unwrap());
}

#[test]
fn moving_selects_the_nearest_box_that_way() {
    let mut view = GraphView::new(&demo(), Zoom::Normal);
    let g = view.graph().clone();
    view.select(g.find("blue mug").unwrap());
    assert!(view.step(Direction::Right));
    assert_eq!(view.selected(), g.find("counter"));
    assert!(view.step(Direction::Left));
    assert_eq!(view.selected(), g.find("blue mug"));
    let start = view.selected();
    assert!(
        !view.step(Direction::Left),
        "nothing left of the first layer"
    );
    assert_eq!(view.selected(), start);
    view.select_prev();
    view.select_next();
    assert_eq!(view.selected(), start);
}

#[test]
fn zoom_and_fit_change_the_layout_kept() {
    let mut view = GraphView::new(&demo(), Zoom::Normal);
    view.zoom_in();
    assert_eq!(view.zoom(), Zoom::Wide);
    view.fit(400, 200);
    assert_eq!(view.zoom(), Zoom::Wide);
    view.fit(20, 5);
    assert_eq!(view.zoom(), Zoom::Compact);
    assert_eq!(
        view.layout(),
        &crate::workbench::graph_layout::layout(&demo(), Zoom::Compact)
    );
}

#[test]
fn a_new_graph_keeps_the_selected_name() {
    let mut view = GraphView::new(&small(), Zoom::Normal);
    view.select(view.graph().find("lamp").unwrap());
    let mut bigger = small();
    bigger.nodes.insert(0, "shelf".into());
    for e in &mut bigger.edges {
        e.from += 1;
        e.to += 1;
    }
    bigger.edges.push(Edge {
        from: 0,
        label: "holds".into(),
        to: 1,
    });
    view.set_graph(&bigger);
    assert_eq!(view.selected(), bigger.find("lamp"));
    assert_eq!(view.layout().nodes.len(), 4);
}

#[test]
fn an_empty_graph_draws_nothing_and_moves_nowhere() {
    let mut view = GraphView::default();
    assert_eq!(view.selected(), None);
    assert!(!view.step(Direction::Down));
    view.select_next();
    view.scroll(3, 3);
    assert_eq!(text(&draw(&view, 20, 4, true)).trim(), "");
    let tiny = draw(&view, 0, 0, true);
    assert_eq!(tiny.area, Rect::new(0, 0, 0, 0));
}

#[test]
fn omitted_nodes_are_told() {
    use crate::workbench::graph_layout::MAX_NODES;
    let g = KnowledgeGraph {
        nodes: (0..MAX_NODES + 3).map(|i| format!("n{i}")).collect(),
        edges: Vec::new(),
    };
    let view = GraphView::new(&g, Zoom::Compact);
    let shown = text(&draw(&view, 50, 6, true));
    assert!(shown.ends_with("+3 nodes, +0 edges not drawn"), "{shown}");
}
