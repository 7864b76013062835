//! The run history and the comparison of two runs.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Sparkline, Wrap};
use ratatui::Frame;

use crate::workbench::app::{App, Severity};
use crate::workbench::keymap::Action;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::{fmt_score, moved, open_box, Overlay};
use crate::workbench::session::{PlanSource, RunRecord};

impl App {
    /// A key of the run history.
    pub(crate) fn on_history_key(
        &mut self,
        selected: usize,
        marked: Option<usize>,
        action: Option<Action>,
    ) -> Vec<Cmd> {
        let mut next = Overlay::Runs { selected, marked };
        match action {
            Some(Action::Leave) => return Vec::new(),
            Some(Action::MarkRun) => {
                next = Overlay::Runs {
                    selected,
                    marked: (marked != Some(selected)).then_some(selected),
                };
            }
            Some(Action::CompareRuns) => {
                let left = marked.unwrap_or(selected.saturating_sub(1));
                if self.runs.history.len() >= 2 && left != selected {
                    next = Overlay::Compare {
                        left,
                        right: selected,
                    };
                } else {
                    self.set_status(
                        "mark a run with space, select another, then press c",
                        Severity::Info,
                    );
                }
            }
            Some(Action::Accept) => {
                if let Some(run) = self.runs.history.get(selected) {
                    self.plan.replace(run.plan.clone());
                    self.plan_source = PlanSource::Run { run: run.id };
                    let id = run.id;
                    self.set_status(format!("plan of run {id} loaded"), Severity::Info);
                    return vec![self.rescore()];
                }
                return Vec::new();
            }
            Some(Action::Move(delta)) => {
                next = Overlay::Runs {
                    selected: moved(selected, delta, self.runs.history.len()),
                    marked,
                };
            }
            _ => {}
        }
        self.overlay = Some(next);
        Vec::new()
    }
}

pub(crate) fn draw(
    frame: &mut Frame,
    app: &App,
    area: Rect,
    selected: usize,
    marked: Option<usize>,
) {
    let t = &app.theme;
    let inner = open_box(
        frame,
        app,
        area,
        (100, 24),
        "Runs (space marks, c compares, Enter loads the plan)",
    );
    if app.runs.history.is_empty() {
        frame.render_widget(Paragraph::new(Span::styled("No runs yet.", t.muted)), inner);
        return;
    }
    let [spark, table] = Layout::vertical([Constraint::Length(3), Constraint::Min(1)]).areas(inner);
    let data: Vec<u64> = app
        .runs
        .history
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
    let (first, count) = super::list_window(
        selected,
        app.runs.history.len(),
        1,
        table.height as usize - 1,
    );
    for (i, r) in app.runs.history.iter().enumerate().skip(first).take(count) {
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

pub(crate) fn run_lines<'a>(app: &App, run: &'a RunRecord, other: &RunRecord) -> Vec<Line<'a>> {
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

pub(crate) fn draw_compare(frame: &mut Frame, app: &App, area: Rect, left: usize, right: usize) {
    let inner = open_box(
        frame,
        app,
        area,
        (area.width, area.height),
        "Compare runs (Esc closes; differences highlighted)",
    );
    let (Some(a), Some(b)) = (app.runs.history.get(left), app.runs.history.get(right)) else {
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
