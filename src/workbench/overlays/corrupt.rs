//! The Plan pane's corruption picker (`c`): choose a kind, and the plan is
//! corrupted on a blocking task into a new run, which is scored at once so
//! the scores' reaction is seen.

use crossterm::event::KeyEvent;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;

use crate::corrupt::Kind;
use crate::workbench::app::App;
use crate::workbench::component::Component;
use crate::workbench::corrupting::{CorruptError, CorruptRequest, Corrupted};
use crate::workbench::keymap::{Action, Context};
use crate::workbench::message::Cmd;
use crate::workbench::overlays::{centred, moved, themed_box, Overlay, Picked};
use crate::workbench::session::{CorruptedFrom, PlanSource, RunRecord, RunState};
use crate::workbench::shared::{unix_now, Severity};
use crate::workbench::theme::Theme;

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

impl App {
    /// Opens the corruption picker, if there is a plan to corrupt.
    pub(crate) fn open_corrupt_picker(&mut self) {
        if self.panes.plan.items.is_empty() {
            self.set_status("the plan is empty: nothing to corrupt", Severity::Info);
        } else if self.runs.active.is_some() {
            self.set_status("a run is in flight: x cancels it", Severity::Warn);
        } else {
            self.overlay = Some(Overlay::CorruptPicker(CorruptPicker::default()));
        }
    }

    /// The kind the corruption picker chose: asks for the plan corrupted
    /// with it.
    pub(crate) fn corrupt_with(&mut self, kind: Kind) -> Vec<Cmd> {
        vec![Cmd::Corrupt(self.corrupt_request(kind))]
    }

    /// The request for corrupting the plan with `kind` into the next run,
    /// seeded by the number of runs so far.
    fn corrupt_request(&mut self, kind: Kind) -> CorruptRequest {
        let field = self.work.approach.dataset_field();
        let others = self
            .work
            .dataset
            .iter()
            .flat_map(|d| &d.tasks)
            .filter(|t| self.work.task.id.as_deref() != Some(t.id.as_str()))
            .map(|t| t.plans.get(field).unwrap_or(&t.ground_truth).clone())
            .collect();
        self.set_status(format!("corrupting the plan: {kind}…"), Severity::Info);
        CorruptRequest {
            run: self.runs.history.iter().map(|r| r.id).max().unwrap_or(0) + 1,
            kind,
            seed: self.runs.history.len() as u64,
            plan: self.panes.plan.items.clone(),
            others,
        }
    }

    /// A corruption finished: a new run with the corrupted plan, scored at
    /// once; or one line saying why not.
    pub(crate) fn on_corrupted(&mut self, result: Result<Corrupted, CorruptError>) -> Vec<Cmd> {
        let corrupted = match result {
            Ok(c) if c.source == self.panes.plan.items && self.runs.active.is_none() => c,
            Ok(_) => {
                self.set_status(
                    "the plan changed while it was being corrupted: c tries again",
                    Severity::Warn,
                );
                return Vec::new();
            }
            Err(reason) => {
                self.set_status(reason.to_string(), Severity::Warn);
                return Vec::new();
            }
        };
        let c = &corrupted.corruption;
        let words = c.words.as_ref().map_or_else(String::new, |w| {
            let similarity = c
                .similarity
                .map_or_else(String::new, |s| format!(", similarity {s:.2}"));
            format!(" ({} → {}{similarity})", w.from, w.to)
        });
        let status = format!(
            "run {}: {} of the plan{words}, {} step(s) edited",
            corrupted.run,
            c.kind,
            c.edits.len()
        );
        self.runs.history.push(RunRecord {
            id: corrupted.run,
            started_unix: unix_now(),
            approach: self.work.approach,
            task: self.work.task.text.clone(),
            agents: Vec::new(),
            prompts: Default::default(),
            plan: corrupted.plan.clone(),
            ground_truth: self.panes.ground_truth.items.clone(),
            scores: None,
            state: RunState::Finished,
            error: None,
            reason: None,
            corrupted: Some(CorruptedFrom {
                source: self.work.plan_source.clone(),
                corruption: corrupted.corruption,
            }),
            steps: Vec::new(),
            samples: Vec::new(),
        });
        self.panes.plan.items = corrupted.plan;
        self.panes.plan.selected = 0;
        self.work.plan_source = PlanSource::Run { run: corrupted.run };
        let cmd = self.rescore();
        self.runs.awaiting_scores = Some((self.runs.history.len() - 1, self.work.score_generation));
        self.set_status(status, Severity::Info);
        vec![cmd]
    }
}

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

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let lines: Vec<Line> = Kind::ALL
            .iter()
            .enumerate()
            .map(|(i, &kind)| {
                let chosen = i == self.selected;
                let style = if chosen { theme.selection } else { theme.base };
                Line::from(vec![
                    Span::styled(format!("{:<12}", kind.name()), style),
                    Span::styled(describe(kind), if chosen { style } else { theme.muted }),
                ])
            })
            .collect();
        let rect = centred(area, 80, lines.len() as u16 + 2);
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
