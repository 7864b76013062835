//! The key help overlay: the key table, drawn as it is declared.

use crossterm::event::KeyEvent;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;

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
        let lines: Vec<Line> = keymap::help_lines()
            .map(|(keys, what)| {
                Line::from(vec![
                    Span::styled(format!("{keys:<34}"), theme.accent),
                    Span::styled(what, theme.base),
                ])
            })
            .collect();
        let rect = centred(area, 100, lines.len() as u16 + 2);
        frame.render_widget(Clear, rect);
        frame.render_widget(
            Paragraph::new(lines).block(themed_box(theme, "Keys (any key closes)")),
            rect,
        );
    }
}
