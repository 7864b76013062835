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
    let view = GraphView::new(&demo(), Zoom::Wide);
    insta::assert_snapshot!("demo_wide", text(&draw(&view, 140, 40, true)));
    let view = GraphView::new(&demo(), Zoom::Normal);
    insta::assert_snapshot!("demo_normal", text(&draw(&view, 120, 34, true)));
    let view = GraphView::new(&demo(), Zoom::Compact);
    let compact = text(&draw(&view, 78, 15, true));
    insta::assert_snapshot!("demo_compact", compact);
    for e in &demo().edges {
        assert!(compact.contains(&e.label), "{} in {compact}", e.label);
    }
}

#[test]
fn a_narrow_pane_shows_the_selection_and_scrolls() {
    let mut view = GraphView::new(&demo(), Zoom::Normal);
    let robot = view.graph().find("robot").unwrap();
    view.select(robot);
    let shown = text(&draw(&view, 36, 12, true));
    insta::assert_snapshot!("demo_narrow_robot", shown);
    assert!(shown.contains("robot"));
    view.scroll(-200, -200, 36, 12);
    assert_eq!(view.sight(36, 12).origin, Point { x: 0, y: 0 });
    let top_left = text(&draw(&view, 36, 12, true));
    assert!(top_left.contains("blue mug"), "{top_left}");
    view.select(robot);
    assert_eq!(text(&draw(&view, 36, 12, true)), shown);
}

#[test]
fn the_selection_and_its_neighbours_are_highlighted() {
    let theme = load_themes(None).0.remove(0);
    let mut view = GraphView::new(&small(), Zoom::Normal);
    let lamp = view.graph().find("lamp").unwrap();
    view.select(lamp);
    let buf = draw(&view, 60, 14, true);
    let sight = view.sight(60, 14);
    let at_name = |node: usize| {
        let b = view.layout(sight.zoom).node_box(node).unwrap();
        (
            (b.x + 2 - sight.origin.x) as u16,
            (b.text_row() - sight.origin.y) as u16,
        )
    };
    let style_at = |name: &str| {
        let at = at_name(view.graph().find(name).unwrap());
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
    assert_eq!(unfocused[at_name(lamp)].fg, theme.title.fg.unwrap());
}

#[test]
fn moving_selects_the_nearest_box_that_way() {
    let mut view = GraphView::new(&demo(), Zoom::Normal);
    let g = view.graph().clone();
    view.select(g.find("blue mug").unwrap());
    assert!(view.step(Direction::Right, 200, 60));
    assert_eq!(view.selected(), g.find("counter"));
    assert!(view.step(Direction::Left, 200, 60));
    assert_eq!(view.selected(), g.find("blue mug"));
    let start = view.selected();
    assert!(
        !view.step(Direction::Left, 200, 60),
        "nothing left of the first layer"
    );
    assert_eq!(view.selected(), start);
    view.select_prev();
    view.select_next();
    assert_eq!(view.selected(), start);
}

#[test]
fn the_widest_zoom_that_fits_is_drawn_until_one_is_chosen() {
    let mut view = GraphView::fitting(&demo());
    assert_eq!(view.zoom(), None);
    let [compact, normal, wide] = Zoom::ALL.map(|z| {
        let l = view.layout(z);
        (l.width as u16, l.height as u16)
    });
    assert_eq!(view.zoom_for(wide.0, wide.1), Zoom::Wide);
    assert_eq!(view.zoom_for(wide.0 - 1, wide.1), Zoom::Normal);
    assert_eq!(view.zoom_for(normal.0, normal.1), Zoom::Normal);
    assert_eq!(view.zoom_for(normal.0, normal.1 - 1), Zoom::Compact);
    assert_eq!(view.zoom_for(78, 15), Zoom::Compact);
    assert_eq!(
        view.zoom_for(compact.0 - 1, 5),
        Zoom::Compact,
        "nothing fits"
    );
    view.zoom_in(78, 15);
    assert_eq!(view.zoom(), Some(Zoom::Normal));
    assert_eq!(view.zoom_for(400, 200), Zoom::Normal, "chosen, not fitted");
    view.zoom_out(78, 15);
    assert_eq!(
        view.zoom(),
        None,
        "back to the level that fits: fitting again"
    );
    view.zoom_out(400, 200);
    assert_eq!(view.zoom(), Some(Zoom::Normal));
    assert_eq!(
        view.layout(Zoom::Compact),
        &crate::workbench::graph_layout::layout(&demo(), Zoom::Compact)
    );
}

#[test]
fn the_demo_fits_a_78_by_15_pane_whole_with_every_label() {
    let g = demo();
    let view = GraphView::fitting(&g);
    let sight = view.sight(78, 15);
    assert_eq!((sight.hidden_nodes, sight.hidden_edges), (0, 0));
    let shown = text(&draw(&view, 78, 15, true));
    for name in &g.nodes {
        assert!(shown.contains(&format!("[{name}]")), "{name} in\n{shown}");
    }
    for e in &g.edges {
        assert!(shown.contains(&e.label), "{} in\n{shown}", e.label);
    }
    assert!(!shown.contains("hidden"), "{shown}");
}

#[test]
fn a_name_cut_by_the_panes_edge_ends_in_an_ellipsis() {
    let g = KnowledgeGraph::from_triples(&parse_triples("(coffee machine, on, shelf)").triples);
    let view = GraphView::new(&g, Zoom::Normal);
    let shown = text(&draw(&view, 10, 6, true));
    assert!(shown.contains("│ coffee…\n"), "{shown}");
    let mut view = view;
    view.scroll(8, 0, 10, 6);
    let shown = text(&draw(&view, 10, 6, true));
    assert!(shown.contains("…machine ├"), "{shown}");
    view.scroll(-3, 0, 10, 6);
    let shown = text(&draw(&view, 10, 6, true));
    assert!(shown.contains("\n…ee machi…\n"), "{shown}");
}

#[test]
fn panning_says_how_many_nodes_and_edges_are_hidden_and_which_way() {
    let g = demo();
    let mut view = GraphView::new(&g, Zoom::Compact);
    let shown = text(&draw(&view, 60, 6, true));
    let sight = view.sight(60, 6);
    assert_eq!(sight.rows, 5, "a row for the note");
    let whole = |name: &String| shown.contains(&format!("[{name}]"));
    let visible = g.nodes.iter().filter(|n| whole(n)).count();
    assert!(visible > 0 && visible < g.nodes.len(), "{shown}");
    assert_eq!(sight.hidden_nodes, g.nodes.len() - visible, "{shown}");
    let note = shown.lines().last().unwrap();
    assert!(
        note.starts_with(&format!(
            "hidden: {} of {} nodes, {} of {} edges · more",
            sight.hidden_nodes,
            g.nodes.len(),
            sight.hidden_edges,
            g.edges.len()
        )),
        "{note}"
    );
    assert_eq!(sight.more_across(), (false, true), "{note}");
    assert!(note.contains(" · more →"), "{note}");
    view.scroll(500, 500, 60, 6);
    let sight = view.sight(60, 6);
    assert_eq!(sight.more_across(), (true, false), "at the right");
    assert_eq!(
        usize::from(sight.rows) + sight.origin.y,
        sight.extent.1,
        "at the bottom"
    );
}

#[test]
fn a_click_finds_the_node_drawn_there() {
    let g = demo();
    let view = GraphView::fitting(&g);
    let sight = view.sight(78, 15);
    for b in &view.layout(sight.zoom).nodes {
        let (column, row) = ((b.x + 1) as u16, b.text_row() as u16);
        assert_eq!(view.node_at(column, row, 78, 15), Some(b.node));
    }
    assert_eq!(view.node_at(77, 14, 78, 15), None, "a blank cell");
    assert_eq!(view.node_at(200, 0, 78, 15), None, "outside the pane");
}

#[test]
fn a_new_graph_keeps_the_picked_name_else_selects_the_node_drawn_first() {
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
    assert_eq!(view.layout(Zoom::Normal).nodes.len(), 4);
    // Not picked: the SKM's graph grows and the view starts at its top left.
    let mut view = GraphView::fitting(&small());
    view.set_graph(&demo());
    assert_eq!(view.selected(), demo().find("blue mug"));
    assert_eq!(view.sight(30, 6).origin, Point { x: 0, y: 0 });
}

#[test]
fn an_empty_graph_draws_nothing_and_moves_nowhere() {
    let mut view = GraphView::default();
    assert_eq!(view.selected(), None);
    assert!(!view.step(Direction::Down, 20, 4));
    view.select_next();
    view.scroll(3, 3, 20, 4);
    assert_eq!(text(&draw(&view, 20, 4, true)).trim(), "");
    let tiny = draw(&view, 0, 0, true);
    assert_eq!(tiny.area, Rect::new(0, 0, 0, 0));
}

#[test]
fn nodes_past_the_bound_are_counted_hidden() {
    use crate::workbench::graph_layout::MAX_NODES;
    let g = KnowledgeGraph {
        nodes: (0..MAX_NODES + 3).map(|i| format!("n{i}")).collect(),
        edges: Vec::new(),
    };
    let view = GraphView::new(&g, Zoom::Compact);
    let shown = text(&draw(&view, 80, 6, true));
    // Five rows show three nodes (a blank row between two components).
    assert!(
        shown.ends_with(&format!(
            "hidden: {} of {} nodes, 0 of 0 edges · T lists all",
            MAX_NODES,
            MAX_NODES + 3
        )),
        "{shown}"
    );
}
