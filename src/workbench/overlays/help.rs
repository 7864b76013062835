//! The key help overlay: the key table, drawn as it is declared, a
//! section a context under its title, for the workbench and for the
//! annotation screen; the workbench's can be filtered by words typed in it.

use std::convert::Infallible;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers, MouseEvent, MouseEventKind};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Clear;
use ratatui::Frame;
use unicode_width::UnicodeWidthStr;

use super::{centred, themed_box, Picked};
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Binding, Context, Section};
use crate::workbench::scroll::{self, wrap_hanging, Motion, Scroll, ScrolledBox};
use crate::workbench::theme::Theme;

/// The help overlay: every key of the workbench, drawn from the key table
/// a section a context, each description wrapped under itself, scrolled by
/// the movement keys and the wheel (with `↑ N more` / `↓ N more` on its
/// frame); `/` filters it by words typed in place, and a key it does not
/// bind closes it.
#[derive(Debug, Clone)]
pub struct Help {
    scroll: Scroll,
    area: Rect,
    /// The words the rows shown must contain ("" shows every row).
    filter: String,
    /// Whether typed keys go to the filter.
    typing: bool,
}

impl Help {
    /// The help at its top, laid out over `area` (the screen).
    pub fn new(area: Rect) -> Help {
        Help {
            scroll: Scroll::default(),
            area,
            filter: String::new(),
            typing: false,
        }
    }

    /// The key context of the help as it is: typing its filter, or not.
    pub fn context(&self) -> Context {
        if self.typing {
            Context::HelpFilter
        } else {
            Context::Help
        }
    }

    /// The help's box over `area`, its lines and how many it shows at once.
    fn layout(&self, area: Rect, theme: &Theme) -> (Rect, Vec<Line<'static>>, usize) {
        let width = HELP_WIDTH.min(area.width.saturating_sub(2));
        let inner_width = usize::from(width.saturating_sub(2)).max(1);
        let sections = filtered(
            keymap::help_sections(&keymap::workbench_contexts()),
            &self.filter,
        );
        let lines = if sections.is_empty() {
            vec![Line::from(Span::styled(
                format!("no key is found with \"{}\"", self.filter),
                theme.muted,
            ))]
        } else {
            key_lines(&sections, inner_width, theme)
        };
        let height = u16::try_from(lines.len() + 2).unwrap_or(u16::MAX);
        let rect = centred(area, width, height);
        (rect, lines, usize::from(rect.height.saturating_sub(2)))
    }

    /// The box's title: what the keys do here, or the filter being typed.
    fn title(&self) -> String {
        let hints = keymap::hints(self.context());
        match (self.typing, self.filter.is_empty()) {
            (true, _) => format!("Keys with: {}▏ ({hints})", self.filter),
            (false, true) => format!("Keys ({hints})"),
            (false, false) => format!("Keys with \"{}\" ({hints})", self.filter),
        }
    }

    /// The filter changed: shown from its top.
    fn refiltered(&mut self) -> Picked<Infallible> {
        self.scroll.reset();
        Picked::Open
    }
}

impl ScrolledBox for Help {
    fn view(&mut self) -> (&mut Scroll, &mut Rect) {
        (&mut self.scroll, &mut self.area)
    }

    fn measure(&self, area: Rect) -> (usize, usize) {
        let (_, lines, viewport) = self.layout(area, &Theme::no_color());
        (lines.len(), viewport)
    }
}

impl Component for Help {
    /// The help chooses nothing: it stays open (scrolled or filtered) or
    /// is closed.
    type Outcome = Picked<Infallible>;

    fn contexts(&self) -> Vec<Context> {
        vec![self.context()]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match (self.typing, action) {
            (false, Action::Move(delta)) => {
                self.scroll_by(Motion::of_move(delta));
                Picked::Open
            }
            (false, Action::HalfPage(delta)) => {
                self.scroll_by(Motion::HalfPage(delta));
                Picked::Open
            }
            (false, Action::Search) => {
                self.typing = true;
                Picked::Open
            }
            (true, Action::Accept) => {
                self.typing = false;
                Picked::Open
            }
            (true, Action::Leave) => {
                self.typing = false;
                self.filter.clear();
                self.refiltered()
            }
            (true, _) => Picked::Open,
            (false, _) => Picked::Cancelled,
        }
    }

    fn on_other_key(&mut self, key: KeyEvent) -> Self::Outcome {
        if !self.typing {
            return Picked::Cancelled;
        }
        let plain = !key
            .modifiers
            .intersects(KeyModifiers::CONTROL | KeyModifiers::ALT);
        match key.code {
            KeyCode::Char(c) if plain => {
                self.filter.push(c);
                self.refiltered()
            }
            KeyCode::Backspace => {
                self.filter.pop();
                self.refiltered()
            }
            _ => Picked::Open,
        }
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
        let (rect, lines, _) = self.layout(area, theme);
        frame.render_widget(Clear, rect);
        let title = self.title();
        let block = themed_box(theme, &title);
        scroll::render(frame, rect, block, &lines, self.scroll, theme.accent);
    }
}

/// The widest a help box gets.
const HELP_WIDTH: u16 = 100;

/// The rows of `sections` whose label, help text or section title holds
/// every word of `filter` (any case), each under its section; the sections
/// left without a row dropped.
fn filtered(sections: Vec<Section>, filter: &str) -> Vec<Section> {
    let words: Vec<String> = filter.split_whitespace().map(str::to_lowercase).collect();
    let found = |title: &str, b: &Binding| {
        let text = format!("{title} {} {}", b.label(), b.help).to_lowercase();
        words.iter().all(|w| text.contains(w.as_str()))
    };
    sections
        .into_iter()
        .map(|s| Section {
            rows: s
                .rows
                .into_iter()
                .filter(|b| found(s.context.title(), b))
                .collect(),
            ..s
        })
        .filter(|s| !s.rows.is_empty())
        .collect()
}

/// The lines of a help `width` columns wide showing `sections`: each
/// section's title, then a line a row, its keys indented in a column as
/// wide as the widest label (at most a third of the width), two blanks at
/// least, then what it does wrapped under itself; a label wider than the
/// column takes a line of its own, so a label never runs into its text.
/// A blank line between sections. Every help (the workbench's and the
/// annotation screen's) lays its keys out by this.
pub fn key_lines(sections: &[Section], width: usize, theme: &Theme) -> Vec<Line<'static>> {
    const INDENT: &str = "  ";
    let keys_width = sections
        .iter()
        .flat_map(|s| &s.rows)
        .map(|b| b.label().width())
        .max()
        .unwrap_or(0)
        .min(width / 3)
        + 2;
    let mut lines = Vec::new();
    for (n, section) in sections.iter().enumerate() {
        if n > 0 {
            lines.push(Line::default());
        }
        lines.extend(wrap_hanging(
            &[],
            &[Span::styled(section.context.title(), theme.title)],
            width,
        ));
        for row in &section.rows {
            let keys = row.label();
            let prefix = if keys.width() + 2 > keys_width {
                lines.push(Line::from(vec![
                    Span::raw(INDENT),
                    Span::styled(keys, theme.accent),
                ]));
                vec![Span::raw(" ".repeat(INDENT.len() + keys_width))]
            } else {
                let pad = " ".repeat(keys_width - keys.width());
                vec![
                    Span::raw(INDENT),
                    Span::styled(format!("{keys}{pad}"), theme.accent),
                ]
            };
            lines.extend(wrap_hanging(
                &prefix,
                &[Span::styled(row.help, theme.base)],
                width,
            ));
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    fn workbench() -> Vec<Section> {
        keymap::help_sections(&keymap::workbench_contexts())
    }

    #[test]
    fn a_label_never_runs_into_its_text() {
        let sections = workbench();
        for width in [24, 40, 78, 98] {
            let lines: Vec<String> = key_lines(&sections, width, &Theme::no_color())
                .iter()
                .map(|l| l.spans.iter().map(|s| s.content.as_ref()).collect())
                .collect();
            for row in sections.iter().flat_map(|s| &s.rows) {
                let (label, first) = (row.label(), row.help.split(' ').next().unwrap_or(""));
                // The label, then two blanks at least and the text; or the
                // label alone and the text on the next line.
                let shown = lines.iter().enumerate().any(|(i, line)| {
                    let Some(rest) = line.strip_prefix("  ").and_then(|r| r.strip_prefix(&label))
                    else {
                        return false;
                    };
                    if rest.is_empty() {
                        lines
                            .get(i + 1)
                            .is_some_and(|next| next.trim_start().starts_with(first))
                    } else {
                        rest.starts_with("  ") && rest.trim_start().starts_with(first)
                    }
                });
                assert!(
                    shown,
                    "{label} and {first} at {width}:\n{}",
                    lines.join("\n")
                );
            }
        }
    }

    #[test]
    fn the_filter_keeps_the_rows_found_with_every_word_under_their_section() {
        let contexts = |filter| -> Vec<Context> {
            filtered(workbench(), filter)
                .iter()
                .map(|s| s.context)
                .collect()
        };
        // "diff": the history's row, the diff's section by its title, the
        // pane key that opens the history.
        assert_eq!(
            contexts("diff"),
            [Context::Panes, Context::History, Context::RunDiff]
        );
        let zoom = filtered(workbench(), "ZOOM in");
        assert_eq!(zoom.len(), 1);
        assert_eq!(zoom[0].rows.len(), 1);
        assert_eq!(zoom[0].rows[0].action, Action::GraphZoom(1));
        assert!(contexts("no such words").is_empty());
        assert_eq!(contexts("").len(), workbench().len());
    }

    #[test]
    fn slash_filters_typed_keys_and_esc_drops_the_filter() {
        let mut help = Help::new(Rect::new(0, 0, 80, 24));
        let (_, whole, _) = help.layout(help.area, &Theme::no_color());
        assert_eq!(help.on_action(Action::Search), Picked::Open);
        assert_eq!(help.contexts(), [Context::HelpFilter]);
        for c in "zom".chars() {
            let key = KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE);
            assert_eq!(help.on_other_key(key), Picked::Open);
        }
        let backspace = KeyEvent::new(KeyCode::Backspace, KeyModifiers::NONE);
        help.on_other_key(backspace);
        let (_, some, _) = help.layout(help.area, &Theme::no_color());
        assert!(some.len() < whole.len());
        assert!(help.title().contains("zo▏"), "{}", help.title());
        assert_eq!(help.on_action(Action::Accept), Picked::Open);
        assert_eq!(help.contexts(), [Context::Help]);
        assert!(help.title().contains("\"zo\""), "{}", help.title());
        // Out of the filter, a key the help does not bind closes it.
        let x = KeyEvent::new(KeyCode::Char('x'), KeyModifiers::NONE);
        assert_eq!(help.clone().on_other_key(x), Picked::Cancelled);
        help.on_action(Action::Search);
        assert_eq!(help.on_action(Action::Leave), Picked::Open);
        let (_, again, _) = help.layout(help.area, &Theme::no_color());
        assert_eq!(again.len(), whole.len());
    }
}
