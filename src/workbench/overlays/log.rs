//! The message log (`M`): every status message and notice of this
//! workbench, with when it came, newest last. The status line shows only
//! the latest message, and cuts a long one; here each is whole, wrapped
//! under its time, and scrolled like the help.

use std::convert::Infallible;

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Clear;
use ratatui::Frame;

use super::{centred, themed_box, Picked};
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::scroll::{self, wrap_hanging, Motion, Scroll, ScrolledBox};
use crate::workbench::shared::{LogEntry, Severity};
use crate::workbench::theme::Theme;

/// The widest the log's box gets.
const LOG_WIDTH: u16 = 120;

/// The log overlay: a copy of the messages (kept up to date while it is
/// open), scrolled to the newest when it opens.
#[derive(Debug, Clone)]
pub struct MessageLog {
    entries: Vec<LogEntry>,
    scroll: Scroll,
    area: Rect,
}

impl MessageLog {
    /// The log over `area` (the screen), at its newest message.
    pub fn new(entries: &[LogEntry], area: Rect) -> MessageLog {
        let mut log = MessageLog {
            entries: entries.to_vec(),
            scroll: Scroll::default(),
            area,
        };
        log.scroll_by(Motion::End);
        log
    }

    /// Takes the messages as they are now; a view at the newest message
    /// follows the new ones.
    pub fn update(&mut self, entries: &[LogEntry]) {
        let (lines, viewport) = self.measure(self.area);
        let at_end = self.scroll.offset() + viewport >= lines;
        self.entries = entries.to_vec();
        if at_end {
            self.scroll_by(Motion::End);
        }
    }
}

impl ScrolledBox for MessageLog {
    fn view(&mut self) -> (&mut Scroll, &mut Rect) {
        (&mut self.scroll, &mut self.area)
    }

    fn measure(&self, area: Rect) -> (usize, usize) {
        let (_, lines, viewport) = layout(&self.entries, area, &Theme::no_color());
        (lines.len(), viewport)
    }
}

impl Component for MessageLog {
    /// The log chooses nothing: it stays open (scrolled) or is closed.
    type Outcome = Picked<Infallible>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Viewer]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Move(delta) => {
                self.scroll_by(Motion::of_move(delta));
                Picked::Open
            }
            Action::HalfPage(delta) => {
                self.scroll_by(Motion::HalfPage(delta));
                Picked::Open
            }
            Action::Leave => Picked::Cancelled,
            _ => Picked::Open,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Self::Outcome {
        Picked::Open
    }

    /// The wheel scrolls; a click changes nothing.
    fn on_mouse(&mut self, mouse: MouseEvent, _area: Rect) -> Self::Outcome {
        self.on_wheel(&mouse);
        Picked::Open
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (rect, lines, _) = layout(&self.entries, area, theme);
        frame.render_widget(Clear, rect);
        let title = format!("Messages, newest last ({})", keymap::hints(Context::Viewer));
        let block = themed_box(theme, &title);
        scroll::render(frame, rect, block, &lines, self.scroll, theme.accent);
    }
}

/// The log's box over `area`, its lines and how many it shows at once:
/// each message under its time (`m:ss` since the start), wrapped under
/// itself, in its severity's colour.
fn layout(entries: &[LogEntry], area: Rect, theme: &Theme) -> (Rect, Vec<Line<'static>>, usize) {
    let width = LOG_WIDTH.min(area.width.saturating_sub(2));
    let inner = usize::from(width.saturating_sub(2)).max(1);
    let mut lines: Vec<Line<'static>> = entries
        .iter()
        .flat_map(|entry| {
            let secs = entry.at.as_secs();
            let time = Span::styled(format!("{:>3}:{:02}  ", secs / 60, secs % 60), theme.muted);
            let style = match entry.severity {
                Severity::Info => theme.base,
                Severity::Warn => theme.warn,
                Severity::Error => theme.bad,
            };
            let text = crate::sanitize::one_line(&entry.text);
            wrap_hanging(&[time], &[Span::styled(text, style)], inner)
        })
        .collect();
    if lines.is_empty() {
        lines.push(Line::from(Span::styled("No messages yet.", theme.muted)));
    }
    let height = u16::try_from(lines.len() + 2).unwrap_or(u16::MAX);
    let rect = centred(area, width, height);
    (rect, lines, usize::from(rect.height.saturating_sub(2)))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn entry(secs: u64, text: &str) -> LogEntry {
        LogEntry {
            at: Duration::from_secs(secs),
            text: text.to_string(),
            severity: Severity::Warn,
        }
    }

    #[test]
    fn it_opens_at_the_newest_and_follows_new_messages_only_from_there() {
        let entries: Vec<LogEntry> = (0..50).map(|i| entry(i, &format!("message {i}"))).collect();
        let area = Rect::new(0, 0, 80, 24);
        let mut log = MessageLog::new(&entries[..40], area);
        let (_, lines, viewport) = layout(&entries[..40], area, &Theme::no_color());
        assert_eq!(log.scroll.offset() + viewport, lines.len(), "at the end");
        log.update(&entries[..45]);
        let (_, lines, _) = layout(&entries[..45], area, &Theme::no_color());
        assert_eq!(log.scroll.offset() + viewport, lines.len(), "followed");
        log.scroll_by(Motion::Home);
        log.update(&entries);
        assert_eq!(log.scroll.offset(), 0, "left where the reader is");
    }

    #[test]
    fn a_long_message_is_wrapped_whole_under_its_time() {
        let long = "Planner: openai answered HTTP 500 ".repeat(6);
        let (_, lines, _) = layout(
            &[entry(75, &long)],
            Rect::new(0, 0, 60, 20),
            &Theme::no_color(),
        );
        let text: String = lines
            .iter()
            .map(|l| {
                l.spans
                    .iter()
                    .map(|s| s.content.as_ref())
                    .collect::<String>()
            })
            .collect::<Vec<_>>()
            .join("\n");
        assert!(text.starts_with("  1:15  Planner: openai"), "{text}");
        assert!(lines.len() > 2, "{text}");
        let words: String = text
            .split_whitespace()
            .skip(1)
            .collect::<Vec<_>>()
            .join(" ");
        assert_eq!(words, long.trim(), "every word, in order");
    }
}
