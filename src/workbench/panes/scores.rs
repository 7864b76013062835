//! The Scores pane: KAS, PG2S and its parts, and the runs' scores.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::Frame;

use super::Shared;
use crate::metrics::pg2s::Pg2sReport;
use crate::stats::summary::Spread;
use crate::workbench::panes::{draw_scrolled, pane_block, Pane};
use crate::workbench::scoring::Pg2sOutcome;
use crate::workbench::scroll;
use crate::workbench::session::{PlanSource, RunRecord, RunState, ScoreRecord};
use crate::workbench::theme::Theme;

/// One score of a [`ScoreRecord`].
type ScoreOf = fn(&ScoreRecord) -> Option<f64>;

/// The scores whose spread over samples the pane shows, by name.
const SAMPLED: [(&str, ScoreOf); 4] = [
    ("PG2S", |s| s.pg2s),
    ("S_plan", |s| s.s_plan),
    ("S_goal", |s| s.s_goal),
    ("KAS", |s| s.kas),
];

/// The spread of one score over `scores`, if any sample has it.
fn spread_of(scores: &[ScoreRecord], of: ScoreOf) -> Option<Spread> {
    Spread::of(scores.iter().filter_map(of))
}

/// The run whose plan the Plan pane shows, with its samples' scores, when
/// more than one sample of it is scored.
fn sampled_run<'a>(app: &Shared<'a>) -> Option<(&'a RunRecord, Vec<ScoreRecord>)> {
    let PlanSource::Run { run } = app.work.plan_source else {
        return None;
    };
    let kept = app.runs.history.iter().find(|r| r.id == run)?;
    let scores = kept.sample_scores();
    (scores.len() > 1).then_some((kept, scores))
}

/// The lines of a sampled run: how many samples, then each score as
/// `PG2S 0.433 ±0.020` (the value right after the name) and its min–max.
fn spread_lines(theme: &Theme, run: &RunRecord, scores: &[ScoreRecord]) -> Vec<Line<'static>> {
    let mut lines = vec![Line::from(Span::styled(
        format!(
            "run #{}{}: {} of {} samples scored (mean ±sd, min–max)",
            run.id,
            match run.state {
                RunState::Partial => " partial",
                _ => "",
            },
            scores.len(),
            run.samples.len() + 1
        ),
        theme.muted,
    ))];
    for (name, of) in SAMPLED {
        let spans = match spread_of(scores, of) {
            Some(spread) => vec![
                Span::styled(format!("{name} "), theme.accent),
                Span::styled(spread.plus_minus(3), score_style(theme, Some(spread.mean))),
                Span::styled(format!("  {}", spread.range(3)), theme.muted),
            ],
            None => score_span(theme, name, None),
        };
        lines.push(Line::from(spans));
    }
    lines.push(Line::from(Span::styled(
        "sample 1, in the Plan pane:",
        theme.muted,
    )));
    lines
}

/// The runs' scores as one line of bars, oldest first, the last a run at
/// the pane's right edge once there are more than `width`: a sampled run
/// as its min, mean and max (min and max muted), a run without any score
/// as an empty bar; a run not scored (failed, cancelled) has none.
fn history_bars(theme: &Theme, history: &[RunRecord], width: usize) -> Line<'static> {
    const LEVELS: [char; 9] = [' ', '▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];
    let bar = |v: f64, style| {
        let level = (v.clamp(0.0, 1.0) * 8.0).round() as usize;
        Span::styled(LEVELS[level].to_string(), style)
    };
    let mut bars = Vec::new();
    for run in history {
        let scores = run.sample_scores();
        let Some(spread) = spread_of(&scores, |s| s.pg2s.or(s.kas)) else {
            if run.state.is_scored() && run.scores.is_some() {
                bars.push(bar(0.0, theme.accent));
            }
            continue;
        };
        if spread.count > 1 {
            bars.push(bar(spread.min, theme.muted));
            bars.push(bar(spread.mean, theme.accent));
            bars.push(bar(spread.max, theme.muted));
        } else {
            bars.push(bar(spread.mean, theme.accent));
        }
    }
    let skip = bars.len().saturating_sub(width);
    Line::from(bars.split_off(skip))
}

/// The style of a score: good, middling, bad or absent.
fn score_style(theme: &Theme, value: Option<f64>) -> ratatui::style::Style {
    match value {
        Some(v) if v >= 0.6 => theme.good,
        Some(v) if v >= 0.3 => theme.warn,
        Some(_) => theme.bad,
        None => theme.muted,
    }
}

pub(crate) fn score_span(theme: &Theme, name: &str, value: Option<f64>) -> Vec<Span<'static>> {
    let shown = value.map_or("  –  ".to_string(), |v| format!("{v:.3}"));
    let style = score_style(theme, value);
    vec![
        Span::styled(format!("{name} "), theme.accent),
        Span::styled(shown, style),
        Span::raw("  "),
    ]
}

pub(crate) fn draw(frame: &mut Frame, app: &Shared, area: Rect) {
    let t = app.theme;
    let extra = app
        .work
        .scoring()
        .then(|| Span::styled("scoring…", t.warn))
        .or_else(|| {
            app.work
                .scores
                .as_ref()
                .map(|s| Span::styled(format!("{:.1} ms", s.millis), t.muted))
        });
    let block = pane_block(app, Pane::Scores, extra, area.width);
    let inner = block.inner(area);
    let lines = body(app, usize::from(inner.width.max(1)));
    draw_scrolled(frame, app, Pane::Scores, block, area, inner, lines);
}

/// The furthest the pane scrolls when drawn in `area`.
pub(crate) fn scroll_limit(app: &Shared, area: Rect) -> usize {
    let inner = pane_block(app, Pane::Scores, None, area.width).inner(area);
    body(app, usize::from(inner.width.max(1)))
        .len()
        .saturating_sub(usize::from(inner.height))
}

/// What the pane shows, `width` columns wide: the scores of the plan shown
/// (why a run that did not finish is not among them, a sampled run's
/// spread), then the runs' scores as bars and a line each, newest first.
fn body(app: &Shared, width: usize) -> Vec<Line<'static>> {
    let t = app.theme;
    let mut lines = Vec::new();
    if let Some(run) = app.unfinished_latest() {
        lines.push(Line::from(Span::styled(
            format!(
                "run #{} {} — the scores below are the plan shown",
                run.id,
                run.state_text()
            ),
            t.bad,
        )));
    }
    if let Some((run, scores)) = sampled_run(app) {
        lines.extend(spread_lines(t, run, &scores));
    }
    match &app.work.scores {
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
    let mut lines = scroll::wrap_text(&lines, width);
    if !app.runs.history.is_empty() {
        lines.push(Line::from(Span::styled(
            format!(
                "runs: {} (H lists and compares them{})",
                app.runs.history.len(),
                if app.runs.history.iter().any(|r| !r.samples.is_empty()) {
                    "; a sampled run: min, mean, max"
                } else {
                    ""
                }
            ),
            t.muted,
        )));
        lines.push(history_bars(t, &app.runs.history, width));
    }
    let rows: Vec<Line> = app
        .runs
        .history
        .iter()
        .rev()
        .map(|r| {
            let scores = r.sample_scores();
            let f = |of: ScoreOf| {
                spread_of(&scores, of).map_or("  –  ".to_string(), |s| s.plus_minus(3))
            };
            let (ms, tokens) = (r.total_ms(), r.total_tokens());
            Line::from(Span::styled(
                format!(
                    "#{:<3} PG2S {} KAS {} {:>6} ms {:>5} tok{}",
                    r.id,
                    f(|s| s.pg2s),
                    f(|s| s.kas),
                    ms,
                    tokens,
                    match r.state {
                        RunState::Finished => String::new(),
                        state => format!(" {}", state.word()),
                    }
                ),
                t.base,
            ))
        })
        .collect();
    lines.extend(scroll::wrap_text(&rows, width));
    lines
}
