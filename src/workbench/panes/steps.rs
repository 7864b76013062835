//! The Plan and Ground Truth panes: two step lists with one editor and one
//! drawing, marked with their matches.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use super::Shared;
use crate::demo;
use crate::metrics::pg2s::Pg2sReport;
use crate::plan::parse_steps;
use crate::workbench::editing::Editing;
use crate::workbench::keymap::Action;
use crate::workbench::panes::{highlighted, pane_block, Pane};
use crate::workbench::runs::AgentStatus;
use crate::workbench::scoring::{Pg2sOutcome, ScoreOutcome};
use crate::workbench::scroll::{self, Scroll, Wrapped};
use crate::workbench::session::{GroundTruthSource, PlanSource};
use crate::workbench::undo::Undo;

pub use crate::workbench::layout::StepList;

/// The demo's ground truth of annotator A (`index` 0) or B (1).
pub(crate) fn demo_ground_truth(index: usize) -> Vec<String> {
    parse_steps(if index == 1 {
        demo::GROUND_TRUTH_B
    } else {
        demo::GROUND_TRUTH
    })
}

/// A step list as it was before an edit, with where its steps came from:
/// what `u` puts back ([`StepUndo`]).
#[derive(Debug, Clone, PartialEq)]
pub struct StepsBefore {
    /// Which list was edited.
    pub list: StepList,
    /// Its steps and selection.
    pub steps: Steps,
    /// The plan's origin then (a restored plan must say where its steps
    /// came from).
    pub plan_source: PlanSource,
    /// The ground truth's origin then (an edit makes it `typed`).
    pub ground_truth_source: GroundTruthSource,
}

/// The step edits `u` can take back on one source.
pub type StepUndo = Undo<StepsBefore>;

/// A list of steps with a selection: the plan or the ground truth. Both
/// panes edit, move and search their steps through this one type.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Steps {
    /// The steps, one sentence each.
    pub items: Vec<String>,
    /// The selected step (0 when the list is empty).
    pub selected: usize,
}

impl Steps {
    /// `items`, with the first one selected.
    pub fn new(items: Vec<String>) -> Self {
        Steps { items, selected: 0 }
    }

    /// How many steps there are.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Replaces every step and selects the first.
    pub fn replace(&mut self, items: Vec<String>) {
        *self = Steps::new(items);
    }

    /// Selects `index`, or the last step when there are fewer.
    pub fn select(&mut self, index: usize) {
        self.selected = index.min(self.len().saturating_sub(1));
    }

    /// Where an edit opens: a new empty step at `insert`, or the selected
    /// step (a new one at the end when there is none). Returns the step's
    /// index and whether it was inserted for the edit.
    pub fn open_edit(&mut self, insert: Option<usize>) -> (usize, bool) {
        let (index, inserted) = match insert {
            Some(at) => {
                let at = at.min(self.len());
                self.items.insert(at, String::new());
                (at, true)
            }
            None if self.selected >= self.len() => {
                self.items.push(String::new());
                (self.len() - 1, true)
            }
            None => (self.selected, false),
        };
        self.selected = index;
        (index, inserted)
    }

    /// Keeps an edit: the step becomes `text`, or goes when `text` is blank.
    pub fn commit(&mut self, index: usize, text: &str) {
        let text = text.trim();
        if text.is_empty() {
            if index < self.len() {
                self.items.remove(index);
            }
        } else if let Some(step) = self.items.get_mut(index) {
            *step = text.to_string();
        }
        self.select(index);
    }

    /// Drops an edit: a step inserted for it goes again.
    pub fn discard(&mut self, index: usize, inserted: bool) {
        if inserted && index < self.len() {
            self.items.remove(index);
        }
        self.select(index);
    }

    /// Deletes or moves the selected step for [`Action::DeleteStep`],
    /// [`Action::StepDown`] and [`Action::StepUp`]; whether the steps changed.
    pub fn rearrange(&mut self, action: Action) -> bool {
        let (sel, len) = (self.selected, self.len());
        match action {
            Action::DeleteStep if sel < len => {
                self.items.remove(sel);
                self.selected = sel.min(len.saturating_sub(2));
            }
            Action::StepDown if sel + 1 < len => {
                self.items.swap(sel, sel + 1);
                self.selected = sel + 1;
            }
            Action::StepUp if sel > 0 && sel < len => {
                self.items.swap(sel, sel - 1);
                self.selected = sel - 1;
            }
            _ => return false,
        }
        true
    }

    /// The next step after the selected one (wrapping) holding `needle`,
    /// ignoring case.
    pub fn next_hit(&self, needle: &str) -> Option<usize> {
        let needle = needle.to_lowercase();
        let n = self.len();
        (1..=n)
            .map(|k| (self.selected + k) % n)
            .find(|&i| self.items[i].to_lowercase().contains(&needle))
    }
}

/// The latest scores and the KAS of step `index`, or the "scoring…" line.
pub(crate) fn step_scores<'a>(
    app: &Shared<'a>,
    index: usize,
    kas_label: impl Fn(f64) -> String,
) -> Result<(&'a ScoreOutcome, String), Line<'static>> {
    let scores = app
        .work
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
pub(crate) fn plan_mark(app: &Shared, index: usize) -> Line<'static> {
    let t = app.theme;
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
pub(crate) fn unmatched_plan_reason(report: &Pg2sReport, index: usize) -> String {
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
pub(crate) fn ground_truth_mark(app: &Shared, index: usize) -> Line<'static> {
    let t = app.theme;
    let (scores, kas) = match step_scores(app, index, |k| {
        format!(" · KAS {k:.2} vs plan {}", index + 1)
    }) {
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

pub(crate) fn draw(frame: &mut Frame, app: &Shared, list: StepList, area: Rect) {
    let t = app.theme;
    let (pane, selected) = match list {
        StepList::Plan => (Pane::Plan, app.panes.plan.selected),
        StepList::GroundTruth => (Pane::GroundTruth, app.panes.ground_truth.selected),
    };
    let extra = match list {
        StepList::Plan => {
            let shown = match &app.work.plan_source {
                PlanSource::None => None,
                PlanSource::Run { run } => Some(
                    match app.runs.agents.get(&app.work.approach.planning_role()) {
                        Some(v) if v.status == AgentStatus::Running => Span::styled(
                            format!(
                                "run {run} · {}",
                                super::waiting_text(v).unwrap_or_else(|| "streaming…".to_string())
                            ),
                            t.warn,
                        ),
                        _ => match app.shown_run() {
                            Some(r) if !r.state.is_scored() => Span::styled(
                                format!(
                                    "run {run} · {}, {}, not scored",
                                    r.state.word(),
                                    if r.plan.is_empty() {
                                        "no plan"
                                    } else {
                                        "partial plan"
                                    }
                                ),
                                t.bad,
                            ),
                            _ => Span::styled(format!("run {run}"), t.muted),
                        },
                    },
                ),
                PlanSource::Published { approach, .. }
                    if !approach.uses_image() && app.work.task.table.is_none() =>
                {
                    Some(Span::styled(
                        format!(
                            "the paper's {} plan · a reference, no table file to run",
                            approach.name()
                        ),
                        t.warn,
                    ))
                }
                PlanSource::Published { approach, .. } => Some(Span::styled(
                    format!("published {}", approach.name()),
                    t.muted,
                )),
            };
            match app.unfinished_latest() {
                Some(r) => {
                    let before = shown.map_or(String::new(), |s| format!("{} · ", s.content));
                    Some(Span::styled(
                        format!("{before}run {} {}", r.id, r.state_text()),
                        t.bad,
                    ))
                }
                None => shown,
            }
        }
        StepList::GroundTruth => Some(Span::styled(
            match &app.work.ground_truth_source {
                GroundTruthSource::Demo { index } => {
                    format!("demo annotator {}", if *index == 1 { 'B' } else { 'A' })
                }
                GroundTruthSource::Dataset { task } => task.clone(),
                GroundTruthSource::File { path } => path.display().to_string(),
                GroundTruthSource::Typed => "typed".to_string(),
            },
            t.muted,
        )),
    };
    let block = pane_block(app, pane, extra, area.width);
    let inner = block.inner(area);
    let items = &app.panes.steps(list).items;
    if items.is_empty() {
        let hint = match list {
            StepList::Plan => {
                "No plan yet: r runs the agents, p loads a published plan, o types one."
            }
            StepList::GroundTruth => "No ground truth: g chooses one, o types one.",
        };
        frame.render_widget(
            Paragraph::new(Span::styled(hint, t.muted))
                .wrap(Wrap { trim: true })
                .block(block),
            area,
        );
        return;
    }
    let viewport = usize::from(inner.height);
    let (wrapped, edited) = wrapped_steps(app, list, usize::from(inner.width));
    let view = Scroll::default().following(&wrapped, selected, viewport);
    scroll::render(frame, area, block, wrapped.lines(), view, t.accent);
    if let (Some((i, indent)), Editing::Step { editor, .. }) = (edited, &app.editing) {
        let row = wrapped.span(i).start;
        if (view.offset()..view.offset() + viewport).contains(&row) {
            let at = Rect {
                x: inner.x + indent as u16,
                y: inner.y + (row - view.offset()) as u16,
                width: inner.width.saturating_sub(indent as u16),
                height: 1,
            };
            frame.render_widget(editor, at);
        }
    }
}

/// The steps of `list` as the pane draws them at `width` columns, each
/// wrapped under its number and followed by its wrapped mark, and which
/// step is being edited (with the editor's indent): shared by drawing and
/// by the mouse, so a click lands on the step drawn where it is.
fn wrapped_steps(app: &Shared, list: StepList, width: usize) -> (Wrapped, Option<(usize, usize)>) {
    let t = app.theme;
    let steps = app.panes.steps(list);
    let pane = match list {
        StepList::Plan => Pane::Plan,
        StepList::GroundTruth => Pane::GroundTruth,
    };
    let mut edited = None;
    // Each step wrapped under its number, then its mark wrapped under its
    // indent: nothing is cut at the pane's edge.
    let wrapped = Wrapped::new(steps.items.iter().enumerate().map(|(i, step)| {
        let number = Span::styled(format!("{:>2}. ", i + 1), t.accent);
        let editing_this = matches!(&app.editing,
            Editing::Step { list: l, index, .. } if *l == list && *index == i);
        let mut lines = if editing_this {
            edited = Some((i, number.width()));
            vec![Line::from(number)]
        } else {
            let base = if i == steps.selected && app.focus == pane {
                t.selection
            } else {
                t.base
            };
            let body = highlighted(step, &app.panes.search, base, t.highlight);
            scroll::wrap_hanging(&[number], &body, width)
        };
        let mark = match list {
            StepList::Plan => plan_mark(app, i),
            StepList::GroundTruth => ground_truth_mark(app, i),
        };
        lines.extend(wrap_mark(mark, width));
        lines
    }));
    (wrapped, edited)
}

/// The step of `list` drawn on `row` (counted inside the frame) of a pane
/// drawn in `area`, if any.
pub(crate) fn step_at(app: &Shared, list: StepList, area: Rect, row: usize) -> Option<usize> {
    let (width, viewport) = (
        usize::from(area.width.saturating_sub(2)),
        usize::from(area.height.saturating_sub(2)),
    );
    let (wrapped, _) = wrapped_steps(app, list, width);
    let view = Scroll::default().following(&wrapped, app.panes.steps(list).selected, viewport);
    let line = view.offset() + row;
    (row < viewport && line < wrapped.total()).then(|| wrapped.item_at(line))
}

/// A step's mark wrapped to `width` under its own leading blanks, so a long
/// reason (`✗ unmatched: nearest GT 3 at cos 0.512 ≤ 0.6 · KAS 0.33 vs GT
/// 4`) goes on below instead of past the pane's edge.
fn wrap_mark(mark: Line<'static>, width: usize) -> Vec<Line<'static>> {
    let mut spans = mark.spans;
    let indent = spans
        .first()
        .map_or(0, |s| s.content.len() - s.content.trim_start().len());
    if let Some(first) = spans.first_mut() {
        first.content = first.content.trim_start().to_string().into();
    }
    scroll::wrap_hanging(&[Span::raw(" ".repeat(indent))], &spans, width)
}
