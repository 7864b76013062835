//! Modal views drawn over the panes: help, pickers, forms, the run history,
//! the comparison of two runs and the framed actions.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Sparkline, Wrap};
use ratatui::Frame;

use crate::session::RunRecord;
use crate::tui::app::{App, Overlay};
use crate::tui::component::Component;
use crate::tui::help::Help;
use crate::tui::scoring::Pg2sOutcome;
use crate::tui::theme::Theme;

/// A `width`×`height` box in the middle of `area` (smaller when it must be).
pub(crate) fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let w = width.min(area.width.saturating_sub(2));
    let h = height.min(area.height.saturating_sub(2));
    Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    )
}

fn frame_box<'a>(app: &App, title: &'a str) -> Block<'a> {
    themed_box(&app.theme, title)
}

/// The frame of an overlay, titled `title`, in `theme`'s colours.
pub(crate) fn themed_box<'a>(theme: &Theme, title: &'a str) -> Block<'a> {
    Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus)
        .style(theme.base)
        .title(Span::styled(format!(" {title} "), theme.title))
}

/// Clears a centred `width`×`height` box, draws its frame titled `title`,
/// and returns the area inside the frame.
fn open_box(frame: &mut Frame, app: &App, area: Rect, size: (u16, u16), title: &str) -> Rect {
    let rect = centred(area, size.0, size.1);
    frame.render_widget(Clear, rect);
    let block = frame_box(app, title);
    let inner = block.inner(rect);
    frame.render_widget(block, rect);
    inner
}

/// Draws the open overlay, if any.
pub(super) fn render_overlay(frame: &mut Frame, app: &App, area: Rect) {
    let Some(overlay) = &app.overlay else { return };
    let t = &app.theme;
    match overlay {
        Overlay::Help => Help.draw(frame, area, t),
        Overlay::GroundTruthPicker { selected } => {
            let choices = app.ground_truth_choices();
            let rect = centred(area, 90, choices.len() as u16 + 2);
            let inner_height = rect.height.saturating_sub(2) as usize;
            let (first, count) = super::list_window(*selected, choices.len(), 1, inner_height);
            let lines: Vec<Line> = choices
                .iter()
                .enumerate()
                .skip(first)
                .take(count)
                .map(|(i, (_, label))| {
                    let style = if i == *selected { t.selection } else { t.base };
                    Line::from(Span::styled(label.clone(), style))
                })
                .collect();
            frame.render_widget(Clear, rect);
            frame.render_widget(
                Paragraph::new(lines).block(frame_box(app, "Ground truth (Enter chooses)")),
                rect,
            );
        }
        Overlay::StepFilePath(editor) => {
            let inner = open_box(
                frame,
                app,
                area,
                (80, 3),
                "Step file path (Enter loads, Esc cancels)",
            );
            frame.render_widget(editor.as_ref(), inner);
        }
        Overlay::ModelForm {
            agent,
            fields,
            field,
        } => {
            let rect = centred(area, 70, 7);
            frame.render_widget(Clear, rect);
            let title = format!("{agent}: provider and model (Tab next, Enter saves)");
            let block = frame_box(app, "").title(Span::styled(title, t.title));
            let inner = block.inner(rect);
            frame.render_widget(block, rect);
            let labels = ["provider", "model", "temperature", "max tokens"];
            let rows = Layout::vertical([Constraint::Length(1); 4]).split(inner);
            for (i, (label, editor)) in labels.iter().zip(fields).enumerate() {
                let [l, r] =
                    Layout::horizontal([Constraint::Length(14), Constraint::Min(1)]).areas(rows[i]);
                let style = if i == *field { t.accent } else { t.muted };
                frame.render_widget(Paragraph::new(Span::styled(*label, style)), l);
                frame.render_widget(editor, r);
            }
        }
        Overlay::Runs { selected, marked } => runs(frame, app, area, *selected, *marked),
        Overlay::Compare { left, right } => compare(frame, app, area, *left, *right),
        Overlay::Actions => actions(frame, app, area),
    }
}

fn fmt_score(v: Option<f64>) -> String {
    v.map_or("–".to_string(), |v| format!("{v:.3}"))
}

fn runs(frame: &mut Frame, app: &App, area: Rect, selected: usize, marked: Option<usize>) {
    let t = &app.theme;
    let inner = open_box(
        frame,
        app,
        area,
        (100, 24),
        "Runs (space marks, c compares, Enter loads the plan)",
    );
    if app.runs.is_empty() {
        frame.render_widget(Paragraph::new(Span::styled("No runs yet.", t.muted)), inner);
        return;
    }
    let [spark, table] = Layout::vertical([Constraint::Length(3), Constraint::Min(1)]).areas(inner);
    let data: Vec<u64> = app
        .runs
        .iter()
        .map(|r| {
            r.scores
                .and_then(|s| s.pg2s.or(s.kas))
                .map_or(0, |v| (v * 100.0).round() as u64)
        })
        .collect();
    frame.render_widget(
        Sparkline::default().data(&data).max(100).style(t.accent),
        spark,
    );
    let mut lines = vec![Line::from(Span::styled(
        "   run  approach       PG2S   S_plan S_goal KAS     ms      tokens  steps",
        t.muted,
    ))];
    let (first, count) = super::list_window(selected, app.runs.len(), 1, table.height as usize - 1);
    for (i, r) in app.runs.iter().enumerate().skip(first).take(count) {
        let s = r.scores.unwrap_or_default();
        let mark = if marked == Some(i) { "●" } else { " " };
        let (ms, tokens) = (r.total_ms(), r.total_tokens());
        let style = if i == selected { t.selection } else { t.base };
        lines.push(Line::from(Span::styled(
            format!(
                "{mark}  #{:<3} {:<14} {:<6} {:<6} {:<6} {:<6} {:>6} {:>8} {:>6}{}",
                r.id,
                r.approach.name(),
                fmt_score(s.pg2s),
                fmt_score(s.s_plan),
                fmt_score(s.s_goal),
                fmt_score(s.kas),
                ms,
                tokens,
                r.plan.len(),
                if r.cancelled { " cancelled" } else { "" }
            ),
            style,
        )));
    }
    frame.render_widget(Paragraph::new(lines), table);
}

fn run_lines<'a>(app: &App, run: &'a RunRecord, other: &RunRecord) -> Vec<Line<'a>> {
    let t = &app.theme;
    let s = run.scores.unwrap_or_default();
    let mut lines = vec![
        Line::from(Span::styled(
            format!("run #{} · {}", run.id, run.approach.name()),
            t.title,
        )),
        Line::from(Span::styled(
            format!(
                "PG2S {} · S_plan {} · S_goal {} · KAS {}",
                fmt_score(s.pg2s),
                fmt_score(s.s_plan),
                fmt_score(s.s_goal),
                fmt_score(s.kas)
            ),
            t.accent,
        )),
    ];
    for a in &run.agents {
        let same_prompt = other
            .agents
            .iter()
            .any(|b| b.agent == a.agent && b.prompt == a.prompt);
        lines.push(Line::from(vec![
            Span::styled(format!("{} ", a.agent), t.accent),
            Span::styled(
                format!(
                    "{}/{} t={} · {} ms · {}+{} tok",
                    a.settings.provider,
                    a.settings.model,
                    a.settings.temperature,
                    a.duration_ms,
                    a.usage.input,
                    a.usage.output
                ),
                t.muted,
            ),
            Span::styled(
                if same_prompt {
                    ""
                } else {
                    " · prompt differs"
                },
                t.warn,
            ),
        ]));
    }
    lines.push(Line::from(Span::styled("plan:", t.muted)));
    for (i, step) in run.plan.iter().enumerate() {
        let differs = other.plan.get(i) != Some(step);
        lines.push(Line::from(Span::styled(
            format!("{:>2}. {step}", i + 1),
            if differs { t.warn } else { t.base },
        )));
    }
    lines
}

fn compare(frame: &mut Frame, app: &App, area: Rect, left: usize, right: usize) {
    let inner = open_box(
        frame,
        app,
        area,
        (area.width, area.height),
        "Compare runs (Esc closes; differences highlighted)",
    );
    let (Some(a), Some(b)) = (app.runs.get(left), app.runs.get(right)) else {
        return;
    };
    let [l, r] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(inner);
    frame.render_widget(
        Paragraph::new(run_lines(app, a, b)).wrap(Wrap { trim: false }),
        l,
    );
    frame.render_widget(
        Paragraph::new(run_lines(app, b, a)).wrap(Wrap { trim: false }),
        r,
    );
}

fn actions(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let inner = open_box(
        frame,
        app,
        area,
        (110, 30),
        "Framed actions and their matches (Esc closes)",
    );
    let mut lines = Vec::new();
    match app.scores.as_ref().map(|s| &s.pg2s) {
        Some(Pg2sOutcome::Ready(report)) => match &report.goal {
            Ok(goal) => {
                lines.push(Line::from(Span::styled(
                    format!(
                        "S_goal {:.3}: ground-truth action → plan action (score)",
                        goal.s_goal
                    ),
                    t.accent,
                )));
                for m in &goal.action_matches {
                    let Some(gt) = goal.gt_actions.get(m.gt) else {
                        continue;
                    };
                    let left = format!("GT {} [{}]", gt.step + 1, gt.words.join(" "));
                    let line = match (m.pred.and_then(|p| goal.pred_actions.get(p)), m.score) {
                        (Some(p), Some(score)) => Line::from(vec![
                            Span::styled(format!("✓ {left:<40} → "), t.good),
                            Span::styled(
                                format!("plan {} [{}] ({score:.3})", p.step + 1, p.words.join(" ")),
                                t.base,
                            ),
                        ]),
                        _ => Line::from(Span::styled(
                            format!("✗ {left:<40}   no plan action matched"),
                            t.bad,
                        )),
                    };
                    lines.push(line);
                }
                let unused: Vec<String> = goal
                    .pred_actions
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| !goal.action_matches.iter().any(|m| m.pred == Some(*j)))
                    .map(|(_, a)| format!("plan {} [{}]", a.step + 1, a.words.join(" ")))
                    .collect();
                if !unused.is_empty() {
                    lines.push(Line::from(Span::styled(
                        format!("plan actions matched to nothing: {}", unused.join(", ")),
                        t.muted,
                    )));
                }
            }
            Err(reason) => lines.push(Line::from(Span::styled(
                format!("no framed actions: {reason}"),
                t.warn,
            ))),
        },
        Some(Pg2sOutcome::Waiting(reason)) => lines.push(Line::from(Span::styled(
            format!("framed actions need the PG2S models: {reason}"),
            t.warn,
        ))),
        Some(Pg2sOutcome::Failed(e)) => {
            lines.push(Line::from(Span::styled(format!("PG2S failed: {e}"), t.bad)))
        }
        None => lines.push(Line::from(Span::styled("scoring…", t.muted))),
    }
    if let Some(s) = &app.scores {
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(
            "KAS key actions, by step:",
            t.accent,
        )));
        for (i, g) in s.kas.chunks.gt.iter().enumerate() {
            let p = s
                .kas
                .chunks
                .pred
                .get(i)
                .map(|p| p.join(" "))
                .unwrap_or_default();
            lines.push(Line::from(Span::styled(
                format!("{:>2}. GT [{}] · plan [{}]", i + 1, g.join(" "), p),
                t.base,
            )));
        }
    }
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: false }), inner);
}
