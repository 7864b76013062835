//! The key help overlay: the key table, drawn as it is declared, for the
//! workbench and for the annotation screen.

use std::convert::Infallible;

use crossterm::event::{KeyEvent, MouseEvent, MouseEventKind};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Clear;
use ratatui::Frame;
use unicode_width::UnicodeWidthStr;

use super::{centred, themed_box, Picked};
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::scroll::{self, wrap_hanging, Motion, Scroll, ScrolledBox};
use crate::workbench::theme::Theme;

/// The help overlay: every key of the workbench, drawn from the key table
/// with its description wrapped under itself, scrolled by the movement
/// keys and the wheel (with `↑ N more` / `↓ N more` on its frame); any
/// other key closes it.
#[derive(Debug, Clone, Copy)]
pub struct Help {
    scroll: Scroll,
    area: Rect,
}

impl Help {
    /// The help at its top, laid out over `area` (the screen).
    pub fn new(area: Rect) -> Help {
        Help {
            scroll: Scroll::default(),
            area,
        }
    }
}

impl ScrolledBox for Help {
    fn view(&mut self) -> (&mut Scroll, &mut Rect) {
        (&mut self.scroll, &mut self.area)
    }

    fn measure(&self, area: Rect) -> (usize, usize) {
        let (_, lines, viewport) = layout(area, &Theme::no_color());
        (lines.len(), viewport)
    }
}

impl Component for Help {
    /// The help chooses nothing: it stays open (scrolled) or is closed.
    type Outcome = Picked<Infallible>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Help]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Move(delta) => {
                self.scroll_by(Motion::of_move(delta));
                Picked::Open
            }
            _ => Picked::Cancelled,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Self::Outcome {
        Picked::Cancelled
    }

    /// The wheel scrolls; a click closes the help, as any key but the
    /// scrolling ones does.
    fn on_mouse(&mut self, mouse: MouseEvent, _area: Rect) -> Self::Outcome {
        if self.on_wheel(&mouse) || !matches!(mouse.kind, MouseEventKind::Down(_)) {
            Picked::Open
        } else {
            Picked::Cancelled
        }
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (rect, lines, _) = layout(area, theme);
        frame.render_widget(Clear, rect);
        let block = themed_box(theme, "Keys (↑↓ PgUp PgDn scroll · any other key closes)");
        scroll::render(frame, rect, block, &lines, self.scroll, theme.accent);
    }
}

/// The widest a help box gets.
const HELP_WIDTH: u16 = 100;

/// The help's box over `area`, its lines and how many it shows at once.
fn layout(area: Rect, theme: &Theme) -> (Rect, Vec<Line<'static>>, usize) {
    let width = HELP_WIDTH.min(area.width.saturating_sub(2));
    let inner_width = usize::from(width.saturating_sub(2)).max(1);
    let lines = key_rows(keymap::help_lines(), inner_width, theme);
    let height = u16::try_from(lines.len() + 2).unwrap_or(u16::MAX);
    let rect = centred(area, width, height);
    (rect, lines, usize::from(rect.height.saturating_sub(2)))
}

/// One row per binding for a help `width` columns wide: its keys in a
/// column as wide as the widest label (at most a third of the width), then what
/// it does, wrapped under itself; a label wider than the column takes a
/// line of its own. Every help (the workbench's and the annotation
/// screen's) lays its keys out by this.
pub fn key_rows<'a>(
    rows: impl Iterator<Item = (&'a str, &'a str)>,
    width: usize,
    theme: &Theme,
) -> Vec<Line<'static>> {
    let rows: Vec<(&str, &str)> = rows.collect();
    let keys_width = rows
        .iter()
        .map(|(k, _)| k.width())
        .max()
        .unwrap_or(0)
        .min(width / 3)
        + 2;
    let mut lines = Vec::new();
    for (keys, what) in rows {
        let pad = keys_width.saturating_sub(keys.width());
        let mut prefix = vec![Span::styled(
            format!("{keys}{}", " ".repeat(pad)),
            theme.accent,
        )];
        if keys.width() + 2 > keys_width {
            lines.push(Line::from(prefix));
            prefix = vec![Span::raw(" ".repeat(keys_width))];
        }
        lines.extend(wrap_hanging(
            &prefix,
            &[Span::styled(what.to_string(), theme.base)],
            width,
        ));
    }
    lines
}
