//! Draws a [`GraphView`] into a pane: edges as box-drawing lines (merged
//! where they meet or cross) with arrowheads and relation labels, then the
//! node boxes on top; what touches the selected node is highlighted.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::widgets::Widget;
use unicode_width::UnicodeWidthChar;

use super::{GraphView, Sight};
use crate::workbench::graph_layout::{NodeBox, Point};
use crate::workbench::scroll::truncate;
use crate::workbench::theme::Theme;

const UP: u8 = 1;
const DOWN: u8 = 2;
const LEFT: u8 = 4;
const RIGHT: u8 = 8;

/// The widget that draws a [`GraphView`] with a [`Theme`].
#[derive(Debug, Clone, Copy)]
pub struct GraphWidget<'a> {
    view: &'a GraphView,
    theme: &'a Theme,
    focused: bool,
}

impl<'a> GraphWidget<'a> {
    /// Draws `view` with `theme`, as an unfocused pane.
    pub fn new(view: &'a GraphView, theme: &'a Theme) -> Self {
        Self {
            view,
            theme,
            focused: false,
        }
    }

    /// Whether the pane has focus: the selected node is then drawn with the
    /// selection style (else as a title).
    pub fn focused(mut self, focused: bool) -> Self {
        self.focused = focused;
        self
    }
}

/// The part of the drawing shown: `origin` is the drawing's cell at the
/// area's top-left.
struct Viewport {
    area: Rect,
    origin: (usize, usize),
}

impl Viewport {
    /// Where the drawing's cell `p` is on screen, if it is shown.
    fn screen(&self, p: Point) -> Option<(u16, u16)> {
        let x = p.x.checked_sub(self.origin.0)?;
        let y = p.y.checked_sub(self.origin.1)?;
        (x < usize::from(self.area.width) && y < usize::from(self.area.height))
            .then(|| (self.area.x + x as u16, self.area.y + y as u16))
    }

    fn put(&self, buf: &mut Buffer, p: Point, symbol: &str, style: Style) {
        if let Some(cell) = self.screen(p).and_then(|at| buf.cell_mut(at)) {
            cell.set_symbol(symbol).set_style(style);
        }
    }

    /// Writes `text` from `at`, each character only if it fits whole; where
    /// the pane's edge cuts the text, its first or last cell shown is an
    /// ellipsis, so that a name is never cut without saying so.
    fn text(&self, buf: &mut Buffer, at: Point, text: &str, style: Style) {
        let mut x = at.x;
        let mut shown: Vec<((u16, u16), char, usize)> = Vec::new();
        let (mut cut_before, mut cut_after) = (false, false);
        for c in text.chars() {
            let w = c.width().unwrap_or(0);
            if w == 0 {
                continue;
            }
            let last = Point {
                x: x + w - 1,
                y: at.y,
            };
            match (self.screen(Point { x, y: at.y }), self.screen(last)) {
                (Some(cell), Some(_)) => shown.push((cell, c, w)),
                _ if shown.is_empty() => cut_before = true,
                _ => cut_after = true,
            }
            x += w;
        }
        // `coffee…`, not `coffee …`: a cut at the end leaves the blanks
        // before it to the ellipsis.
        let mut end = shown.len();
        if cut_after {
            end = end.saturating_sub(1);
            while end > 0 && shown[end - 1].1 == ' ' {
                end -= 1;
            }
        }
        for (i, &((sx, sy), c, w)) in shown.iter().enumerate() {
            let symbol = if (i == 0 && cut_before) || i == end {
                format!("{:<w$}", '…')
            } else if i > end {
                " ".repeat(w)
            } else {
                c.to_string()
            };
            buf.set_stringn(sx, sy, symbol, w, style);
        }
    }
}

impl Widget for GraphWidget<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let t = self.theme;
        buf.set_style(area, t.base);
        let sight = self.view.sight(area.width, area.height);
        let layout = self.view.layout(sight.zoom);
        let graph_area = Rect {
            height: sight.rows,
            ..area
        };
        let view = Viewport {
            area: graph_area,
            origin: (sight.origin.x, sight.origin.y),
        };
        let selected = self.view.selected();
        let neighbours = self.view.neighbours();
        let box_of = |n: usize| layout.node_box(n);
        let mut lines = Lines::new(graph_area);
        let mut heads = Vec::new();
        let mut ports = Vec::new();
        for route in &layout.edges {
            let hot = selected.is_some_and(|s| s == route.from || s == route.to);
            let style = if hot { t.accent } else { t.border };
            for pair in route.points.windows(2) {
                lines.segment(&view, pair[0], pair[1], hot);
            }
            let (Some(&first), Some(&last)) = (route.points.first(), route.points.last()) else {
                continue;
            };
            if let Some(b) = box_of(route.from) {
                ports.push(port(b, first));
                let towards = if b.x + b.width == first.x {
                    LEFT
                } else {
                    RIGHT
                };
                lines.add(&view, first, towards, hot);
            }
            let before = route.points[route.points.len() - 2];
            heads.push((last, arrowhead(before, last), style));
        }
        lines.draw(buf, t.border, t.accent);
        for route in &layout.edges {
            if let Some(label) = &route.label {
                let hot = selected.is_some_and(|s| s == route.from || s == route.to);
                view.text(
                    buf,
                    label.at,
                    &label.text,
                    if hot { t.accent } else { t.muted },
                );
            }
        }
        let styles = |node: usize| {
            if Some(node) == selected {
                let style = if self.focused { t.selection } else { t.title };
                (style, style)
            } else if neighbours.contains(&node) {
                (t.accent, t.base)
            } else {
                (t.border, t.base)
            }
        };
        for b in &layout.nodes {
            let (frame, text) = styles(b.node);
            draw_box(buf, &view, b, frame, text);
        }
        for (node, at, symbol) in ports.into_iter().flatten() {
            view.put(buf, at, symbol, styles(node).0);
        }
        for (at, symbol, style) in heads {
            view.put(buf, at, symbol, style);
        }
        if sight.hides() && sight.rows < area.height {
            let note = truncate(&hidden_note(&sight, self.view), usize::from(area.width));
            let y = area.y + area.height - 1;
            buf.set_stringn(area.x, y, note, usize::from(area.width), t.muted);
        }
    }
}

/// What the pane says when part of the graph is hidden: how many nodes and
/// edges of all, whether the drawing goes on left or right (the frame says
/// up and down), and where the whole list is.
fn hidden_note(sight: &Sight, view: &GraphView) -> String {
    let g = view.graph();
    let mut note = format!(
        "hidden: {} of {} nodes, {} of {} edges",
        sight.hidden_nodes,
        g.nodes.len(),
        sight.hidden_edges,
        g.edges.len()
    );
    match sight.more_across() {
        (true, true) => note.push_str(" · more ← →"),
        (true, false) => note.push_str(" · more ←"),
        (false, true) => note.push_str(" · more →"),
        (false, false) => {}
    }
    note.push_str(" · T lists all");
    note
}

/// The border cell of a bordered box where a line leaving it starts, and
/// the tee drawn there.
fn port(b: &NodeBox, end: Point) -> Option<(usize, Point, &'static str)> {
    if !b.bordered {
        return None;
    }
    if end.x == b.x + b.width {
        Some((
            b.node,
            Point {
                x: end.x - 1,
                y: end.y,
            },
            "├",
        ))
    } else {
        Some((
            b.node,
            Point {
                x: end.x + 1,
                y: end.y,
            },
            "┤",
        ))
    }
}

/// The arrowhead at `tip` of a line arriving from `before`.
fn arrowhead(before: Point, tip: Point) -> &'static str {
    if tip.x > before.x {
        "▶"
    } else if tip.x < before.x {
        "◀"
    } else if tip.y > before.y {
        "▼"
    } else {
        "▲"
    }
}

fn draw_box(buf: &mut Buffer, view: &Viewport, b: &NodeBox, frame: Style, text: Style) {
    let inner = b.width.saturating_sub(2);
    for row in 0..b.height {
        let y = b.y + row;
        let (left, fill, right) = match (b.bordered, row) {
            (true, 0) => ("┌", "─", "┐"),
            (true, r) if r + 1 == b.height => ("└", "─", "┘"),
            (true, _) => ("│", " ", "│"),
            (false, _) => ("[", " ", "]"),
        };
        view.put(buf, Point { x: b.x, y }, left, frame);
        for k in 0..inner {
            let style = if fill == " " { text } else { frame };
            view.put(buf, Point { x: b.x + 1 + k, y }, fill, style);
        }
        view.put(
            buf,
            Point {
                x: b.x + b.width - 1,
                y,
            },
            right,
            frame,
        );
    }
    let pad = usize::from(b.bordered);
    view.text(
        buf,
        Point {
            x: b.x + 1 + pad,
            y: b.text_row(),
        },
        &b.text,
        text,
    );
}

/// The lines on screen: for each shown cell, which ways a line leaves it
/// and whether a highlighted line passes (it is then drawn highlighted).
struct Lines {
    area: Rect,
    cells: Vec<(u8, bool)>,
}

impl Lines {
    fn new(area: Rect) -> Self {
        Self {
            area,
            cells: vec![(0, false); usize::from(area.width) * usize::from(area.height)],
        }
    }

    fn add(&mut self, view: &Viewport, p: Point, ways: u8, hot: bool) {
        let Some((x, y)) = view.screen(p) else {
            return;
        };
        let i = usize::from(y - self.area.y) * usize::from(self.area.width)
            + usize::from(x - self.area.x);
        let cell = &mut self.cells[i];
        cell.0 |= ways;
        cell.1 |= hot;
    }

    /// Adds the straight line from `a` to `b`, clipped to the view.
    fn segment(&mut self, view: &Viewport, a: Point, b: Point, hot: bool) {
        let horizontal = a.y == b.y;
        let (lo, hi) = if horizontal {
            (a.x.min(b.x), a.x.max(b.x))
        } else {
            (a.y.min(b.y), a.y.max(b.y))
        };
        let (first, last) = if horizontal {
            (view.origin.0, view.origin.0 + usize::from(self.area.width))
        } else {
            (view.origin.1, view.origin.1 + usize::from(self.area.height))
        };
        for k in lo.max(first)..=hi.min(last) {
            let (p, back, forward) = if horizontal {
                (Point { x: k, y: a.y }, LEFT, RIGHT)
            } else {
                (Point { x: a.x, y: k }, UP, DOWN)
            };
            let ways = if k > lo { back } else { 0 } | if k < hi { forward } else { 0 };
            self.add(view, p, ways, hot);
        }
    }

    /// Draws the lines: highlighted ones in `hot`, the rest in `normal`.
    fn draw(&self, buf: &mut Buffer, normal: Style, hot: Style) {
        for (i, &(ways, is_hot)) in self.cells.iter().enumerate() {
            if ways == 0 {
                continue;
            }
            let style = if is_hot { hot } else { normal };
            let x = self.area.x + (i % usize::from(self.area.width)) as u16;
            let y = self.area.y + (i / usize::from(self.area.width)) as u16;
            if let Some(cell) = buf.cell_mut((x, y)) {
                cell.set_symbol(line_symbol(ways)).set_style(style);
            }
        }
    }
}

/// The box-drawing character for a cell left by lines in `ways`.
fn line_symbol(ways: u8) -> &'static str {
    match ways {
        w if w == UP | DOWN | LEFT | RIGHT => "┼",
        w if w == UP | DOWN | RIGHT => "├",
        w if w == UP | DOWN | LEFT => "┤",
        w if w == LEFT | RIGHT | DOWN => "┬",
        w if w == LEFT | RIGHT | UP => "┴",
        w if w == DOWN | RIGHT => "┌",
        w if w == DOWN | LEFT => "┐",
        w if w == UP | RIGHT => "└",
        w if w == UP | LEFT => "┘",
        w if w & (UP | DOWN) != 0 => "│",
        _ => "─",
    }
}
