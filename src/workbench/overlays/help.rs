//! The key help overlay: the key table, drawn as it is declared, for the
//! workbench and for the annotation screen.

use crossterm::event::KeyEvent;
use ratatui::layout::Rect;
use ratatui::layout::{Constraint, Layout};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph, Wrap};
use ratatui::Frame;
use unicode_width::UnicodeWidthStr;

use super::{centred, themed_box};
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::theme::Theme;

/// The help overlay. It has no keys of its own: any key closes it.
#[derive(Debug, Clone, Copy, Default)]
pub struct Help;

/// What a key does to the help: it always closes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Close;

impl Component for Help {
    type Outcome = Close;

    fn contexts(&self) -> Vec<Context> {
        Vec::new()
    }

    fn on_action(&mut self, _action: Action) -> Close {
        Close
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Close {
        Close
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        draw_keys(frame, area, theme, &[], keymap::help_lines());
    }
}

/// The width of the keys column of every help.
const KEYS_WIDTH: usize = 34;

/// The widest a help box gets.
const HELP_WIDTH: u16 = 100;

/// Draws a key help over `area`, closed by any key: `intro` (paragraphs,
/// wrapped) above one row per binding, its keys and what they do. The
/// workbench's help and the annotation screen's are both drawn by it.
pub fn draw_keys<'a>(
    frame: &mut Frame,
    area: Rect,
    theme: &Theme,
    intro: &[String],
    rows: impl Iterator<Item = (&'a str, &'a str)>,
) {
    let rows: Vec<Line> = rows
        .map(|(keys, what)| {
            Line::from(vec![
                Span::styled(format!("{keys:<KEYS_WIDTH$}"), theme.accent),
                Span::styled(what, theme.base),
            ])
        })
        .collect();
    let inner_width = usize::from(
        HELP_WIDTH
            .min(area.width.saturating_sub(2))
            .saturating_sub(2),
    );
    let intro_height = match intro {
        [] => 0,
        _ => {
            intro
                .iter()
                .map(|p| wrapped_height(p, inner_width))
                .sum::<usize>()
                + 1
        }
    };
    let height = u16::try_from(intro_height + rows.len() + 2).unwrap_or(u16::MAX);
    let rect = centred(area, HELP_WIDTH, height);
    frame.render_widget(Clear, rect);
    let block = themed_box(theme, "Keys (any key closes)");
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    let [top, bottom] = Layout::vertical([
        Constraint::Length(u16::try_from(intro_height).unwrap_or(u16::MAX)),
        Constraint::Min(0),
    ])
    .areas(inner);
    let intro: Vec<Line> = intro
        .iter()
        .map(|p| Line::from(Span::styled(p.as_str(), theme.base)))
        .collect();
    frame.render_widget(Paragraph::new(intro).wrap(Wrap { trim: true }), top);
    frame.render_widget(Paragraph::new(rows), bottom);
}

/// The lines `text` takes when its words are wrapped greedily at `width`
/// columns (a word wider than the line takes lines of its own).
fn wrapped_height(text: &str, width: usize) -> usize {
    let width = width.max(1);
    let mut lines = 1;
    let mut used = 0;
    for word in text.split_whitespace().map(UnicodeWidthStr::width) {
        let needed = if used == 0 { word } else { used + 1 + word };
        if needed <= width {
            used = needed;
        } else {
            lines += usize::from(used > 0) + (word.saturating_sub(1)) / width;
            used = (word - 1) % width + 1;
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::wrapped_height;

    #[test]
    fn wrapped_height_counts_greedy_lines() {
        assert_eq!(wrapped_height("", 10), 1);
        assert_eq!(wrapped_height("one two", 7), 1);
        assert_eq!(wrapped_height("one two three", 7), 2);
        assert_eq!(wrapped_height("abcdefghijkl", 5), 3);
        assert_eq!(wrapped_height("ab abcdefghijkl", 5), 4);
    }
}
