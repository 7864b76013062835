//! Drawing the annotation screen: a pure function of [`Judging`] and the
//! theme. Nothing drawn names an item's id or source, a metric, or how a
//! plan was made: items are named by their position only.
//!
//! Every list (the plan, both sides of a pair, the reference plan) and the
//! help wrap by words with a hanging indent and scroll by wrapped lines
//! through [`crate::workbench::scroll`], with `↑ N more` / `↓ N more` on
//! the frame when lines are out of sight. The update lays the screen out
//! with the same functions ([`lists`], [`help_view`]), so the steps it
//! keeps in view are the steps drawn.

use std::collections::BTreeMap;

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Gauge, Paragraph, Wrap};
use ratatui::Frame;
use unicode_width::UnicodeWidthStr;

use super::state::{Focus, Judging, Mode, Scene, Severity};
use crate::annotate::order::Unit;
use crate::annotate::{Preference, StepLabelKind};
use crate::sanitize::for_terminal;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::overlays::help::key_lines;
use crate::workbench::scene_image;
use crate::workbench::scroll::{self, wrap_hanging, Scroll, Wrapped};
use crate::workbench::theme::Theme;

/// Narrower than this, the image is left out and panes stack.
const WIDE: u16 = 90;

/// The smallest window judging is offered in (columns, rows); below it the
/// screen says so, and no rating, preference or label can be given.
pub const MIN_SIZE: (u16, u16) = (40, 16);

/// What the help of the pairwise screen says to judge by (the guidelines'
/// introduction is about rating one plan and labelling its steps).
const PAIRWISE_INTRO: &str = "Judge which of the two plans would better achieve the task if a robot carried it out, step by step, in the scene shown. Choose neither when they are about as good, or as bad, as each other.";

/// Where the parts of the screen go.
struct Areas {
    task: Rect,
    image: Option<Rect>,
    plans: Rect,
    reference: Option<Rect>,
    scale: Rect,
    /// The scale is drawn in full (else one short line).
    full_scale: bool,
    note: Rect,
    progress: Rect,
    hints: Rect,
}

/// The text width inside a frame `width` columns wide.
fn inner_width(width: u16) -> usize {
    usize::from(width.saturating_sub(2)).max(1)
}

fn areas(area: Rect, screen: &Judging) -> Areas {
    let theme = Theme::no_color();
    let width = inner_width(area.width);
    let task_lines = task_lines(screen, width, &theme).len().clamp(1, 2);
    let task_height = 2 + if area.height >= 24 { task_lines } else { 1 };
    let hints_height = if area.height >= 22 {
        hint_lines(screen, usize::from(area.width)).len()
    } else {
        1
    };
    let fixed = task_height + 2 + hints_height;
    let full = scale_lines(screen, width, &theme, true).len() + 2;
    let short = scale_lines(screen, width, &theme, false).len() + 2;
    let wanted_middle = if screen.show_gt { 10 } else { 6 };
    let full_scale = usize::from(area.height) >= fixed + full + wanted_middle;
    let scale_height = if full_scale { full } else { short };
    let length = |n: usize| Constraint::Length(u16::try_from(n).unwrap_or(u16::MAX));
    let [task, middle, scale, note, progress, hints] = Layout::vertical([
        length(task_height),
        Constraint::Min(4),
        length(scale_height),
        Constraint::Length(1),
        Constraint::Length(1),
        length(hints_height),
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
        full_scale,
        note,
        progress,
        hints,
    }
}

/// Whether the window is large enough to judge in: at least [`MIN_SIZE`],
/// with room for two lines of the plan (and one of the reference).
pub fn fits(area: Rect, screen: &Judging) -> bool {
    if area.width < MIN_SIZE.0 || area.height < MIN_SIZE.1 {
        return false;
    }
    let a = areas(area, screen);
    let inside = |r: Rect| Block::bordered().inner(r).height;
    inside(a.plans) >= 2 && a.reference.is_none_or(|r| inside(r) >= 1)
}

/// The area the scene image is drawn in (inside its frame), if it is shown:
/// the runtime encodes the image for exactly this area.
pub fn image_area(area: Rect, screen: &Judging) -> Option<Rect> {
    if !fits(area, screen) {
        return None;
    }
    areas(area, screen)
        .image
        .map(|r| Block::bordered().inner(r))
}

/// The key that moves between the plan and the reference plan, as the
/// titles name it.
fn reference_key() -> String {
    keymap::key_of(Context::AnnotateReference, Action::NextPane)
}

fn framed<'a>(theme: &Theme, title: String) -> Block<'a> {
    Block::default()
        .borders(Borders::ALL)
        .border_style(theme.border)
        .style(theme.base)
        .title(Span::styled(format!(" {title} "), theme.title))
}

/// One list of the screen as laid out: its frame, its steps wrapped for
/// the frame's width, and how many lines it shows.
pub(super) struct List {
    /// Where the list's frame goes.
    pub rect: Rect,
    /// The steps, wrapped.
    pub wrapped: Wrapped,
    /// The lines shown at once.
    pub viewport: usize,
}

/// The lists of the screen in a window of `area`.
pub(super) struct Lists {
    /// The plan rated (single items).
    pub plan: Option<List>,
    /// The two plans of a pair.
    pub sides: Option<[List; 2]>,
    /// The reference plan (`--show-gt`).
    pub reference: Option<List>,
}

/// The steps of a plan as a list: `▸ N. text  [label]`, the marker on
/// `selected`, wrapped under the text.
fn step_list(
    steps: &[String],
    selected: Option<usize>,
    labels: &BTreeMap<usize, StepLabelKind>,
    width: usize,
    theme: &Theme,
) -> Wrapped {
    let number_width = steps.len().to_string().len();
    Wrapped::new(steps.iter().enumerate().map(|(n, step)| {
        let here = selected == Some(n);
        let base = if here { theme.selection } else { theme.base };
        let prefix = [
            Span::styled(if here { "▸ " } else { "  " }, theme.accent),
            Span::styled(format!("{:>number_width$}. ", n + 1), base),
        ];
        let mut body = vec![Span::styled(for_terminal(step), base)];
        if let Some(label) = labels.get(&n) {
            let style = if *label == StepLabelKind::Ok {
                theme.good
            } else {
                theme.bad
            };
            body.push(Span::styled(format!("  [{}]", label.as_str()), style));
        }
        wrap_hanging(&prefix, &body, width)
    }))
}

/// The list of `steps` in the frame `rect`.
fn list_in(
    rect: Rect,
    steps: &[String],
    selected: Option<usize>,
    labels: &BTreeMap<usize, StepLabelKind>,
    theme: &Theme,
) -> List {
    let inner = Block::bordered().inner(rect);
    List {
        rect,
        wrapped: step_list(steps, selected, labels, usize::from(inner.width), theme),
        viewport: usize::from(inner.height),
    }
}

/// The step of a pair's side that the shared selection `step` stands on.
pub(super) fn side_step(step: usize, len: usize) -> usize {
    step.min(len.saturating_sub(1))
}

/// The lists of the screen in a window of `area`, wrapped in `theme`.
pub(super) fn lists(screen: &Judging, area: Rect, theme: &Theme) -> Lists {
    let a = areas(area, screen);
    let none = BTreeMap::new();
    let mut out = Lists {
        plan: None,
        sides: None,
        reference: None,
    };
    match screen.units.get(screen.pos) {
        Some(Unit::Pair(l, r)) => {
            let [left, right] =
                Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
                    .areas(a.plans);
            let side = |rect, i: usize| {
                let steps = &screen.items[i].pred;
                let at = side_step(screen.step, steps.len());
                list_in(rect, steps, Some(at), &none, theme)
            };
            out.sides = Some([side(left, *l), side(right, *r)]);
        }
        _ => {
            let selected = (screen.focus == Focus::Plan).then_some(screen.step);
            out.plan = Some(list_in(
                a.plans,
                screen.plan(),
                selected,
                &screen.draft.labels,
                theme,
            ));
        }
    }
    if let (Some(rect), Some(item)) = (a.reference, screen.shown_item()) {
        let selected = (screen.focus == Focus::Reference).then_some(screen.reference_step);
        out.reference = Some(list_in(rect, &item.gt, selected, &none, theme));
    }
    out
}

/// Draws the screen in `area`.
pub fn draw(frame: &mut Frame, area: Rect, screen: &Judging, theme: &Theme) {
    frame.render_widget(Block::default().style(theme.base), area);
    if !fits(area, screen) {
        let (w, h) = MIN_SIZE;
        frame.render_widget(
            Paragraph::new(format!(
                "This window is too small to judge in ({} × {}): make it at least {w} × {h}, so that every step can be read.",
                area.width, area.height
            ))
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
        for_terminal(&screen.annotator)
    );
    let task = task_lines(screen, inner_width(a.task.width), theme);
    scroll::render(
        frame,
        a.task,
        framed(theme, title),
        &task,
        Scroll::default(),
        theme.accent,
    );
    if let Some(rect) = a.image {
        draw_image(frame, screen, theme, rect);
    }
    let lists = lists(screen, area, theme);
    if let Some(plan) = &lists.plan {
        let title = if screen.focus == Focus::Plan {
            format!(
                "Plan ({}{} select a step, then label it)",
                keymap::key_of(Context::AnnotateRating, Action::Move(-1)),
                keymap::key_of(Context::AnnotateRating, Action::Move(1))
            )
        } else {
            format!("Plan ({}: back here)", reference_key())
        };
        let style = if screen.focus == Focus::Plan && screen.show_gt {
            theme.focus
        } else {
            theme.border
        };
        let block = framed(theme, title).border_style(style);
        draw_list(frame, plan, block, screen.scrolls.plan, screen.step, theme);
    }
    if let (Some(sides), Some(Unit::Pair(l, r))) = (&lists.sides, screen.units.get(screen.pos)) {
        let chosen = screen.verdict().and_then(|v| v.preference);
        for (list, name, i, pref, kept) in [
            (
                &sides[0],
                "Left plan",
                *l,
                Preference::Left,
                screen.scrolls.left,
            ),
            (
                &sides[1],
                "Right plan",
                *r,
                Preference::Right,
                screen.scrolls.right,
            ),
        ] {
            let style = if chosen == Some(pref) {
                theme.focus
            } else {
                theme.border
            };
            let at = side_step(screen.step, screen.items[i].pred.len());
            let block = framed(theme, name.into()).border_style(style);
            draw_list(frame, list, block, kept, at, theme);
        }
    }
    if let Some(reference) = &lists.reference {
        let (title, style) = if screen.focus == Focus::Reference {
            (
                format!("Reference plan ({}: back to the plan)", reference_key()),
                theme.focus,
            )
        } else {
            (
                format!("Reference plan ({}: move in it)", reference_key()),
                theme.border,
            )
        };
        let block = framed(theme, title).border_style(style);
        let kept = screen.scrolls.reference;
        draw_list(frame, reference, block, kept, screen.reference_step, theme);
    }
    draw_scale(frame, screen, theme, a.scale, a.full_scale);
    draw_note(frame, screen, theme, a.note);
    draw_progress(frame, screen, theme, a.progress);
    draw_hints(frame, screen, theme, a.hints);
    if matches!(screen.mode, Mode::Help) {
        draw_help(frame, screen, theme, area);
    }
}

/// Draws `list` in `block`, scrolled from `kept` just enough to show step
/// `selected`.
fn draw_list(
    frame: &mut Frame,
    list: &List,
    block: Block<'_>,
    kept: Scroll,
    selected: usize,
    theme: &Theme,
) {
    let scroll = kept.following(&list.wrapped, selected, list.viewport);
    let lines = list.wrapped.lines();
    scroll::render(frame, list.rect, block, lines, scroll, theme.accent);
}

/// The task, wrapped for `width`.
fn task_lines(screen: &Judging, width: usize, theme: &Theme) -> Vec<Line<'static>> {
    let task = screen
        .shown_item()
        .and_then(|i| i.task.as_deref())
        .map_or_else(|| "(no task given)".to_string(), for_terminal);
    wrap_hanging(&[], &[Span::styled(task, theme.base)], width)
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

/// The short name of a rating: its wording up to the first `:` (or its
/// first word).
fn short_name(wording: &str) -> &str {
    let head = wording.split(':').next().unwrap_or(wording).trim();
    if head.is_empty() || head.chars().count() > 16 {
        wording.split_whitespace().next().unwrap_or("")
    } else {
        head
    }
}

/// The rating scale (or the pairwise choices) wrapped for `width`: every
/// rating's whole wording when `full`, else one short name each.
fn scale_lines(screen: &Judging, width: usize, theme: &Theme, full: bool) -> Vec<Line<'static>> {
    let v = screen.verdict();
    if screen.pairwise {
        let chosen = v.and_then(|v| v.preference);
        let entries: Vec<Vec<Span>> = [
            ("1", "left is better", Preference::Left),
            ("2", "right is better", Preference::Right),
            ("0", "neither", Preference::Neither),
        ]
        .into_iter()
        .map(|(key, what, p)| {
            let style = if chosen == Some(p) {
                theme.selection
            } else {
                theme.base
            };
            vec![
                Span::styled(format!(" {key} "), theme.accent),
                Span::styled(what, style),
            ]
        })
        .collect();
        return scroll::pack(&entries, &Span::raw("  "), width);
    }
    let rated = v.and_then(|v| v.rating);
    let style_of = |r: u8| {
        if rated == Some(r) {
            theme.selection
        } else {
            theme.base
        }
    };
    let scale = screen.guidelines.scale.iter().zip(1u8..);
    if full {
        scale
            .flat_map(|(wording, r)| {
                wrap_hanging(
                    &[Span::styled(format!(" {r} "), theme.accent)],
                    &[Span::styled(for_terminal(wording), style_of(r))],
                    width,
                )
            })
            .collect()
    } else {
        let entries: Vec<Vec<Span>> = scale
            .map(|(wording, r)| {
                vec![
                    Span::styled(format!(" {r} "), theme.accent),
                    Span::styled(for_terminal(short_name(wording)), style_of(r)),
                ]
            })
            .collect();
        scroll::pack(&entries, &Span::raw(" "), width)
    }
}

/// The current judgement of the unit on screen, in words, for the scale's
/// title: `yours: 3 (Fair)`, `yours: left`, or nothing.
fn current_in_words(screen: &Judging) -> Option<String> {
    let v = screen.verdict()?;
    if let Some(r) = v.rating {
        let wording = screen
            .guidelines
            .scale
            .get(usize::from(r.saturating_sub(1)))
            .map_or("", |w| short_name(w));
        return Some(format!("yours: {r} ({})", for_terminal(wording)));
    }
    v.preference.map(|p| format!("yours: {}", p.as_str()))
}

fn draw_scale(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect, full: bool) {
    let lines = scale_lines(screen, inner_width(rect.width), theme, full);
    let mut title = if screen.pairwise {
        "Which plan is better?".to_string()
    } else if full {
        "Rating".to_string()
    } else {
        "Rating (? shows the whole scale)".to_string()
    };
    if let Some(words) = current_in_words(screen) {
        title = format!("{title} · {words}");
    }
    scroll::render(
        frame,
        rect,
        framed(theme, title),
        &lines,
        Scroll::default(),
        theme.accent,
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
                Span::styled(for_terminal(&screen.draft.note), theme.base)
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

/// The key hints of the screen as it is now, in table order.
fn hints(screen: &Judging) -> Vec<String> {
    let contexts: Vec<Context> = screen
        .contexts()
        .into_iter()
        .filter(|c| *c != Context::Always)
        .collect();
    keymap::hints_of(&contexts)
}

/// The hint lines for `width` columns: one when every hint fits on it,
/// else two, whole hints packed on the first and the rest fitted on the
/// second ([`fitted`]).
fn hint_lines(screen: &Judging, width: usize) -> Vec<String> {
    let all = hints(screen);
    let one = all.join(" · ");
    if one.width() <= width {
        return vec![one];
    }
    let mut first: Vec<String> = Vec::new();
    let mut rest = all.into_iter().peekable();
    while let Some(next) = rest.peek() {
        let mut trial = first.clone();
        trial.push(next.clone());
        if trial.join(" · ").width() > width {
            break;
        }
        first = trial;
        rest.next();
    }
    vec![first.join(" · "), fitted(rest.collect(), width)]
}

fn draw_hints(frame: &mut Frame, screen: &Judging, theme: &Theme, rect: Rect) {
    let lines: Vec<Line> = match &screen.status {
        Some((text, severity)) => {
            let style: Style = match severity {
                Severity::Info => theme.muted,
                Severity::Warn => theme.warn,
                Severity::Error => theme.bad,
            };
            wrap_hanging(
                &[],
                &[Span::styled(for_terminal(text), style)],
                usize::from(rect.width),
            )
        }
        None if rect.height >= 2 => hint_lines(screen, usize::from(rect.width))
            .into_iter()
            .map(|h| Line::from(Span::styled(h, theme.muted)))
            .collect(),
        None => vec![Line::from(Span::styled(
            fitted(hints(screen), usize::from(rect.width)),
            theme.muted,
        ))],
    };
    frame.render_widget(Paragraph::new(lines), rect);
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
        if joined(&keep).width() > width {
            keep[i] = false;
        }
    }
    joined(&keep)
}

/// The contexts whose keys the screen's help lists: its own, for the mode
/// it is in (rating or pairwise), never the workbench's.
fn help_contexts(screen: &Judging) -> Vec<Context> {
    let mut contexts = vec![if screen.pairwise {
        Context::AnnotatePairwise
    } else {
        Context::AnnotateRating
    }];
    if screen.show_gt {
        contexts.push(Context::AnnotateReference);
    }
    contexts.extend([
        Context::Annotate,
        Context::AnnotateNote,
        Context::AnnotateHelp,
        Context::Always,
    ]);
    contexts
}

/// The help's lines for `width` columns: what to judge by (the guidelines'
/// introduction and whole scale, or the pairwise screen's own words), then
/// every key of the screen's mode, its description wrapped under itself.
fn help_lines(screen: &Judging, width: usize, theme: &Theme) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    let paragraph = |text: &str, lines: &mut Vec<Line<'static>>| {
        lines.extend(wrap_hanging(
            &[],
            &[Span::styled(for_terminal(text), theme.base)],
            width,
        ));
    };
    if screen.pairwise {
        paragraph(PAIRWISE_INTRO, &mut lines);
    } else {
        for p in &screen.guidelines.introduction {
            paragraph(p, &mut lines);
        }
        lines.push(Line::default());
        lines.push(Line::from(Span::styled("The scale:", theme.title)));
        for (wording, r) in screen.guidelines.scale.iter().zip(1u8..) {
            lines.extend(wrap_hanging(
                &[Span::styled(format!(" {r} "), theme.accent)],
                &[Span::styled(for_terminal(wording), theme.base)],
                width,
            ));
        }
    }
    lines.push(Line::default());
    lines.push(Line::from(Span::styled("Keys:", theme.title)));
    lines.extend(key_lines(
        &keymap::help_sections(&help_contexts(screen)),
        width,
        theme,
    ));
    lines
}

/// The help as laid out in a window of `area`: its frame, its lines and
/// how many it shows at once.
pub(super) fn help_view(
    screen: &Judging,
    area: Rect,
    theme: &Theme,
) -> (Rect, Vec<Line<'static>>, usize) {
    let width = area.width.min(100);
    let lines = help_lines(screen, inner_width(width), theme);
    let height = u16::try_from(lines.len() + 2)
        .unwrap_or(u16::MAX)
        .min(area.height);
    let rect = Rect::new(
        area.x + (area.width - width) / 2,
        area.y + (area.height - height) / 2,
        width,
        height,
    );
    let viewport = usize::from(height.saturating_sub(2));
    (rect, lines, viewport)
}

/// The screen's help: the guidelines, then every key that works on this
/// screen in its mode, scrolled as the help's scroll says.
fn draw_help(frame: &mut Frame, screen: &Judging, theme: &Theme, area: Rect) {
    let (rect, lines, _) = help_view(screen, area, theme);
    frame.render_widget(Clear, rect);
    let block = framed(
        theme,
        format!("Keys ({})", keymap::hints(Context::AnnotateHelp)),
    )
    .border_style(theme.focus);
    scroll::render(
        frame,
        rect,
        block,
        &lines,
        screen.scrolls.help,
        theme.accent,
    );
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{items, open, press, setup};
    use super::super::state::{Judging, Mode, Msg};
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

    /// Opens the help in a `width` × `height` window and scrolls it to the
    /// end with ↓, gathering every line it showed.
    fn help_read_through(pairwise: bool, width: u16, height: u16) -> String {
        let (mut s, _) = open(setup(pairwise, Annotations::default()));
        s.update(Msg::Resize(width, height));
        press(&mut s, '?');
        let mut seen = String::new();
        for _ in 0..200 {
            let text = drawn(&s, width, height);
            assert_blind(&text);
            seen.push_str(&text);
            press(&mut s, 'j');
        }
        assert!(matches!(s.mode, Mode::Help), "↓ closed the help");
        press(&mut s, 'x');
        assert!(matches!(s.mode, Mode::Judging), "another key closes it");
        seen
    }

    #[test]
    fn the_help_scrolls_to_every_key_of_its_own_mode_and_no_other() {
        for pairwise in [false, true] {
            let seen = help_read_through(pairwise, 80, 24);
            let flat: String = seen
                .split(['│', '\n'])
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(" ");
            let flat = flat.split_whitespace().collect::<Vec<_>>().join(" ");
            let judging = if pairwise {
                Context::AnnotatePairwise
            } else {
                Context::AnnotateRating
            };
            let own = [judging, Context::Annotate, Context::AnnotateHelp];
            for section in keymap::help_sections(&own) {
                assert!(flat.contains(section.context.title()));
                for row in section.rows {
                    let first_words: String = row
                        .help
                        .split_whitespace()
                        .take(3)
                        .collect::<Vec<_>>()
                        .join(" ");
                    // The keys, then what they do.
                    let shown = format!("{} {first_words}", row.label());
                    assert!(
                        flat.contains(&shown),
                        "{shown} never shown (pairwise {pairwise})"
                    );
                }
            }
            let lower = flat.to_lowercase();
            for word in [
                "corrupt", "swap", "pg2s", "kas ", "s_plan", "s_goal", "score",
            ] {
                assert!(!lower.contains(word), "the help says {word}:\n{seen}");
            }
            assert!(
                seen.contains("↓") && seen.contains("more"),
                "no sign of more below"
            );
            if pairwise {
                assert!(
                    !flat.contains("label"),
                    "the pairwise help talks of labels:\n{seen}"
                );
                assert!(flat.contains("neither"));
            } else {
                assert!(flat.contains("wrong object") && flat.contains("moves the selection on"));
                assert!(flat.contains("5 Excellent: correct, complete and in a sensible order."));
            }
        }
    }

    #[test]
    fn a_label_needs_a_window_that_shows_the_step() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        s.update(Msg::Resize(30, 12));
        press(&mut s, 'w');
        assert!(s.draft.labels.is_empty(), "labelled a step no one can see");
        assert!(press(&mut s, '4').is_empty(), "rated in a window too small");
        assert!(drawn(&s, 30, 12).contains("too small"));
        s.update(Msg::Resize(80, 24));
        press(&mut s, 'w');
        assert_eq!(s.draft.labels.len(), 1);
        let text = drawn(&s, 80, 24);
        assert!(text.contains("[wrong object]"), "{text}");
    }

    #[test]
    fn a_long_plan_scrolls_to_the_selection_and_says_what_is_hidden() {
        let mut init = setup(false, Annotations::default());
        for item in &mut init.items {
            item.pred = (1..=12)
                .map(|n| format!("Step {n}: walk to the counter and pick up the object that is there, then look around."))
                .collect();
        }
        let (mut s, _) = open(init);
        s.update(Msg::Resize(60, 20));
        let text = drawn(&s, 60, 20);
        assert!(text.contains("↓") && text.contains("more"), "{text}");
        s.update(Msg::Key(KeyEvent::new(KeyCode::End, KeyModifiers::NONE)));
        assert_eq!(s.step, 11);
        let text = drawn(&s, 60, 20);
        assert!(text.contains("▸ 12. Step 12"), "{text}");
        assert!(text.contains("↑") && text.contains("more"), "{text}");
        insta::assert_snapshot!(text);
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
        assert!(text.contains("cannot be shown"), "{text}");
        assert!(image_area(ratatui::layout::Rect::new(0, 0, 120, 30), &s).is_some());
        press(&mut s, '5');
        assert_eq!(s.judged(), 1);
    }
}
