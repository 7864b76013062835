//! Drawing the annotation screen: a pure function of [`Judging`] and the
//! theme. Nothing drawn names an item's id or source, a metric, or how a
//! plan was made: items are named by their position only.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Gauge, Paragraph, Wrap};
use ratatui::Frame;

use super::state::{Judging, Mode, Scene, Severity};
use crate::annotate::order::Unit;
use crate::annotate::Preference;
use crate::workbench::keymap::{self, Context};
use crate::workbench::overlays::help::draw_keys;
use crate::workbench::scene_image;
use crate::workbench::theme::Theme;

/// Narrower than this, the image is left out and panes stack.
const WIDE: u16 = 90;

/// Where the parts of the screen go.
struct Areas {
    task: Rect,
    image: Option<Rect>,
    plans: Rect,
    reference: Option<Rect>,
    scale: Rect,
    note: Rect,
    progress: Rect,
    hints: Rect,
}

fn areas(area: Rect, screen: &Judging) -> Areas {
    let scale_height = if screen.pairwise { 3 } else { 7 };
    let [task, middle, scale, note, progress, hints] = Layout::vertical([
        Constraint::Length(3),
        Constraint::Min(4),
        Constraint::Length(scale_height),
        Constraint::Length(1),
        Constraint::Length(1),
        Constraint::Length(1),
    ])
    .areas(area);
    let has_image = !matches!(screen.scene, Scene::None);
    let (image, rest) = if has_image && area.width >= WIDE {
        let [image, rest] =
            Layout::horizontal([Constraint::Percentage(35), Constraint::Percentage(65)])
                .areas(middle);
        (Some(image), rest)
    } else {
        (None, middle)
    };
    let (plans, reference) = if screen.show_gt {
        let [plans, reference] =
            Layout::vertical([Constraint::Percentage(60), Constraint::Percentage(40)]).areas(rest);
        (plans, Some(reference))
    } else {
        (rest, None)
    };
    Areas {
        task,
        image,
        plans,
        reference,
        scale,
        note,
        progress,
        hints,
    }
}

/// The area the scene image is drawn in (inside its frame), if it is shown:
/// the runtime encodes the image for exactly this area.
pub fn image_area(area: Rect, screen: &Judging) -> Option<Rect> {
    areas(area, screen)
        .image
        .map(|r| Block::bordered().inner(r))
}

fn framed<'a>(theme: &Theme, title: String) -> Block<'a> {
    Block::default()
        .borders(Borders::ALL)
        .border_style(theme.border)
        .style(theme.base)
        .title(Span::styled(format!(" {title} "), theme.title))
}

/// Draws the screen in `area`.
pub fn draw(frame: &mut Frame, area: Rect, screen: &Judging, theme: &Theme) {
    frame.render_widget(Block::default().style(theme.base), area);
    if area.width < 30 || area.height < 16 {
        frame.render_widget(
            Paragraph::new("Make the terminal larger (at least 30 × 16) to judge.")
                .style(theme.warn)
                .wrap(Wrap { trim: true }),
            area,
        );
        return;
    }
    let a = areas(area, screen);
    let what = if screen.pairwise { "Pair" } else { "Item" };
    let title = format!(
        "{what} {} of {} · judging as {}",
        screen.pos + 1,
        screen.units.len(),
        screen.annotator
    );
    let task = screen
        .shown_item()
        .and_then(|i| i.task.clone())
        .unwrap_or_else(|| "(no task given)".into());
    frame.render_widget(
        Paragraph::new(Span::styled(task, theme.base))
            .wrap(Wrap { trim: true })
            .block(framed(theme, title)),
        a.task,
    );
    if let Some(rect) = a.image {
        draw_image(frame, screen, theme, rect);
    }
    match screen.units.get(screen.pos) {
        Some(Unit::Pair(l, r)) => {
            let [left, right] =
                Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
                    .areas(a.plans);
            let chosen = screen.verdict().and_then(|v| v.preference);
            for (rect, side, i, pref) in [
                (left, "Left plan", *l, Preference::Left),
                (right, "Right plan", *r, Preference::Right),
            ] {
                let style = if chosen == Some(pref) {
                    theme.focus
                } else {
                    theme.border
                };
                let lines = numbered(&screen.items[i].pred, theme);
                frame.render_widget(
                    Paragraph::new(lines)
                        .wrap(Wrap { trim: true })
                        .block(framed(theme, side.to_string()).border_style(style)),
                    rect,
                );
            }
        }
        _ => draw_plan(frame, screen, theme, a.plans),
    }
    if let (Some(rect), Some(item)) = (a.reference, screen.shown_item()) {
        frame.render_widget(
            Paragraph::new(numbered(&item.gt, theme))
                .wrap(Wrap { trim: true })
                .block(framed(theme, "Reference plan".into())),
            rect,
        );
    }
    draw_scale(frame, screen, theme, a.scale);
    draw_note(frame, screen, theme, a.note);
    draw_progress(frame, screen, theme, a.progress);
    draw_hints(frame, screen, theme, a.hints);
    if matches!(screen.mode, Mode::Help) {
        draw_help(frame, screen, theme, area);
    }
}

fn numbered<'a>(steps: &'a [String], theme: &Theme) -> Vec<Line<'a>> {
    steps
        .iter()
        .enumerate()
        .map(|(n, s)| {
            Line::from(vec![
                Span::styled(format!("{}. ", n + 1), theme.muted),
                Span::styled(s.as_str(), theme.base),
            ])
        })
        .collect()
}

fn draw_image(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let block = framed(theme, "Scene".into());
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    let (encoded, note) = match &screen.scene {
        Scene::Loaded(..) => (screen.image.as_ref(), "drawing the image…"),
        Scene::Failed(why) => (None, why.as_str()),
        Scene::None | Scene::Loading(_) => (None, "drawing the image…"),
    };
    let held = matches!(screen.mode, Mode::Help);
    scene_image::draw(frame, inner, encoded, note, theme.warn, held);
}

fn draw_plan(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let block = framed(theme, "Plan (↑↓ select a step, then label it)".into());
    let inner = block.inner(rect);
    let lines: Vec<Line> = screen
        .plan()
        .iter()
        .enumerate()
        .map(|(n, step)| {
            let selected = n == screen.step;
            let base = if selected {
                theme.selection
            } else {
                theme.base
            };
            let mut spans = vec![
                Span::styled(if selected { "▸ " } else { "  " }, theme.accent),
                Span::styled(format!("{}. ", n + 1), base),
                Span::styled(step.as_str(), base),
            ];
            if let Some(label) = screen.draft.labels.get(&n) {
                let style = if label.as_str() == "ok" {
                    theme.good
                } else {
                    theme.bad
                };
                spans.push(Span::styled(format!("  [{}]", label.as_str()), style));
            }
            Line::from(spans)
        })
        .collect();
    let scroll = screen
        .step
        .saturating_sub(usize::from(inner.height.saturating_sub(1)));
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .scroll((u16::try_from(scroll).unwrap_or(u16::MAX), 0))
            .block(block),
        rect,
    );
}

fn draw_scale(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let v = screen.verdict();
    let lines: Vec<Line> = if screen.pairwise {
        let chosen = v.and_then(|v| v.preference);
        let choice = |key: &'static str, what: &'static str, p: Preference| {
            let style = if chosen == Some(p) {
                theme.selection
            } else {
                theme.base
            };
            [
                Span::styled(format!(" {key} "), theme.accent),
                Span::styled(what, style),
                Span::raw("   "),
            ]
        };
        let mut spans = Vec::new();
        spans.extend(choice("1", "left is better", Preference::Left));
        spans.extend(choice("2", "right is better", Preference::Right));
        spans.extend(choice("0", "neither", Preference::Neither));
        vec![Line::from(spans)]
    } else {
        let rated = v.and_then(|v| v.rating);
        screen
            .guidelines
            .scale
            .iter()
            .enumerate()
            .map(|(i, wording)| {
                let r = i as u8 + 1;
                let style = if rated == Some(r) {
                    theme.selection
                } else {
                    theme.base
                };
                Line::from(vec![
                    Span::styled(format!(" {r} "), theme.accent),
                    Span::styled(wording.as_str(), style),
                ])
            })
            .collect()
    };
    let title = if screen.pairwise {
        "Which plan is better?"
    } else {
        "Rating"
    };
    // One line a rating, cut at the edge: every rating stays in view.
    frame.render_widget(
        Paragraph::new(lines).block(framed(theme, title.into())),
        rect,
    );
}

fn draw_note(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let [label, rest] = Layout::horizontal([Constraint::Length(6), Constraint::Min(1)]).areas(rect);
    frame.render_widget(Span::styled("Note: ", theme.accent), label);
    match &screen.mode {
        Mode::Note(editor) => frame.render_widget(editor.as_ref(), rest),
        _ => {
            let text = if screen.draft.note.is_empty() {
                Span::styled("(none; e writes one)", theme.muted)
            } else {
                Span::styled(screen.draft.note.as_str(), theme.base)
            };
            frame.render_widget(text, rest);
        }
    }
}

fn draw_progress(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let total = screen.units.len();
    let judged = screen.judged();
    let mean = screen
        .mean_seconds()
        .map_or_else(String::new, |m| format!(" · {m} s per item"));
    let label = format!(
        "{judged}/{total} judged · {} skipped · {} s on this one{mean}",
        screen.skipped.len(),
        screen.seconds_here()
    );
    let ratio = if total == 0 {
        0.0
    } else {
        judged as f64 / total as f64
    };
    frame.render_widget(
        Gauge::default()
            .ratio(ratio.clamp(0.0, 1.0))
            .label(Span::styled(label, theme.base))
            .gauge_style(theme.good)
            .style(theme.base),
        rect,
    );
}

fn draw_hints(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let line = match &screen.status {
        Some((text, severity)) => {
            let style: Style = match severity {
                Severity::Info => theme.muted,
                Severity::Warn => theme.warn,
                Severity::Error => theme.bad,
            };
            Line::from(Span::styled(text.as_str(), style))
        }
        None => {
            let contexts: Vec<Context> = screen
                .contexts()
                .into_iter()
                .filter(|c| *c != Context::Always)
                .collect();
            let hints = fitted(keymap::hints_of(&contexts), usize::from(rect.width));
            Line::from(Span::styled(hints, theme.muted))
        }
    };
    frame.render_widget(Paragraph::new(line), rect);
}

/// The hints joined by dots, as many as fit in `width` columns: the first
/// (what judges) and the last two (the help and quitting) always, the
/// others in table order while they fit.
fn fitted(hints: Vec<String>, width: usize) -> String {
    const DOT: &str = " · ";
    let n = hints.len();
    let mut keep: Vec<bool> = (0..n).map(|i| i == 0 || i + 2 >= n).collect();
    let joined = |keep: &[bool]| {
        hints
            .iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(h, _)| h.as_str())
            .collect::<Vec<_>>()
            .join(DOT)
    };
    for i in 1..n.saturating_sub(2) {
        keep[i] = true;
        if joined(&keep).chars().count() > width {
            keep[i] = false;
        }
    }
    joined(&keep)
}

/// The screen's help: the guidelines' introduction, then every key that
/// works on this screen, drawn by the workbench's help.
fn draw_help(frame: &mut Frame, screen: &Judging, theme: &Theme, area: Rect) {
    let judging = if screen.pairwise {
        Context::AnnotatePairwise
    } else {
        Context::AnnotateRating
    };
    let contexts = [
        Context::Always,
        judging,
        Context::Annotate,
        Context::AnnotateNote,
    ];
    draw_keys(
        frame,
        area,
        theme,
        &screen.guidelines.introduction,
        keymap::help_lines_of(&contexts),
    );
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{items, open, press, setup};
    use super::super::state::{Judging, Msg};
    use super::*;
    use crate::annotate::Annotations;
    use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    fn drawn(screen: &Judging, width: u16, height: u16) -> String {
        let mut terminal =
            Terminal::new(TestBackend::new(width, height)).unwrap_or_else(|e| panic!("{e}"));
        let theme = Theme::no_color();
        terminal
            .draw(|f| {
                let area = f.area();
                super::draw(f, area, screen, &theme);
            })
            .unwrap_or_else(|e| panic!("{e}"));
        let buffer = terminal.backend().buffer();
        let mut text = String::new();
        for y in 0..buffer.area.height {
            for x in 0..buffer.area.width {
                text.push_str(buffer[(x, y)].symbol());
            }
            text.push('\n');
        }
        text
    }

    /// Nothing on screen may tell how a plan was made or scored.
    fn assert_blind(screen_text: &str) {
        let lower = screen_text.to_lowercase();
        for word in [
            "corrupt",
            "swap",
            "pg2s",
            "kas",
            "s_plan",
            "s_goal",
            "score",
            "multi_agent",
            "~",
            "task0",
            "source",
        ] {
            assert!(!lower.contains(word), "`{word}` on screen:\n{screen_text}");
        }
        for item in items() {
            assert!(!screen_text.contains(&item.id));
        }
    }

    #[test]
    fn rating_view() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        press(&mut s, '4');
        let text = drawn(&s, 100, 30);
        assert_blind(&text);
        insta::assert_snapshot!(text);
    }

    #[test]
    fn step_labels_and_note() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        press(&mut s, 'w');
        press(&mut s, 'm');
        press(&mut s, 'e');
        for c in "hm".chars() {
            press(&mut s, c);
        }
        let text = drawn(&s, 100, 30);
        assert_blind(&text);
        insta::assert_snapshot!(text);
    }

    #[test]
    fn pairwise_with_the_reference() {
        let mut init = setup(true, Annotations::default());
        init.show_gt = true;
        let (mut s, _) = open(init);
        press(&mut s, '2');
        press(&mut s, 'p');
        let text = drawn(&s, 100, 30);
        assert_blind(&text);
        assert!(text.contains("Reference plan"));
        insta::assert_snapshot!(text);
    }

    #[test]
    fn narrow_terminal_with_help() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let text = drawn(&s, 44, 24);
        assert_blind(&text);
        insta::assert_snapshot!(text);
        press(&mut s, '?');
        let help = drawn(&s, 100, 40);
        assert_blind(&help);
        assert!(help.contains("wrong object"));
        insta::assert_snapshot!("help_from_the_key_table", help);
        s.update(Msg::Key(KeyEvent::new(
            KeyCode::Char('3'),
            KeyModifiers::NONE,
        )));
        assert_eq!(
            s.judged(),
            0,
            "the key that closes the help does nothing else"
        );
        assert_blind(&drawn(&s, 20, 8));
    }

    #[test]
    fn a_missing_image_is_one_line_and_judging_goes_on() {
        let mut init = setup(false, Annotations::default());
        for item in &mut init.items {
            item.image = Some("images/gone.png".into());
        }
        let (mut s, cmds) = open(init);
        assert_eq!(
            cmds,
            vec![super::super::state::Cmd::LoadImage(
                "/nowhere/images/gone.png".into()
            )]
        );
        let gone = std::path::Path::new("/nowhere/images/gone.png");
        s.update(Msg::Image(
            gone.to_path_buf(),
            Err(crate::workbench::scene_image::read(gone).unwrap_err()),
        ));
        let text = drawn(&s, 120, 30);
        assert!(text.contains("cannot be read"), "{text}");
        assert!(image_area(ratatui::layout::Rect::new(0, 0, 120, 30), &s).is_some());
        press(&mut s, '5');
        assert_eq!(s.judged(), 1);
    }
}
