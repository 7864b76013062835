//! The Scores pane: KAS, PG2S and its parts, and the runs' scores.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Sparkline, Wrap};
use ratatui::Frame;

use crate::metrics::pg2s::Pg2sReport;
use crate::workbench::app::App;
use crate::workbench::panes::{pane_block, Pane};
use crate::workbench::scoring::Pg2sOutcome;
use crate::workbench::theme::Theme;

pub(crate) fn score_span(theme: &Theme, name: &str, value: Option<f64>) -> Vec<Span<'static>> {
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

pub(crate) fn draw(frame: &mut Frame, app: &App, area: Rect) {
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
        .history
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
            format!(
                "runs: {} (H lists and compares them)",
                app.runs.history.len()
            ),
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
        .history
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
