//! The run history and the comparison of two runs.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Sparkline, Wrap};
use ratatui::Frame;

use crate::agents::cost::{dollars, Billing, PriceTable};
use crate::agents::pipeline::AgentRecord;
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
        "   run  approach       PG2S   S_plan S_goal KAS     ms      tokens  steps       cost",
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
                "{mark}  #{:<3} {:<14} {:<6} {:<6} {:<6} {:<6} {:>6} {:>8} {:>6} {:>10}{}",
                r.id,
                r.approach.name(),
                fmt_score(s.pg2s),
                fmt_score(s.s_plan),
                fmt_score(s.s_goal),
                fmt_score(s.kas),
                ms,
                tokens,
                r.plan.len(),
                cost_text(run_cost(&app.prices, r)),
                if r.cancelled { " cancelled" } else { "" }
            ),
            style,
        )));
    }
    frame.render_widget(Paragraph::new(lines), table);
}

/// What one agent's answer cost in US dollars at `prices`: nothing when it
/// came from the response cache, `None` when its model has no price (the
/// demo's `replay` agents among them).
fn agent_cost(prices: &PriceTable, agent: &AgentRecord) -> Option<f64> {
    let billing = if agent.cached {
        Billing::Cached
    } else {
        Billing::Interactive
    };
    prices.cost(
        agent.settings.provider,
        &agent.settings.model,
        agent.usage,
        billing,
    )
}

/// What a whole run cost: the sum over its agents, `None` when any of them
/// has no price (a partial sum would read as the whole).
fn run_cost(prices: &PriceTable, run: &RunRecord) -> Option<f64> {
    run.agents.iter().map(|a| agent_cost(prices, a)).sum()
}

/// A cost as the run history shows it: `$0.0123`, or `no price`.
fn cost_text(usd: Option<f64>) -> String {
    match usd {
        Some(_) => format!("${}", dollars(usd)),
        None => dollars(None),
    }
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
        Line::from(Span::styled(
            format!(
                "{} ms · {} tok · {}",
                run.total_ms(),
                run.total_tokens(),
                cost_text(run_cost(&app.prices, run))
            ),
            t.muted,
        )),
    ];
    for a in &run.agents {
        let same_prompt = other
            .agents
            .iter()
            .any(|b| b.role == a.role && b.prompt_hash == a.prompt_hash);
        lines.push(Line::from(vec![
            Span::styled(format!("{} ", a.role), t.accent),
            Span::styled(
                format!(
                    "{}/{} t={} · {} ms · {}+{} tok · {}",
                    a.settings.provider,
                    a.settings.model,
                    a.settings.temperature,
                    a.elapsed_ms,
                    a.usage.input_tokens,
                    a.usage.output_tokens,
                    cost_text(agent_cost(&app.prices, a))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::config::AgentSettings;
    use crate::agents::config::ConfigFile;
    use crate::agents::ProviderKind;
    use crate::agents::{AgentRole, Approach, Usage};

    /// gpt-4o at $2.50 in and $10 out per million tokens, as a config
    /// file writes it; nothing else.
    fn prices() -> PriceTable {
        let file: ConfigFile = toml::from_str(
            "[prices.openai.\"gpt-4o\"]\ninput_per_million = 2.5\noutput_per_million = 10.0\n",
        )
        .unwrap();
        PriceTable::from_config(&file.prices).unwrap()
    }

    fn agent(provider: &str, model: &str, cached: bool) -> AgentRecord {
        let provider: ProviderKind = provider.parse().unwrap();
        AgentRecord {
            usage: Usage {
                input_tokens: 1_000,
                output_tokens: 200,
            },
            cached,
            ..AgentRecord::blank(
                AgentRole::Planner,
                &AgentSettings::new(provider, model, 0.0, 512),
                "multi-image-planner",
                "",
            )
        }
    }

    fn run(agents: Vec<AgentRecord>) -> RunRecord {
        RunRecord {
            id: 1,
            started_unix: 0,
            approach: Approach::MultiImage,
            task: String::new(),
            agents,
            prompts: Default::default(),
            plan: Vec::new(),
            ground_truth: Vec::new(),
            scores: None,
            cancelled: false,
            corrupted: None,
            steps: Vec::new(),
        }
    }

    #[test]
    fn a_priced_answer_costs_its_tokens_a_cached_one_nothing_an_unpriced_one_no_figure() {
        let p = prices();
        // 1,000 × $2.50 / 1e6 + 200 × $10 / 1e6 = $0.0045.
        let cases = [
            (("openai", "gpt-4o", false), "$0.0045"),
            (("openai", "gpt-4o", true), "$0.0000"),
            (("openai", "gpt-4.1", false), "no price"),
            (("replay", "demo-recording", false), "no price"),
        ];
        for ((provider, model, cached), shown) in cases {
            let a = agent(provider, model, cached);
            assert_eq!(cost_text(agent_cost(&p, &a)), shown, "{provider}/{model}");
        }
    }

    #[test]
    fn a_run_costs_the_sum_of_its_agents_and_nothing_when_one_has_no_price() {
        let p = prices();
        let paid = || agent("openai", "gpt-4o", false);
        assert_eq!(
            cost_text(run_cost(
                &p,
                &run(vec![paid(), paid(), agent("openai", "gpt-4o", true)])
            )),
            "$0.0090"
        );
        assert_eq!(
            cost_text(run_cost(
                &p,
                &run(vec![paid(), agent("anthropic", "claude", false)])
            )),
            "no price"
        );
    }
}
