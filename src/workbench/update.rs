//! The update function: applies one message, routing keys through the key
//! table to the editor, overlay or pane that has them.

use crossterm::event::{KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Position, Rect};

use crate::plan::parse_steps;
use crate::workbench::app::{single_line_editor, App, Severity};
use crate::workbench::editing::Editing;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::layout::{pane_rects, Screen};
use crate::workbench::message::{Cmd, Msg};
use crate::workbench::overlays::actions::ActionsView;
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::steps::StepList;
use crate::workbench::panes::{list_window, Pane};
use crate::workbench::scoring::ModelSlot;
use crate::workbench::session::GroundTruthSource;

impl App {
    /// The top-level update: applies one message.
    pub fn update(&mut self, msg: Msg) -> Vec<Cmd> {
        match msg {
            Msg::Key(key) if key.kind != KeyEventKind::Release => self.on_key(key),
            Msg::Key(_) => Vec::new(),
            Msg::Mouse(mouse) => self.on_mouse(mouse),
            Msg::Resize(w, h) => {
                self.size = (w, h);
                Vec::new()
            }
            Msg::Paste(text) => self.on_paste(&text),
            Msg::Agent(run, event) => self.on_agent(run, event),
            Msg::Scored(outcome) => {
                self.on_scored(outcome);
                Vec::new()
            }
            Msg::SamplesScored(run, scores) => {
                self.on_samples_scored(run, scores);
                Vec::new()
            }
            Msg::ModelsProgress(line) => {
                self.models = ModelSlot::Loading(line);
                Vec::new()
            }
            Msg::ModelsLoaded(slot) => {
                self.models = slot;
                vec![self.rescore()]
            }
            Msg::StepFile(path, result) => match result {
                Ok(text) => {
                    let steps = parse_steps(&text);
                    if steps.is_empty() {
                        self.set_status(
                            format!(
                                "{}: no steps in this file; write one step a line",
                                path.display()
                            ),
                            Severity::Warn,
                        );
                        return Vec::new();
                    }
                    self.ground_truth.items = steps;
                    self.ground_truth_source = GroundTruthSource::File { path };
                    self.ground_truth.selected = 0;
                    vec![self.rescore()]
                }
                Err(e) => {
                    self.set_status(e.to_string(), Severity::Error);
                    Vec::new()
                }
            },
            Msg::SceneImage(result) => {
                match result {
                    Ok(img) => self.scene.image = Some(img),
                    Err(e) => self.image_status(e.to_string()),
                }
                self.scene.protocol = None;
                self.scene.requested = None;
                Vec::new()
            }
            Msg::Corrupted(result) => self.on_corrupted(result),
            Msg::PromptSetSaved(name, saved) => {
                self.on_prompt_set_saved(name, saved);
                Vec::new()
            }
            Msg::PromptSets(listed) => {
                self.on_prompt_sets(listed);
                Vec::new()
            }
            Msg::PromptSetLoaded(name, loaded) => {
                self.on_prompt_set_loaded(name, loaded);
                Vec::new()
            }
            Msg::ImageReady(rect, encoded) => {
                if self.scene.requested != Some(rect) {
                    // For an image or an area since replaced.
                    return Vec::new();
                }
                self.scene.requested = None;
                match encoded {
                    Ok(protocol) => self.scene.protocol = Some((rect, protocol)),
                    Err(e) => {
                        self.scene.enabled = false;
                        self.image_status(format!(
                            "the scene image cannot be drawn here ({e}); i tries again"
                        ));
                    }
                }
                Vec::new()
            }
            Msg::Saved(result) => {
                if let Err(e) = &result {
                    self.set_status(format!("session not saved: {e}"), Severity::Error);
                }
                self.saved = Some(result);
                Vec::new()
            }
            Msg::Quit => {
                self.quit = true;
                Vec::new()
            }
        }
    }

    pub(crate) fn on_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        if keymap::action(&[Context::Always], &key) == Some(Action::Quit) {
            self.quit = true;
            return Vec::new();
        }
        if !matches!(self.editing, Editing::None) {
            return self.on_editor_key(key);
        }
        if self.overlay.is_some() {
            return self.on_overlay_key(key);
        }
        self.on_command_key(key)
    }

    pub(crate) fn on_command_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let Some(action) = keymap::action(&self.pane_contexts(), &key) else {
            return Vec::new();
        };
        let list = match self.focus {
            Pane::Plan => StepList::Plan,
            _ => StepList::GroundTruth,
        };
        match action {
            Action::EditStep
            | Action::InsertAfter
            | Action::InsertBefore
            | Action::DeleteStep
            | Action::StepDown
            | Action::StepUp => return self.step_command(list, action),
            Action::Quit => self.quit = true,
            Action::NextPane => self.focus_step(1),
            Action::PreviousPane => self.focus_step(-1),
            Action::Help => self.overlay = Some(Overlay::Help),
            Action::Zoom => self.zoom = !self.zoom,
            Action::Escape => {
                if self.notice.is_some() {
                    self.notice = None;
                } else if self.zoom {
                    self.zoom = false;
                } else if !self.search.is_empty() {
                    self.search.clear();
                } else {
                    self.status = None;
                }
            }
            Action::Search => {
                self.editing = Editing::Search(single_line_editor(&self.search));
            }
            Action::NextHit => self.jump_to_search(),
            Action::Move(delta) => self.move_selection(self.focus, delta),
            Action::GraphEnter
            | Action::GraphBack
            | Action::GraphNode(_)
            | Action::GraphSelect(_)
            | Action::GraphStep(_)
            | Action::GraphZoom(_)
            | Action::GraphMode => self.graph.on_action(action),
            Action::PromptStep(step) => self.move_selection(Pane::Prompt, step),
            Action::EditPrompt => {
                self.prompt
                    .editor
                    .move_cursor(ratatui_textarea::CursorMove::Bottom);
                self.prompt
                    .editor
                    .move_cursor(ratatui_textarea::CursorMove::End);
                self.editing = Editing::Prompt;
            }
            Action::PromptOf(position) => {
                if let Some(&agent) = self.approach.roles().get(position) {
                    self.store_prompt_editor();
                    self.prompt.agent = agent;
                    self.load_prompt_editor();
                }
            }
            Action::Run => return self.start_run(false),
            Action::RunAll => return self.start_run(true),
            Action::CancelRun => return self.cancel_run(),
            Action::ChooseGroundTruth => self.open_ground_truth_picker(),
            Action::NextApproach => return self.cycle_approach(),
            Action::NextSamples => self.next_samples(),
            Action::PublishedPlan => {
                self.load_published_plan();
                if self.plan.items.is_empty() {
                    self.set_status(
                        format!("this task has no published {} plan", self.approach),
                        Severity::Info,
                    );
                }
                return vec![self.rescore()];
            }
            Action::ModelForm => self.open_model_form(),
            Action::SavePromptSet => self.open_save_prompt_set(),
            Action::LoadPromptSet => return self.list_prompt_sets(),
            Action::ToggleImage => {
                self.scene.enabled = !self.scene.enabled;
                self.session_dirty = true;
            }
            Action::NextTheme => {
                if !self.no_color && !self.themes.is_empty() {
                    let i = self
                        .themes
                        .iter()
                        .position(|t| t.name == self.theme.name)
                        .map_or(0, |i| (i + 1) % self.themes.len());
                    self.theme = self.themes[i].clone();
                    self.session_dirty = true;
                    self.set_status(format!("theme: {}", self.theme.name), Severity::Info);
                } else if self.no_color {
                    self.set_status("NO_COLOR is set: themes are off", Severity::Info);
                }
            }
            Action::Actions => {
                let view = ActionsView {
                    scores: self.scores.clone(),
                };
                self.overlay = Some(Overlay::Actions(Box::new(view)));
            }
            Action::Corrupt => self.open_corrupt_picker(),
            Action::History => self.open_runs(),
            Action::Accept
            | Action::Leave
            | Action::RunFromEditor
            | Action::NextField
            | Action::PreviousField
            | Action::EveryAgent
            | Action::MarkRun
            | Action::CompareRuns => {}
            // The annotation screen's actions: never bound in a pane.
            Action::Rate(_)
            | Action::Prefer(_)
            | Action::Label(_)
            | Action::ClearLabel
            | Action::WriteNote
            | Action::NextItem
            | Action::PreviousItem
            | Action::NextUnjudged
            | Action::SkipItem
            | Action::Undo => {}
        }
        Vec::new()
    }

    pub(crate) fn focus_step(&mut self, step: isize) {
        let n = Pane::ALL.len() as isize;
        let i = (self.focus.index() as isize + step).rem_euclid(n) as usize;
        self.focus = Pane::ALL[i];
    }

    pub(crate) fn move_selection(&mut self, pane: Pane, delta: isize) {
        let moved = |sel: usize, len: usize| -> usize {
            (sel as isize + delta).clamp(0, len.saturating_sub(1) as isize) as usize
        };
        match pane {
            Pane::Plan => self.plan.selected = moved(self.plan.selected, self.plan.items.len()),
            Pane::GroundTruth => {
                self.ground_truth.selected =
                    moved(self.ground_truth.selected, self.ground_truth.items.len())
            }
            Pane::Graph => self.graph.move_neighbour(delta),
            Pane::Prompt => {
                let shown = self.approach.roles();
                let idx = shown
                    .iter()
                    .position(|a| *a == self.prompt.agent)
                    .unwrap_or(0);
                let next = shown[moved(idx, shown.len())];
                if next != self.prompt.agent {
                    self.store_prompt_editor();
                    self.prompt.agent = next;
                    self.load_prompt_editor();
                }
            }
            Pane::Scene | Pane::Description | Pane::Scores => {
                let s = self.scroll.entry(pane).or_insert(0);
                *s = (i64::from(*s) + delta as i64).clamp(0, 500) as u16;
            }
        }
    }

    pub(crate) fn pane_at(&self, column: u16, row: u16) -> Option<(Pane, Rect)> {
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        match pane_rects(screen, self.focus, self.zoom) {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find(|(_, r)| r.contains(Position::new(column, row))),
            Screen::TooSmall => None,
        }
    }

    pub(crate) fn on_mouse(&mut self, mouse: MouseEvent) -> Vec<Cmd> {
        if self.overlay.is_some() || !matches!(self.editing, Editing::None) {
            if matches!(mouse.kind, MouseEventKind::Down(_))
                && matches!(self.overlay, Some(Overlay::Help))
            {
                self.overlay = None;
            }
            return Vec::new();
        }
        let Some((pane, rect)) = self.pane_at(mouse.column, mouse.row) else {
            return Vec::new();
        };
        match mouse.kind {
            MouseEventKind::Down(MouseButton::Left) => {
                self.focus = pane;
                let row = mouse.row.saturating_sub(rect.y + 1) as usize;
                let height = rect.height.saturating_sub(2) as usize;
                match pane {
                    Pane::Plan => {
                        let first =
                            list_window(self.plan.selected, self.plan.items.len(), 2, height).0;
                        let target = first + row / 2;
                        if target < self.plan.items.len() {
                            self.plan.selected = target;
                        }
                    }
                    Pane::GroundTruth => {
                        let first = list_window(
                            self.ground_truth.selected,
                            self.ground_truth.items.len(),
                            2,
                            height,
                        )
                        .0;
                        let target = first + row / 2;
                        if target < self.ground_truth.items.len() {
                            self.ground_truth.selected = target;
                        }
                    }
                    _ => {}
                }
            }
            MouseEventKind::ScrollDown => self.move_selection(pane, 1),
            MouseEventKind::ScrollUp => self.move_selection(pane, -1),
            _ => {}
        }
        Vec::new()
    }
}
