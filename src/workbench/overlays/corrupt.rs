//! The Plan pane's corruption picker (`c`): choose a kind, and the plan is
//! corrupted on a blocking task into a new run, which is scored at once so
//! the scores' reaction is seen.

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;

use crate::corrupt::Kind;
use crate::workbench::component::Component;
use crate::workbench::corrupting::{CorruptRequest, Corrupted};
use crate::workbench::keymap::{Action, Context};
use crate::workbench::overlays::{list_box, list_mouse, moved, themed_box, Picked};
use crate::workbench::runs::Runs;
use crate::workbench::session::{CorruptedFrom, RunRecord, RunState};
use crate::workbench::shared::unix_now;
use crate::workbench::theme::Theme;
use crate::workbench::workspace::Workspace;

/// What each kind does, as the picker says it.
fn describe(kind: Kind) -> &'static str {
    match kind {
        Kind::ObjectSwap => "an object becomes another household object, in every step",
        Kind::PlaceSwap => "a place or receptacle becomes another one, in every step",
        Kind::VerbSwap => "a step's action becomes its opposite or a wrong one",
        Kind::Reorder => "two different steps trade places",
        Kind::Drop => "one step is removed",
        Kind::Duplicate => "one step is repeated",
        Kind::Insert => "a step of another task's plan is inserted",
        Kind::Truncate => "the plan stops after half its steps",
    }
}

/// The request for corrupting `plan` with `kind` into the next run,
/// seeded by the number of runs so far; an inserted step comes from the
/// other tasks' plans for the approach (their ground truth where they have
/// none).
pub fn corrupt_request(
    kind: Kind,
    work: &Workspace,
    runs: &Runs,
    plan: &[String],
) -> CorruptRequest {
    let field = work.approach.dataset_field();
    let others = work
        .dataset
        .iter()
        .flat_map(|d| &d.tasks)
        .filter(|t| work.task.id.as_deref() != Some(t.id.as_str()))
        .map(|t| t.plans.get(field).unwrap_or(&t.ground_truth).clone())
        .collect();
    CorruptRequest {
        run: runs.next_id(),
        kind,
        seed: runs.history.len() as u64,
        plan: plan.to_vec(),
        others,
    }
}

/// What the status line says of a corruption: the run, the kind, the words
/// swapped and how many steps changed.
pub fn corrupted_status(corrupted: &Corrupted) -> String {
    let c = &corrupted.corruption;
    let words = c.words.as_ref().map_or_else(String::new, |w| {
        let similarity = c
            .similarity
            .map_or_else(String::new, |s| format!(", similarity {s:.2}"));
        format!(" ({} → {}{similarity})", w.from, w.to)
    });
    format!(
        "run {}: {} of the plan{words}, {} step(s) edited",
        corrupted.run,
        c.kind,
        c.edits.len()
    )
}

/// The run a corruption makes of the plan shown (from `work`'s plan
/// source), finished and waiting for its scores against `ground_truth`.
pub fn corrupted_run(corrupted: Corrupted, work: &Workspace, ground_truth: &[String]) -> RunRecord {
    RunRecord {
        id: corrupted.run,
        started_unix: unix_now(),
        approach: work.approach,
        task: work.task.text.clone(),
        agents: Vec::new(),
        prompts: Default::default(),
        plan: corrupted.plan,
        ground_truth: ground_truth.to_vec(),
        scores: None,
        state: RunState::Finished,
        error: None,
        reason: None,
        corrupted: Some(CorruptedFrom {
            source: work.plan_source.clone(),
            corruption: corrupted.corruption,
        }),
        steps: Vec::new(),
        samples: Vec::new(),
    }
}

/// How wide the corruption picker's box is.
const PICKER_WIDTH: u16 = 80;

/// The corruption picker (`c`): every kind and what it does, one
/// highlighted.
#[derive(Debug, Clone, Default)]
pub struct CorruptPicker {
    selected: usize,
}

impl Component for CorruptPicker {
    type Outcome = Picked<Kind>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Picker]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Accept => Kind::ALL
                .get(self.selected)
                .map_or(Picked::Cancelled, |&kind| Picked::Chosen(kind)),
            Action::Leave => Picked::Cancelled,
            Action::Move(delta) => {
                self.selected = moved(self.selected, delta, Kind::ALL.len());
                Picked::Open
            }
            _ => Picked::Open,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Self::Outcome {
        Picked::Open
    }

    /// A click selects a row, a click on the selected row chooses it, the
    /// wheel moves the selection.
    fn on_mouse(&mut self, mouse: MouseEvent, area: Rect) -> Self::Outcome {
        let (selected, action) =
            list_mouse(&mouse, area, PICKER_WIDTH, Kind::ALL.len(), self.selected);
        self.selected = selected;
        self.on_action(action)
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (rect, first, count) = list_box(area, PICKER_WIDTH, Kind::ALL.len(), self.selected);
        let lines: Vec<Line> = Kind::ALL
            .iter()
            .enumerate()
            .skip(first)
            .take(count)
            .map(|(i, &kind)| {
                let chosen = i == self.selected;
                let style = if chosen { theme.selection } else { theme.base };
                Line::from(vec![
                    Span::styled(format!("{:<12}", kind.name()), style),
                    Span::styled(describe(kind), if chosen { style } else { theme.muted }),
                ])
            })
            .collect();
        frame.render_widget(Clear, rect);
        frame.render_widget(
            Paragraph::new(lines).block(themed_box(theme, "Corrupt the plan into a new run")),
            rect,
        );
    }
}

#[cfg(test)]
mod tests {
    use crossterm::event::{KeyCode, KeyModifiers};

    use super::*;
    use crate::workbench::component::dispatch;

    #[test]
    fn the_corrupt_picker_offers_every_kind_and_stops_at_the_last() {
        let mut picker = CorruptPicker::default();
        let down = KeyEvent::new(KeyCode::Char('j'), KeyModifiers::NONE);
        for _ in 0..Kind::ALL.len() + 2 {
            assert_eq!(dispatch(&mut picker, &down), Picked::Open);
        }
        let enter = KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE);
        assert_eq!(
            dispatch(&mut picker, &enter),
            Picked::Chosen(Kind::ALL[Kind::ALL.len() - 1])
        );
    }
}
