//! The run history and the diff of two runs: one overlay that owns a copy
//! of the history, its selection and mark, and the open diff with its
//! scroll position; its keys are the `History` and `RunDiff` rows of the
//! key table.

use std::cell::Cell;

use crossterm::event::{KeyEvent, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Constraint, Layout, Position, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph, Sparkline};
use ratatui::Frame;

use crate::agents::cost::PriceTable;
use crate::metrics::shown;
use crate::stats::summary::Spread;
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::overlays::diff_page::{diff_lines, wrap};
use crate::workbench::overlays::{centred, moved, themed_box};
use crate::workbench::panes::list_window;
use crate::workbench::run_diff::{agent_side, cost_text, run_cost, ReadMetric, RunDiff, METRICS};
use crate::workbench::runs::mean_score;
use crate::workbench::scroll::wheel_step;
use crate::workbench::scroll::{self, WHEEL_LINES};
use crate::workbench::session::{RunRecord, RunState};
use crate::workbench::theme::Theme;

/// The run history, and the diff of two of its runs when one is open.
#[derive(Debug, Clone)]
pub struct RunsOverlay {
    runs: Vec<RunRecord>,
    prices: PriceTable,
    selected: usize,
    marked: Option<usize>,
    diff: Option<DiffPage>,
    /// Where the table's rows were drawn last (below its header) and the
    /// index of the run on the first, for the mouse.
    rows_drawn: Cell<(Rect, usize)>,
}

/// An open diff and how far it is scrolled.
#[derive(Debug, Clone)]
struct DiffPage {
    diff: RunDiff,
    scroll: usize,
    /// The wrapped lines and the rows shown at the last draw, so that
    /// scrolling stops at the end.
    extent: Cell<(usize, usize)>,
}

/// What a key in the overlay asks of the app.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RunsOutcome {
    /// Keep the overlay open.
    Stay,
    /// Close it.
    Close,
    /// Close it and load the plan of the run at this index of the history.
    Load(usize),
    /// Keep it open and show this line in the status bar.
    Note(String),
}

impl RunsOverlay {
    /// The history of `runs` (with costs at `prices`), the latest selected.
    pub fn new(runs: &[RunRecord], prices: &PriceTable) -> Self {
        RunsOverlay {
            runs: runs.to_vec(),
            prices: prices.clone(),
            selected: runs.len().saturating_sub(1),
            marked: None,
            diff: None,
            rows_drawn: Cell::new((Rect::default(), 0)),
        }
    }

    /// Takes the history again after a run was added or scored, keeping
    /// the selection and an open diff.
    pub fn set_runs(&mut self, runs: &[RunRecord]) {
        self.runs = runs.to_vec();
        self.selected = self.selected.min(runs.len().saturating_sub(1));
        self.marked = self.marked.filter(|&m| m < runs.len());
    }

    /// The key context of what is shown: the history or the diff.
    pub fn context(&self) -> Context {
        if self.diff.is_some() {
            Context::RunDiff
        } else {
            Context::History
        }
    }

    /// The diff shown, if one is open.
    pub fn diff(&self) -> Option<&RunDiff> {
        self.diff.as_ref().map(|d| &d.diff)
    }

    /// Opens the diff of the marked run (else the one before the selected)
    /// and the selected one, the older first.
    fn open_diff(&mut self) -> RunsOutcome {
        let other = self.marked.unwrap_or(self.selected.saturating_sub(1));
        let (first, second) = (other.min(self.selected), other.max(self.selected));
        match (self.runs.get(first), self.runs.get(second)) {
            (Some(a), Some(b)) if first != second => {
                self.diff = Some(DiffPage {
                    diff: RunDiff::between(a, b, &self.prices),
                    scroll: 0,
                    extent: Cell::new((0, 0)),
                });
                RunsOutcome::Stay
            }
            _ => RunsOutcome::Note(
                "a diff needs two runs: mark one with space, select another, press d".into(),
            ),
        }
    }

    fn on_history_action(&mut self, action: Action) -> RunsOutcome {
        match action {
            Action::Leave => RunsOutcome::Close,
            Action::MarkRun => {
                self.marked = (self.marked != Some(self.selected)).then_some(self.selected);
                RunsOutcome::Stay
            }
            Action::CompareRuns => self.open_diff(),
            Action::Accept if self.selected < self.runs.len() => RunsOutcome::Load(self.selected),
            Action::Move(delta) => {
                self.selected = moved(self.selected, delta, self.runs.len());
                RunsOutcome::Stay
            }
            _ => RunsOutcome::Stay,
        }
    }

    fn draw_history(&self, frame: &mut Frame, area: Rect, t: &Theme) {
        let rect = centred(area, 100, 26);
        frame.render_widget(Clear, rect);
        let title = format!("Runs ({})", keymap::hints(Context::History));
        let block = themed_box(t, &title);
        let inner = block.inner(rect);
        frame.render_widget(block, rect);
        let Some(current) = self.runs.get(self.selected) else {
            frame.render_widget(Paragraph::new(Span::styled("No runs yet.", t.muted)), inner);
            return;
        };
        let mut per_agent = vec![Line::from(Span::styled(
            format!("run #{} {}", current.id, current.state_text()),
            if current.state == RunState::Finished {
                t.muted
            } else {
                t.bad
            },
        ))];
        let scores = current.sample_scores();
        let spreads: Vec<String> = METRICS
            .iter()
            .filter_map(|(name, of)| {
                let spread = Spread::of(scores.iter().filter_map(of))?;
                Some(format!("{name} {}", spread.plus_minus(3)))
            })
            .collect();
        per_agent.push(Line::from(Span::styled(
            match scores.len() {
                0 => "not scored".to_string(),
                n => format!(
                    "{} (mean ±sd over {n} of {} samples); per agent:",
                    spreads.join(" · "),
                    current.samples.len() + 1
                ),
            },
            t.muted,
        )));
        // Wrapped, never cut: as many rows as it takes (each agent's under
        // itself), the table keeping its header and a row.
        let width = usize::from(inner.width).max(1);
        let mut per_agent = scroll::wrap_text(&per_agent, width);
        per_agent.extend(current.agents.iter().flat_map(|a| {
            scroll::wrap_hanging(
                &[Span::styled(format!("  {:<8}", a.role.label()), t.accent)],
                &[Span::styled(
                    match agent_side(&self.prices, current, a.role) {
                        Some(side) => format!(
                            "{}/{} · {} ms · {}+{} tok · {}{}{}",
                            a.settings.provider,
                            a.settings.model,
                            side.elapsed_ms,
                            side.usage.input_tokens,
                            side.usage.output_tokens,
                            cost_text(side.usd),
                            if side.cached { " (cached)" } else { "" },
                            match side.calls {
                                1 => String::new(),
                                n => format!(" · {n} calls"),
                            }
                        ),
                        None => String::new(),
                    },
                    t.base,
                )],
                width,
            )
        }));
        let detail = u16::try_from(per_agent.len())
            .unwrap_or(u16::MAX)
            .min(inner.height.saturating_sub(5));
        let [spark, table, agents] = Layout::vertical([
            Constraint::Length(3),
            Constraint::Min(2),
            Constraint::Length(detail),
        ])
        .areas(inner);
        let data: Vec<u64> = self
            .runs
            .iter()
            .filter(|r| r.state.is_scored())
            .map(|r| mean_score(r, |s| s.pg2s.or(s.kas)).map_or(0, |v| (v * 100.0).round() as u64))
            .collect();
        frame.render_widget(
            Sparkline::default().data(&data).max(100).style(t.accent),
            spark,
        );
        let widths = column_widths(usize::from(table.width));
        let row = |mark: &str, cells: [String; COLUMNS.len()]| {
            let mut text = mark.to_string();
            for ((column, width), cell) in COLUMNS.iter().zip(&widths).zip(cells) {
                let Some(width) = width else { continue };
                if column.right {
                    text.push_str(&format!(" {cell:>width$}"));
                } else {
                    text.push_str(&format!(" {cell:<width$}"));
                }
            }
            scroll::truncate(&text, usize::from(table.width))
        };
        let mut lines = vec![Line::from(Span::styled(
            row("  ", COLUMNS.map(|c| c.name.to_string())),
            t.muted,
        ))];
        let (first, count) = list_window(
            self.selected,
            self.runs.len(),
            1,
            usize::from(table.height.saturating_sub(1)),
        );
        let rows = Rect {
            y: table.y + 1,
            height: table.height.saturating_sub(1),
            ..table
        };
        self.rows_drawn.set((rows, first));
        for (i, r) in self.runs.iter().enumerate().skip(first).take(count) {
            let mean = |of: ReadMetric| mean_score(r, of);
            let mark = if self.marked == Some(i) { "● " } else { "  " };
            let style = if i == self.selected {
                t.selection
            } else {
                t.base
            };
            let cells = [
                format!("#{}", r.id),
                r.approach.name().to_string(),
                shown(mean(|s| s.pg2s)),
                shown(mean(|s| s.s_plan)),
                shown(mean(|s| s.s_goal)),
                shown(mean(|s| s.kas)),
                r.total_ms().to_string(),
                r.total_tokens().to_string(),
                r.plan.len().to_string(),
                cost_text(run_cost(&self.prices, r)),
                format!("{}/{}", r.sample_scores().len(), r.samples.len() + 1),
                r.state.word().to_string(),
            ];
            lines.push(Line::from(Span::styled(row(mark, cells), style)));
        }
        frame.render_widget(Paragraph::new(lines), table);
        frame.render_widget(Paragraph::new(per_agent), agents);
    }
}

/// A column of the run history: its name, width and alignment, and how
/// soon it goes when the box is narrow (0 never).
struct Column {
    name: &'static str,
    width: usize,
    right: bool,
    gives_way: u8,
}

const fn column(name: &'static str, width: usize, right: bool, gives_way: u8) -> Column {
    Column {
        name,
        width,
        right,
        gives_way,
    }
}

/// The history's columns in the order shown. On a narrow screen the
/// approach goes first, then the steps, S_plan, S_goal, the samples, the
/// time and the tokens; the run, PG2S, KAS, the cost and the state stay.
const COLUMNS: [Column; 12] = [
    column("run", 4, false, 0),
    column("approach", 12, false, 1),
    column("PG2S", 6, false, 0),
    column("S_plan", 6, false, 3),
    column("S_goal", 6, false, 4),
    column("KAS", 6, false, 0),
    column("ms", 6, true, 6),
    column("tokens", 7, true, 7),
    column("steps", 5, true, 2),
    column("cost", 9, true, 0),
    column("samples", 7, true, 5),
    column("state", 9, false, 0),
];

/// The width of each column shown in a table `width` columns wide (`None`
/// for a column given up), after the two of the mark.
fn column_widths(width: usize) -> [Option<usize>; COLUMNS.len()] {
    let mut widths = COLUMNS.map(|c| Some(c.width));
    let used = |widths: &[Option<usize>]| 2 + widths.iter().flatten().map(|w| w + 1).sum::<usize>();
    for rank in 1..=COLUMNS.iter().map(|c| c.gives_way).max().unwrap_or(0) {
        if used(&widths) <= width {
            break;
        }
        for (w, c) in widths.iter_mut().zip(&COLUMNS) {
            if c.gives_way == rank {
                *w = None;
            }
        }
    }
    widths
}

impl Component for RunsOverlay {
    type Outcome = RunsOutcome;

    fn contexts(&self) -> Vec<Context> {
        vec![self.context()]
    }

    fn on_action(&mut self, action: Action) -> RunsOutcome {
        let Some(page) = &mut self.diff else {
            return self.on_history_action(action);
        };
        match action {
            Action::Leave => self.diff = None,
            Action::Move(_) | Action::HalfPage(_) => {
                // Past the end stops at the end once a draw has measured it.
                let (last, half) = match page.extent.get() {
                    (0, 0) => (usize::MAX, 1),
                    (total, shown) => (total.saturating_sub(shown), (shown / 2).max(1)),
                };
                let delta = match action {
                    Action::HalfPage(d) => d.saturating_mul(half as isize),
                    Action::Move(d) => d,
                    _ => 0,
                };
                page.scroll = page.scroll.min(last).saturating_add_signed(delta).min(last);
            }
            _ => {}
        }
        RunsOutcome::Stay
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> RunsOutcome {
        RunsOutcome::Stay
    }

    /// In the history a click selects a run and a click on the selected
    /// one loads its plan; the wheel moves the selection, or scrolls the
    /// diff.
    fn on_mouse(&mut self, mouse: MouseEvent, _area: Rect) -> RunsOutcome {
        let step = wheel_step(&mouse);
        if self.diff.is_some() {
            return self.on_action(Action::Move(step * WHEEL_LINES));
        }
        let (rows, first) = self.rows_drawn.get();
        let clicked = (mouse.kind == MouseEventKind::Down(MouseButton::Left)
            && rows.contains(Position::new(mouse.column, mouse.row)))
        .then(|| first + usize::from(mouse.row - rows.y))
        .filter(|&i| i < self.runs.len());
        match clicked {
            Some(i) if i == self.selected => self.on_action(Action::Accept),
            Some(i) => {
                self.selected = i;
                RunsOutcome::Stay
            }
            None => self.on_action(Action::Move(step)),
        }
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let Some(page) = &self.diff else {
            return self.draw_history(frame, area, theme);
        };
        // The whole screen but a margin, so the status bar shows the keys.
        let area = centred(area, area.width, area.height);
        frame.render_widget(Clear, area);
        let [a, b] = page.diff.ids;
        let inner = themed_box(theme, "").inner(area);
        let lines = wrap(diff_lines(&page.diff, theme), usize::from(inner.width));
        let shown = usize::from(inner.height);
        page.extent.set((lines.len(), shown));
        let first = page.scroll.min(lines.len().saturating_sub(shown));
        let title = format!(
            "Diff run #{a} → #{b} · lines {}–{} of {}",
            first + 1,
            (first + shown).min(lines.len()),
            lines.len()
        );
        frame.render_widget(themed_box(theme, &title), area);
        let visible: Vec<Line> = lines.into_iter().skip(first).take(shown).collect();
        frame.render_widget(Paragraph::new(visible), inner);
    }
}
