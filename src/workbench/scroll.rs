//! One scrolling mechanism for every pane and overlay: text wrapped by
//! words with a hanging indent ([`wrap_hanging`]), a list of wrapped items
//! ([`Wrapped`]), the scroll position of a view ([`Scroll`]) that keeps a
//! selected item in view (an item taller than the view scrolls inside
//! itself before the selection moves on), and the visible markers
//! `↑ 3 more` / `↓ 5 more` on the pane's frame ([`render`]) whenever lines
//! are out of sight.
//!
//! A leaf module: it knows nothing of the screens that use it, only text,
//! line counts and ratatui's widgets, so that every pane can adopt it.
//! Views stay pure: a screen keeps a [`Scroll`] in its state and moves it
//! in its update; drawing brings the selection into view on a copy
//! ([`Scroll::following`]), so a frame never hides the selection even when
//! the update did not know the pane's size yet.

use std::ops::Range;

use crossterm::event::{MouseEvent, MouseEventKind};

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;
use unicode_width::{UnicodeWidthChar, UnicodeWidthStr};

/// How a key moves a view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// One line (or item) down (+1) or up (-1): ↓ ↑ j k.
    Line(isize),
    /// One page down (+1) or up (-1): PgDn PgUp.
    Page(isize),
    /// Half a page down (+1) or up (-1): Ctrl-D Ctrl-U.
    HalfPage(isize),
    /// To the top: Home.
    Home,
    /// To the bottom: End.
    End,
    /// The mouse wheel, this many lines down (+) or up (-); the selection
    /// is dragged along to stay in view.
    Wheel(isize),
}

impl Motion {
    /// The motion of the key table's `Move(delta)`: ±1 is a line,
    /// `isize::MIN` and `isize::MAX` are Home and End, any other delta a
    /// page in its direction (PgUp and PgDn are bound to ±10).
    pub fn of_move(delta: isize) -> Motion {
        match delta {
            isize::MIN => Motion::Home,
            isize::MAX => Motion::End,
            -1..=1 => Motion::Line(delta),
            d => Motion::Page(d.signum()),
        }
    }
}

/// The lines (or items) a wheel notch of `mouse` moves: 1 down, -1 up, 0 for any
/// other mouse event.
pub fn wheel_step(mouse: &MouseEvent) -> isize {
    match mouse.kind {
        MouseEventKind::ScrollDown => 1,
        MouseEventKind::ScrollUp => -1,
        _ => 0,
    }
}

/// The lines the mouse wheel scrolls at a time.
pub const WHEEL_LINES: isize = 3;

/// Wraps `prefix` then `body` to `width` columns by words: the first line
/// starts with `prefix`, every further line with blanks as wide as it (a
/// hanging indent), and a word longer than a line is broken where the line
/// ends. Runs of blanks inside a line are kept, those at a break dropped.
/// Always at least one line.
pub fn wrap_hanging(prefix: &[Span<'_>], body: &[Span<'_>], width: usize) -> Vec<Line<'static>> {
    let indent: usize = prefix.iter().map(|s| s.content.width()).sum();
    // A prefix as wide as the line leaves no room: no indent then.
    let indent = if indent + 1 >= width { 0 } else { indent };
    let width = width.max(1);
    let mut lines: Vec<Line<'static>> = Vec::new();
    let mut current: Vec<Span<'static>> = prefix
        .iter()
        .map(|s| Span::styled(s.content.to_string(), s.style))
        .collect();
    let mut used: usize = prefix.iter().map(|s| s.content.width()).sum();
    let mut at_start = true;
    let mut pending_blank: Option<(String, Style)> = None;
    let new_line = |lines: &mut Vec<Line<'static>>, current: &mut Vec<Span<'static>>| {
        lines.push(Line::from(std::mem::take(current)));
        current.push(Span::raw(" ".repeat(indent)));
    };
    for span in body {
        for (is_blank, piece) in tokens(&span.content) {
            if is_blank {
                match &mut pending_blank {
                    Some((text, _)) => text.push_str(piece),
                    None => pending_blank = Some((piece.to_string(), span.style)),
                }
                continue;
            }
            let blank = pending_blank.take();
            let blank_width = blank
                .as_ref()
                .filter(|_| !at_start)
                .map_or(0, |(t, _)| t.width());
            let word_width = piece.width();
            if !at_start && used + blank_width + word_width > width {
                new_line(&mut lines, &mut current);
                used = indent;
            } else if let Some((text, style)) = blank.filter(|_| !at_start) {
                current.push(Span::styled(text, style));
                used += blank_width;
            }
            // Break a word that does not fit on a line of its own.
            let mut rest = piece;
            while used + rest.width() > width && used < width {
                let room = width - used;
                let cut = cut_at_width(rest, room);
                if cut == 0 {
                    break;
                }
                current.push(Span::styled(rest[..cut].to_string(), span.style));
                rest = &rest[cut..];
                new_line(&mut lines, &mut current);
                used = indent;
            }
            if !rest.is_empty() {
                current.push(Span::styled(rest.to_string(), span.style));
                used += rest.width();
            }
            at_start = false;
        }
    }
    lines.push(Line::from(current));
    lines
}

/// Packs whole `entries` (a key and its words, a rating and its name) into
/// lines of `width` columns, `separator` between two on a line: an entry
/// never breaks across lines unless it is wider than a line alone (then it
/// is wrapped by [`wrap_hanging`]). Always at least one line.
pub fn pack(entries: &[Vec<Span<'_>>], separator: &Span<'_>, width: usize) -> Vec<Line<'static>> {
    let owned = |spans: &[Span<'_>]| -> Vec<Span<'static>> {
        spans
            .iter()
            .map(|s| Span::styled(s.content.to_string(), s.style))
            .collect()
    };
    let gap = separator.content.width();
    let mut lines: Vec<Line<'static>> = Vec::new();
    let mut current: Vec<Span<'static>> = Vec::new();
    let mut used = 0;
    for entry in entries {
        let w: usize = entry.iter().map(|s| s.content.width()).sum();
        if !current.is_empty() && used + gap + w <= width {
            current.push(Span::styled(separator.content.to_string(), separator.style));
            current.extend(owned(entry));
            used += gap + w;
            continue;
        }
        if !current.is_empty() {
            lines.push(Line::from(std::mem::take(&mut current)));
        }
        if w > width {
            let mut wrapped = wrap_hanging(&[], entry, width);
            let last = wrapped.pop().unwrap_or_default();
            lines.extend(wrapped);
            used = last.width();
            current = last.spans;
        } else {
            current = owned(entry);
            used = w;
        }
    }
    lines.push(Line::from(current));
    lines
}

/// The pieces of `text`: runs of blanks and runs of other characters, each
/// marked whether it is blank.
fn tokens(text: &str) -> impl Iterator<Item = (bool, &str)> + '_ {
    let mut rest = text;
    std::iter::from_fn(move || {
        let first = rest.chars().next()?;
        let blank = first.is_whitespace();
        let end = rest
            .char_indices()
            .find(|(_, c)| c.is_whitespace() != blank)
            .map_or(rest.len(), |(i, _)| i);
        let (piece, tail) = rest.split_at(end);
        rest = tail;
        Some((blank, piece))
    })
}

/// The byte length of the longest start of `text` at most `room` columns
/// wide, at least one character when `room` is not zero.
fn cut_at_width(text: &str, room: usize) -> usize {
    let mut used = 0;
    for (i, c) in text.char_indices() {
        let w = unicode_width::UnicodeWidthChar::width(c).unwrap_or(0);
        if used + w > room {
            return if i == 0 { c.len_utf8() } else { i };
        }
        used += w;
    }
    text.len()
}

/// Items wrapped into lines, one after another: item `i` takes the lines
/// [`Wrapped::span`]`(i)`.
#[derive(Debug, Clone, Default)]
pub struct Wrapped {
    lines: Vec<Line<'static>>,
    /// Where each item starts, and the total at the end.
    starts: Vec<usize>,
}

impl Wrapped {
    /// The items, each already wrapped (see [`wrap_hanging`]); an item of
    /// no lines takes one empty line, so every item can be shown.
    pub fn new(items: impl IntoIterator<Item = Vec<Line<'static>>>) -> Wrapped {
        let mut out = Wrapped {
            lines: Vec::new(),
            starts: vec![0],
        };
        for mut item in items {
            if item.is_empty() {
                item.push(Line::default());
            }
            out.lines.extend(item);
            out.starts.push(out.lines.len());
        }
        out
    }

    /// How many items there are.
    pub fn items(&self) -> usize {
        self.starts.len() - 1
    }

    /// How many lines there are.
    pub fn total(&self) -> usize {
        self.lines.len()
    }

    /// The lines item `i` takes (empty past the end).
    pub fn span(&self, i: usize) -> Range<usize> {
        match (self.starts.get(i), self.starts.get(i + 1)) {
            (Some(&a), Some(&b)) => a..b,
            _ => self.total()..self.total(),
        }
    }

    /// The item line `line` belongs to (the last one past the end).
    pub fn item_at(&self, line: usize) -> usize {
        let n = self.items();
        (0..n)
            .find(|&i| self.span(i).contains(&line))
            .unwrap_or(n.saturating_sub(1))
    }

    /// Every line, in order.
    pub fn lines(&self) -> &[Line<'static>] {
        &self.lines
    }
}

/// The scroll position of one view: the first line shown.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Scroll {
    offset: usize,
}

impl Scroll {
    /// A view from line `offset` down (kept inside the text when drawn).
    pub fn at(offset: usize) -> Scroll {
        Scroll { offset }
    }

    /// The first line shown.
    pub fn offset(self) -> usize {
        self.offset
    }

    /// Back to the top (a new text shown in the view).
    pub fn reset(&mut self) {
        self.offset = 0;
    }

    /// The offset kept inside the text: no blank page past its end.
    fn clamp(&mut self, total: usize, viewport: usize) {
        self.offset = self.offset.min(total.saturating_sub(viewport));
    }

    /// Whether item `i` is in view: whole when it fits in `viewport` lines,
    /// else at least one of its lines.
    pub fn shows(self, wrapped: &Wrapped, i: usize, viewport: usize) -> bool {
        self.shows_span(wrapped.span(i), viewport)
    }

    /// Whether the lines `span` are in view: all of them when they fit in
    /// `viewport` lines, else at least one.
    fn shows_span(self, span: Range<usize>, viewport: usize) -> bool {
        if span.is_empty() || viewport == 0 {
            return false;
        }
        let (top, bottom) = (self.offset, self.offset + viewport);
        if span.len() <= viewport {
            span.start >= top && span.end <= bottom
        } else {
            span.start < bottom && span.end > top
        }
    }

    /// Brings item `selected` into view with the least movement: an item
    /// above the view shows from its top, one below shows down to its
    /// bottom; an item taller than the view that is partly in view stays
    /// where it is (it scrolls inside itself).
    pub fn follow(&mut self, wrapped: &Wrapped, selected: usize, viewport: usize) {
        self.reveal(wrapped.span(selected), wrapped.total(), viewport);
    }

    /// Brings the lines `span` of a text of `total` lines into view with
    /// the least movement, as [`Scroll::follow`] does for an item: for
    /// anything shown in a scrolled view, whether lines of a list or the
    /// rows (or columns) of a box in a drawing.
    pub fn reveal(&mut self, span: Range<usize>, total: usize, viewport: usize) {
        self.clamp(total, viewport);
        if self.shows_span(span.clone(), viewport) {
            return;
        }
        if span.start < self.offset || span.len() > viewport {
            self.offset = span.start;
        } else {
            self.offset = span.end.saturating_sub(viewport);
        }
    }

    /// A copy that shows item `selected` ([`Scroll::follow`]): what a
    /// frame draws.
    pub fn following(mut self, wrapped: &Wrapped, selected: usize, viewport: usize) -> Scroll {
        self.follow(wrapped, selected, viewport);
        self
    }

    /// Moves a list with a selected item by `motion` and returns the item
    /// selected after. ↓ scrolls inside the selected item while it goes on
    /// below the view, then selects the next; ↑ likewise upwards (entering
    /// a tall item at its bottom); a page moves the view and selects the
    /// first item wholly (or, if none, partly) in it; Home and End go to
    /// the first and last item; the wheel scrolls and drags the selection.
    pub fn select(
        &mut self,
        wrapped: &Wrapped,
        selected: usize,
        viewport: usize,
        motion: Motion,
    ) -> usize {
        let n = wrapped.items();
        if n == 0 {
            self.offset = 0;
            return 0;
        }
        let selected = selected.min(n - 1);
        self.follow(wrapped, selected, viewport);
        let span = wrapped.span(selected);
        let bottom = self.offset + viewport;
        let chosen = match motion {
            Motion::Line(d) if d > 0 => {
                if span.end > bottom {
                    self.offset += 1;
                    return selected;
                }
                (selected + 1).min(n - 1)
            }
            Motion::Line(d) if d < 0 => {
                if span.start < self.offset {
                    self.offset -= 1;
                    return selected;
                }
                let previous = selected.saturating_sub(1);
                let above = wrapped.span(previous);
                if previous != selected && above.start < self.offset {
                    // Enter it at its bottom: ↑ goes on inside it.
                    self.offset = above.end.saturating_sub(viewport).max(above.start);
                }
                previous
            }
            Motion::Line(_) => selected,
            Motion::Page(d) | Motion::HalfPage(d) | Motion::Wheel(d) => {
                let lines = match motion {
                    Motion::Page(_) => viewport.saturating_sub(1).max(1),
                    Motion::HalfPage(_) => (viewport / 2).max(1),
                    _ => d.unsigned_abs(),
                };
                self.offset = if d > 0 {
                    self.offset + lines
                } else {
                    self.offset.saturating_sub(lines)
                };
                self.clamp(wrapped.total(), viewport);
                if self.shows(wrapped, selected, viewport) && matches!(motion, Motion::Wheel(_)) {
                    return selected;
                }
                let in_view = |i: &usize| self.shows(wrapped, *i, viewport);
                let candidates: Vec<usize> = (0..n).filter(in_view).collect();
                let pick = if d > 0 {
                    candidates.first()
                } else {
                    candidates.last()
                };
                match pick {
                    Some(&i) => return i,
                    None => wrapped.item_at(self.offset),
                }
            }
            Motion::Home => {
                self.offset = 0;
                0
            }
            Motion::End => {
                self.offset = wrapped.total().saturating_sub(viewport);
                n - 1
            }
        };
        self.follow(wrapped, chosen, viewport);
        chosen
    }

    /// Moves a view without a selection (a text to read) by `motion`.
    pub fn scroll(&mut self, total: usize, viewport: usize, motion: Motion) {
        let page = viewport.saturating_sub(1).max(1);
        self.offset = match motion {
            Motion::Line(d) | Motion::Wheel(d) => self.offset.saturating_add_signed(d),
            Motion::Page(d) => self.offset.saturating_add_signed(d * page as isize),
            Motion::HalfPage(d) => self
                .offset
                .saturating_add_signed(d * (viewport / 2).max(1) as isize),
            Motion::Home => 0,
            Motion::End => usize::MAX,
        };
        self.clamp(total, viewport);
    }
}

/// A text in a box laid out over the screen (the help, the message log,
/// the framed actions): its scroll position and the screen it is laid out
/// for are all it keeps, so scrolling and resizing are written once.
pub trait ScrolledBox {
    /// Its scroll position and the screen it is laid out over.
    fn view(&mut self) -> (&mut Scroll, &mut Rect);

    /// Its lines over `area`, and how many of them its box shows.
    fn measure(&self, area: Rect) -> (usize, usize);

    /// Scrolls it by `motion`, within its lines.
    fn scroll_by(&mut self, motion: Motion) {
        let area = *self.view().1;
        let (total, viewport) = self.measure(area);
        self.view().0.scroll(total, viewport, motion);
    }

    /// Scrolls it [`WHEEL_LINES`] a notch when `mouse` is the wheel;
    /// whether it was.
    fn on_wheel(&mut self, mouse: &MouseEvent) -> bool {
        let step = wheel_step(mouse);
        if step != 0 {
            self.scroll_by(Motion::Wheel(step * WHEEL_LINES));
        }
        step != 0
    }

    /// Lays it out over a resized screen `area`, still within its lines.
    fn resize(&mut self, area: Rect) {
        *self.view().1 = area;
        self.scroll_by(Motion::Line(0));
    }
}

/// How many columns `text` takes in a terminal.
pub fn text_width(text: &str) -> usize {
    text.chars().map(|c| c.width().unwrap_or(0)).sum()
}

/// `text` on one line (control characters as spaces), cut with `…` (after
/// the last character kept, not a space) to at most `width` columns; empty
/// when `width` is 0.
pub fn truncate(text: &str, width: usize) -> String {
    let clean: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    if text_width(&clean) <= width {
        return clean;
    }
    if width == 0 {
        return String::new();
    }
    let mut out = String::new();
    let mut used = 0;
    for c in clean.chars() {
        let w = c.width().unwrap_or(0);
        if used + w > width - 1 {
            break;
        }
        used += w;
        out.push(c);
    }
    // `in…`, not `in …`: the ellipsis follows the last character shown.
    out.truncate(out.trim_end().len());
    out.push('…');
    out
}

/// `line` as it is when it fits `width` columns, else cut with `…`, each
/// span keeping its style: a one-line text that must not be cut silently.
pub fn cut_line<'a>(line: Line<'a>, width: usize) -> Line<'a> {
    if line.width() <= width {
        return line;
    }
    let mut left = width;
    let mut spans = Vec::new();
    let count = line.spans.len();
    for (i, span) in line.spans.into_iter().enumerate() {
        let w = text_width(&span.content);
        if w <= left && (i + 1 == count || w < left) {
            left -= w;
            spans.push(span);
            continue;
        }
        // A span that fills the rest exactly, with more to come, leaves
        // its last column to the ellipsis.
        let room = if w > left {
            left
        } else {
            left.saturating_sub(1)
        };
        spans.push(Span::styled(truncate(&span.content, room), span.style));
        break;
    }
    Line::from(spans)
}

/// The markers of a view `offset` lines down a text of `total` lines
/// showing `viewport`: `↑ N more` when lines are above it, `↓ N more` when
/// lines are below it.
pub fn markers(offset: usize, total: usize, viewport: usize) -> (Option<String>, Option<String>) {
    let below = total.saturating_sub(offset + viewport);
    (
        (offset > 0).then(|| format!("↑ {offset} more")),
        (below > 0).then(|| format!("↓ {below} more")),
    )
}

/// `text` wrapped by words to `width` columns, line by line (blank lines
/// kept): how a pane of running text fits it before [`render`] scrolls it.
pub fn wrap_text(text: &[Line<'_>], width: usize) -> Vec<Line<'static>> {
    text.iter()
        .flat_map(|line| wrap_hanging(&[], &line.spans, width))
        .collect()
}

/// `block` with the [`markers`] of a view `offset` lines down a text of
/// `total` lines showing `viewport` on its top and bottom edges, right
/// aligned in `marker_style`: what [`render`] draws, for a pane whose
/// scrolled text is only part of what it shows.
pub fn framed<'a>(
    block: Block<'a>,
    offset: usize,
    total: usize,
    viewport: usize,
    marker_style: Style,
) -> Block<'a> {
    let (up, down) = markers(offset, total, viewport);
    let mut block = block;
    if let Some(up) = up {
        block = block
            .title_top(Line::from(Span::styled(format!(" {up} "), marker_style)).right_aligned());
    }
    if let Some(down) = down {
        block = block.title_bottom(
            Line::from(Span::styled(format!(" {down} "), marker_style)).right_aligned(),
        );
    }
    block
}

/// Draws `lines` in `block` over `area`, from line `scroll.offset()`, with
/// the markers ([`markers`]) on the frame's top and bottom edges, right
/// aligned in `marker_style`. The lines must be wrapped for the inner
/// width already.
pub fn render(
    frame: &mut Frame,
    area: Rect,
    block: Block<'_>,
    lines: &[Line<'static>],
    scroll: Scroll,
    marker_style: Style,
) {
    let inner = block.inner(area);
    let viewport = usize::from(inner.height);
    let mut scroll = scroll;
    scroll.clamp(lines.len(), viewport);
    let block = framed(block, scroll.offset, lines.len(), viewport, marker_style);
    let shown: Vec<Line<'static>> = lines
        .iter()
        .skip(scroll.offset)
        .take(viewport)
        .cloned()
        .collect();
    frame.render_widget(Paragraph::new(shown).block(block), area);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(lines: &[Line<'_>]) -> Vec<String> {
        lines
            .iter()
            .map(|l| l.spans.iter().map(|s| s.content.as_ref()).collect())
            .collect()
    }

    fn items(heights: &[usize]) -> Wrapped {
        Wrapped::new(heights.iter().map(|&h| {
            (0..h)
                .map(|k| Line::from(format!("line {k}")))
                .collect::<Vec<_>>()
        }))
    }

    #[test]
    fn wrapping_hangs_under_the_prefix_and_breaks_long_words() {
        let lines = wrap_hanging(
            &[Span::raw("12. ")],
            &[Span::raw("Pick up the  red mug from the counter")],
            16,
        );
        assert_eq!(
            text(&lines),
            ["12. Pick up the", "    red mug from", "    the counter"]
        );
        let long = wrap_hanging(&[Span::raw("1. ")], &[Span::raw("abcdefghijklmnop")], 8);
        assert_eq!(text(&long), ["1. abcde", "   fghij", "   klmno", "   p"]);
        assert_eq!(text(&wrap_hanging(&[], &[], 5)), [""]);
        // Styles survive the wrap, and a label span wraps like the text.
        let styled = wrap_hanging(
            &[Span::raw("1. ")],
            &[
                Span::raw("Open it."),
                Span::styled("  [wrong order]", Style::new().bold()),
            ],
            14,
        );
        assert_eq!(text(&styled), ["1. Open it.", "   [wrong", "   order]"]);
        assert_eq!(styled[1].spans[1].style, Style::new().bold());
    }

    #[test]
    fn packing_keeps_each_entry_whole() {
        let entries: Vec<Vec<Span>> = ["1 Useless", "2 Poor", "3 Fair", "4 Good", "5 Excellent"]
            .iter()
            .map(|e| vec![Span::raw(*e)])
            .collect();
        let lines = pack(&entries, &Span::raw("  "), 24);
        assert_eq!(
            text(&lines),
            ["1 Useless  2 Poor", "3 Fair  4 Good", "5 Excellent"]
        );
        assert_eq!(
            text(&pack(&entries[..1], &Span::raw(" "), 4)),
            ["1", "Usel", "ess"]
        );
        assert_eq!(text(&pack(&[], &Span::raw(" "), 4)), [""]);
    }

    #[test]
    fn every_line_fits_and_no_word_is_lost() {
        let body = "Walk to the sink, then turn the faucet on briefly before turning it off again.";
        for width in 6..40 {
            let lines = wrap_hanging(&[Span::raw("3. ")], &[Span::raw(body)], width);
            let got: Vec<String> = text(&lines);
            assert!(got.iter().all(|l| l.width() <= width), "{width}: {got:?}");
            let words: String = got.concat().split_whitespace().collect::<Vec<_>>().join("");
            assert_eq!(words, format!("3.{}", body.replace(' ', "")), "{width}");
        }
    }

    #[test]
    fn the_selection_stays_in_view_and_a_tall_item_scrolls_inside_itself() {
        let w = items(&[1, 2, 5, 1, 1]);
        let mut s = Scroll::default();
        let view = 3;
        let mut sel = 0;
        let mut seen = Vec::new();
        for _ in 0..12 {
            sel = s.select(&w, sel, view, Motion::Line(1));
            assert!(s.shows(&w, sel, view), "{sel} at {}", s.offset());
            seen.push((sel, s.offset()));
        }
        // Item 2 (lines 3..8) is entered at its top and scrolled through.
        assert_eq!(
            &seen[..6],
            &[(1, 0), (2, 3), (2, 4), (2, 5), (3, 6), (4, 7)]
        );
        assert_eq!(s.offset(), 7, "the end: no blank page");
        for _ in 0..12 {
            sel = s.select(&w, sel, view, Motion::Line(-1));
            assert!(s.shows(&w, sel, view));
        }
        assert_eq!((sel, s.offset()), (0, 0));
        assert_eq!(s.select(&w, sel, view, Motion::End), 4);
        assert_eq!(s.offset(), 7);
        assert_eq!(s.select(&w, 4, view, Motion::Home), 0);
        assert_eq!(s.offset(), 0);
        let paged = s.select(&w, 0, view, Motion::Page(1));
        assert!(paged > 0 && s.shows(&w, paged, view));
        let wheel = s.select(&w, paged, view, Motion::Wheel(3));
        assert!(s.shows(&w, wheel, view));
    }

    #[test]
    fn markers_count_the_lines_out_of_sight() {
        assert_eq!(markers(0, 3, 5), (None, None));
        assert_eq!(
            markers(3, 13, 5),
            (Some("↑ 3 more".into()), Some("↓ 5 more".into()))
        );
        let mut s = Scroll::default();
        s.scroll(13, 5, Motion::End);
        assert_eq!(s.offset(), 8);
        s.scroll(13, 5, Motion::Page(-1));
        assert_eq!(s.offset(), 4);
        s.scroll(13, 5, Motion::Wheel(-9));
        assert_eq!(s.offset(), 0);
        assert_eq!(Motion::of_move(10), Motion::Page(1));
        assert_eq!(Motion::of_move(isize::MIN), Motion::Home);
    }
}
