//! The seven panes.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span, Text};
use ratatui::widgets::{Paragraph, Sparkline, Wrap};
use ratatui::Frame;
use ratatui_image::Image;

use super::{highlighted, list_window, pane_block, scene_image_area};
use crate::agents::AgentRole;
use crate::metrics::pg2s::Pg2sReport;
use crate::session::PlanSource;
use crate::tui::agents::{planning_role, role_label, roles};
use crate::tui::app::{AgentStatus, App, Editing, Pane, StepList};
use crate::tui::scoring::{Pg2sOutcome, ScoreOutcome};
use crate::tui::theme::Theme;

/// Draws one pane.
pub(super) fn render_pane(frame: &mut Frame, app: &App, pane: Pane, area: Rect) {
    match pane {
        Pane::Scene => scene(frame, app, area),
        Pane::Graph => super::graph::render(frame, app, area),
        Pane::Description => description(frame, app, area),
        Pane::Plan => steps(frame, app, StepList::Plan, area),
        Pane::GroundTruth => steps(frame, app, StepList::GroundTruth, area),
        Pane::Scores => scores(frame, app, area),
        Pane::Prompt => prompt(frame, app, area),
    }
}

/// A short word for an agent's state, with its style.
pub(super) fn agent_badge<'a>(app: &App, agent: AgentRole) -> Span<'a> {
    let t = &app.theme;
    let Some(v) = app.agents.get(&agent) else {
        return Span::raw("");
    };
    match &v.status {
        AgentStatus::Idle => Span::styled("idle", t.muted),
        AgentStatus::Waiting => Span::styled("waiting", t.warn),
        AgentStatus::Running => Span::styled("writing…", t.warn),
        AgentStatus::Done => Span::styled(
            format!(
                "{} ms · {} tok",
                v.duration_ms,
                v.usage.input + v.usage.output
            ),
            t.good,
        ),
        AgentStatus::Failed(_) => Span::styled("failed", t.bad),
        AgentStatus::Cancelled => Span::styled("cancelled", t.bad),
    }
}

fn scene(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let block = pane_block(app, Pane::Scene, None);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let caption = Line::from(highlighted(
        &app.task.text,
        &app.search,
        t.base,
        t.highlight,
    ));
    frame.render_widget(Paragraph::new(caption), Rect { height: 1, ..inner });
    let image_area = scene_image_area(area);
    let note = if !app.image_enabled {
        "image off (i shows it)"
    } else if app.scene.is_none() {
        "no image for this task"
    } else {
        match &app.scene_protocol {
            Some((rect, protocol)) if *rect == image_area => {
                frame.render_widget(Image::new(protocol), image_area);
                return;
            }
            _ => "drawing the image…",
        }
    };
    frame.render_widget(
        Paragraph::new(Span::styled(note, t.muted)).wrap(Wrap { trim: true }),
        image_area,
    );
}

fn description(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let block = pane_block(
        app,
        Pane::Description,
        Some(agent_badge(app, AgentRole::Gkm)),
    );
    let output = app
        .agents
        .get(&AgentRole::Gkm)
        .map(|v| v.output.as_str())
        .unwrap_or_default();
    let text: Text = if output.is_empty() {
        Text::from(Span::styled(
            "No description yet: r runs the agents.",
            t.muted,
        ))
    } else {
        Text::from(
            output
                .lines()
                .map(|l| Line::from(highlighted(l, &app.search, t.base, t.highlight)))
                .collect::<Vec<_>>(),
        )
    };
    let scroll = app.scroll.get(&Pane::Description).copied().unwrap_or(0);
    frame.render_widget(
        Paragraph::new(text)
            .block(block)
            .wrap(Wrap { trim: false })
            .scroll((scroll, 0)),
        area,
    );
}

/// The latest scores and the KAS of step `index`, or the "scoring…" line.
fn step_scores(
    app: &App,
    index: usize,
    kas_label: impl Fn(f64) -> String,
) -> Result<(&ScoreOutcome, String), Line<'static>> {
    let scores = app
        .scores
        .as_ref()
        .ok_or_else(|| Line::from(Span::styled("    scoring…", app.theme.muted)))?;
    let kas = scores
        .kas
        .step_scores
        .get(index)
        .map(|k| kas_label(*k))
        .unwrap_or_default();
    Ok((scores, kas))
}

/// The mark under a plan step: which ground-truth step it matched, or why none.
fn plan_mark(app: &App, index: usize) -> Line<'static> {
    let t = &app.theme;
    let (scores, kas) =
        match step_scores(app, index, |k| format!(" · KAS {k:.2} vs GT {}", index + 1)) {
            Ok(found) => found,
            Err(line) => return line,
        };
    match &scores.pg2s {
        Pg2sOutcome::Ready(report) => {
            if let Some(m) = report
                .sentence_matches
                .iter()
                .find(|m| m.pred == Some(index))
            {
                let cos = m.cosine.unwrap_or_default();
                Line::from(vec![
                    Span::styled(format!("    ✓ GT {} · cos {cos:.3}", m.gt + 1), t.good),
                    Span::styled(kas, t.muted),
                ])
            } else {
                Line::from(vec![
                    Span::styled(
                        format!("    ✗ {}", unmatched_plan_reason(report, index)),
                        t.bad,
                    ),
                    Span::styled(kas, t.muted),
                ])
            }
        }
        _ => Line::from(Span::styled(
            format!("    {}", kas.trim_start_matches(" · ")),
            t.muted,
        )),
    }
}

/// Why a plan step matched no ground-truth step.
fn unmatched_plan_reason(report: &Pg2sReport, index: usize) -> String {
    let threshold = report.settings.sentence_threshold;
    let nearest = report
        .sentence_matches
        .iter()
        .filter_map(|m| m.closest.filter(|c| c.0 == index).map(|c| (m.gt, c.1)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    match nearest {
        Some((gt, cos)) => format!(
            "unmatched: nearest GT {} at cos {cos:.3} ≤ {threshold}",
            gt + 1
        ),
        None => format!("unmatched: no free GT step above cos {threshold}"),
    }
}

/// The mark under a ground-truth step: the plan step that matched it, or why none.
fn ground_truth_mark(app: &App, index: usize) -> Line<'static> {
    let t = &app.theme;
    let (scores, kas) = match step_scores(app, index, |k| format!(" · KAS {k:.2}")) {
        Ok(found) => found,
        Err(line) => return line,
    };
    match &scores.pg2s {
        Pg2sOutcome::Ready(report) => match report.sentence_matches.get(index) {
            Some(m) if m.pred.is_some() => Line::from(vec![
                Span::styled(
                    format!(
                        "    ✓ plan {} · cos {:.3}",
                        m.pred.unwrap_or_default() + 1,
                        m.cosine.unwrap_or_default()
                    ),
                    t.good,
                ),
                Span::styled(kas, t.muted),
            ]),
            Some(m) => {
                let why = match m.closest {
                    Some((j, c)) => format!(
                        "    ✗ missed: nearest plan step {} at cos {c:.3} ≤ {}",
                        j + 1,
                        report.settings.sentence_threshold
                    ),
                    None => "    ✗ missed: no plan step left".to_string(),
                };
                Line::from(vec![Span::styled(why, t.bad), Span::styled(kas, t.muted)])
            }
            None => Line::from(Span::styled("    scoring…", t.muted)),
        },
        _ => Line::from(Span::styled(
            format!("    {}", kas.trim_start_matches(" · ")),
            t.muted,
        )),
    }
}

fn steps(frame: &mut Frame, app: &App, list: StepList, area: Rect) {
    let t = &app.theme;
    let (pane, selected) = match list {
        StepList::Plan => (Pane::Plan, app.plan_selected),
        StepList::GroundTruth => (Pane::GroundTruth, app.ground_truth_selected),
    };
    let extra = match list {
        StepList::Plan => match &app.plan_source {
            PlanSource::None => None,
            PlanSource::Run { run } => Some(match app.agents.get(&planning_role(app.approach)) {
                Some(v) if v.status == AgentStatus::Running => {
                    Span::styled(format!("run {run} · streaming…"), t.warn)
                }
                _ => Span::styled(format!("run {run}"), t.muted),
            }),
            PlanSource::Published { approach, .. } => Some(Span::styled(
                format!("published {}", approach.name()),
                t.muted,
            )),
        },
        StepList::GroundTruth => Some(Span::styled(
            match &app.ground_truth_source {
                crate::session::GroundTruthSource::Demo { index } => {
                    format!("demo annotator {}", if *index == 1 { 'B' } else { 'A' })
                }
                crate::session::GroundTruthSource::Dataset { task } => task.clone(),
                crate::session::GroundTruthSource::File { path } => path.display().to_string(),
                crate::session::GroundTruthSource::Typed => "typed".to_string(),
            },
            t.muted,
        )),
    };
    let block = pane_block(app, pane, extra);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let items = app.steps(list);
    if items.is_empty() {
        let hint = match list {
            StepList::Plan => {
                "No plan yet: r runs the agents, p loads a published plan, o types one."
            }
            StepList::GroundTruth => "No ground truth: g chooses one, o types one.",
        };
        frame.render_widget(
            Paragraph::new(Span::styled(hint, t.muted)).wrap(Wrap { trim: true }),
            inner,
        );
        return;
    }
    let (first, count) = list_window(selected, items.len(), 2, inner.height as usize);
    let mut lines: Vec<Line> = Vec::with_capacity(count * 2);
    let mut cursor_row = None;
    for (i, step) in items.iter().enumerate().skip(first).take(count) {
        let number = Span::styled(format!("{:>2}. ", i + 1), t.accent);
        let editing_this = matches!(&app.editing,
            Editing::Step { list: l, index, .. } if *l == list && *index == i);
        if editing_this {
            cursor_row = Some((lines.len(), number.width()));
            lines.push(Line::from(number));
        } else {
            let base = if i == selected && app.focus == pane {
                t.selection
            } else {
                t.base
            };
            let mut spans = vec![number];
            spans.extend(highlighted(step, &app.search, base, t.highlight));
            lines.push(Line::from(spans));
        }
        lines.push(match list {
            StepList::Plan => plan_mark(app, i),
            StepList::GroundTruth => ground_truth_mark(app, i),
        });
    }
    frame.render_widget(Paragraph::new(lines), inner);
    if let (Some((row, indent)), Editing::Step { editor, .. }) = (cursor_row, &app.editing) {
        let at = Rect {
            x: inner.x + indent as u16,
            y: inner.y + row as u16,
            width: inner.width.saturating_sub(indent as u16),
            height: 1,
        };
        frame.render_widget(editor, at);
    }
}

fn score_span(theme: &Theme, name: &str, value: Option<f64>) -> Vec<Span<'static>> {
    let shown = value.map_or("  –  ".to_string(), |v| format!("{v:.3}"));
    let style = match value {
        Some(v) if v >= 0.6 => theme.good,
        Some(v) if v >= 0.3 => theme.warn,
        Some(_) => theme.bad,
        None => theme.muted,
    };
    vec![
        Span::styled(format!("{name} "), theme.accent),
        Span::styled(shown, style),
        Span::raw("  "),
    ]
}

fn scores(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let extra = app
        .scoring()
        .then(|| Span::styled("scoring…", t.warn))
        .or_else(|| {
            app.scores
                .as_ref()
                .map(|s| Span::styled(format!("{:.1} ms", s.millis), t.muted))
        });
    let block = pane_block(app, Pane::Scores, extra);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let mut lines = Vec::new();
    match &app.scores {
        None => lines.push(Line::from(Span::styled("scoring…", t.muted))),
        Some(s) => {
            let report = match &s.pg2s {
                Pg2sOutcome::Ready(r) => Some(r.as_ref()),
                _ => None,
            };
            let mut first = score_span(t, "PG2S", report.and_then(Pg2sReport::pg2s));
            first.extend(score_span(t, "KAS", s.kas.kas));
            lines.push(Line::from(first));
            let mut second = score_span(t, "S_plan", report.map(|r| r.s_plan));
            second.extend(score_span(t, "S_goal", report.and_then(Pg2sReport::s_goal)));
            lines.push(Line::from(second));
            match &s.pg2s {
                Pg2sOutcome::Waiting(reason) => lines.push(Line::from(Span::styled(
                    format!("PG2S is waiting for models: {reason}"),
                    t.warn,
                ))),
                Pg2sOutcome::Failed(e) => {
                    lines.push(Line::from(Span::styled(format!("PG2S failed: {e}"), t.bad)))
                }
                Pg2sOutcome::Ready(r) => {
                    if let Err(reason) = &r.goal {
                        lines.push(Line::from(Span::styled(
                            format!("S_goal unavailable: {reason}"),
                            t.warn,
                        )));
                    }
                }
            }
            if let Some(reason) = &s.kas.reason {
                lines.push(Line::from(Span::styled(format!("KAS: {reason}"), t.muted)));
            }
        }
    }
    let history: Vec<u64> = app
        .runs
        .iter()
        .filter_map(|r| r.scores)
        .map(|s| (s.pg2s.or(s.kas).unwrap_or(0.0) * 100.0).round() as u64)
        .collect();
    let width = usize::from(inner.width.max(1));
    let text_height = lines
        .iter()
        .map(|l| l.width().max(1).div_ceil(width) as u16)
        .sum::<u16>();
    let [text_area, rest] =
        Layout::vertical([Constraint::Length(text_height), Constraint::Min(0)]).areas(inner);
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: true }), text_area);
    if rest.height < 2 {
        return;
    }
    let [label, spark, table] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(2.min(rest.height - 1)),
        Constraint::Min(0),
    ])
    .areas(rest);
    frame.render_widget(
        Paragraph::new(Span::styled(
            format!("runs: {} (H lists and compares them)", app.runs.len()),
            t.muted,
        )),
        label,
    );
    frame.render_widget(
        Sparkline::default().data(&history).max(100).style(t.accent),
        spark,
    );
    let rows: Vec<Line> = app
        .runs
        .iter()
        .rev()
        .take(table.height as usize)
        .map(|r| {
            let s = r.scores.unwrap_or_default();
            let f = |v: Option<f64>| v.map_or("  –  ".to_string(), |v| format!("{v:.3}"));
            let (ms, tokens) = (r.total_ms(), r.total_tokens());
            Line::from(Span::styled(
                format!(
                    "#{:<3} PG2S {} KAS {} {:>6} ms {:>5} tok{}",
                    r.id,
                    f(s.pg2s),
                    f(s.kas),
                    ms,
                    tokens,
                    if r.cancelled { " cancelled" } else { "" }
                ),
                t.base,
            ))
        })
        .collect();
    frame.render_widget(Paragraph::new(rows), table);
}

fn prompt(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let block = pane_block(app, Pane::Prompt, Some(agent_badge(app, app.prompt_agent)));
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let mut tabs = Vec::new();
    for (i, agent) in roles(app.approach).iter().enumerate() {
        let style = if *agent == app.prompt_agent {
            t.selection
        } else {
            t.base
        };
        tabs.push(Span::styled(
            format!(" {} {} ", i + 1, role_label(*agent)),
            style,
        ));
    }
    if let Some(v) = app.agents.get(&app.prompt_agent) {
        tabs.push(Span::styled(
            format!(
                "  {}/{} · t={} · max {}",
                v.settings.provider,
                v.settings.model,
                v.settings.temperature,
                v.settings.max_tokens
            ),
            t.muted,
        ));
    }
    let note = app.provider_note();
    let changed = app.agent_changed(app.prompt_agent);
    let footer_height = if note.is_some() { 3 } else { 1 };
    let [tab_row, body, footer] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(1),
        Constraint::Length(footer_height),
    ])
    .areas(inner);
    frame.render_widget(Paragraph::new(Line::from(tabs)), tab_row);
    if matches!(app.editing, Editing::Prompt) {
        frame.render_widget(&app.prompt_editor, body);
    } else {
        let text: Vec<Line> = app
            .prompt_editor
            .lines()
            .iter()
            .map(|l| Line::from(highlighted(l, &app.search, t.base, t.highlight)))
            .collect();
        frame.render_widget(Paragraph::new(text).wrap(Wrap { trim: false }), body);
    }
    let mut footer_lines = vec![Line::from(Span::styled(
        if matches!(app.editing, Editing::Prompt) {
            "editing · Esc done · Ctrl-R run"
        } else if changed {
            "changed since its last run · r runs what changed · Enter edits"
        } else {
            "Enter edits · ←/→ agent · m provider and model"
        },
        if changed { t.warn } else { t.muted },
    ))];
    if let Some(note) = note {
        footer_lines.push(Line::from(Span::styled(note, t.warn)));
    }
    frame.render_widget(
        Paragraph::new(footer_lines).wrap(Wrap { trim: true }),
        footer,
    );
}
