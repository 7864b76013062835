//! The update function: applies one message, routing keys through the key
//! table to the editor, overlay or pane that has them.

use crossterm::event::{KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Position, Rect};

use crate::agents::AgentRole;
use crate::plan::parse_steps;
use crate::workbench::app::App;
use crate::workbench::editing::Editing;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::layout::{pane_rects, Screen};
use crate::workbench::message::{Cmd, Msg};
use crate::workbench::overlays::actions::ActionsView;
use crate::workbench::overlays::help::Help;
use crate::workbench::overlays::log::MessageLog;
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::graph;
use crate::workbench::panes::steps::{self, StepList, StepsBefore};
use crate::workbench::panes::{self, Pane};
use crate::workbench::runs::FreshRun;
use crate::workbench::scoring::ModelSlot;
use crate::workbench::scroll::{Motion, WHEEL_LINES};
use crate::workbench::session::GroundTruthSource;
use crate::workbench::shared::{single_line_editor, Severity};

impl App {
    /// The top-level update: applies one message.
    pub fn update(&mut self, msg: Msg) -> Vec<Cmd> {
        match msg {
            Msg::Key(key) if key.kind != KeyEventKind::Release => self.on_key(key),
            Msg::Key(_) => Vec::new(),
            Msg::Mouse(mouse) => self.on_mouse(mouse),
            Msg::Resize(w, h) => {
                self.size = (w, h);
                if let Some(text) = self.overlay.as_mut().and_then(Overlay::scrolled_box) {
                    text.resize(Rect::new(0, 0, w, h));
                }
                Vec::new()
            }
            Msg::Paste(text) => self.on_paste(&text),
            Msg::Agent(run, event) => self.on_agent(run, event),
            Msg::Scored(outcome) => {
                self.on_scored(outcome);
                Vec::new()
            }
            Msg::FreshRunPriced(priced) => self.on_fresh_run_priced(priced),
            Msg::SamplesScored(run, scores) => {
                self.on_samples_scored(run, scores);
                Vec::new()
            }
            Msg::ModelsProgress(line) => {
                self.work.models = ModelSlot::Loading(line);
                Vec::new()
            }
            Msg::ModelsLoaded(slot) => {
                self.work.models = slot;
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
                    self.panes.ground_truth.items = steps;
                    self.work.ground_truth_source = GroundTruthSource::File { path };
                    self.panes.ground_truth.selected = 0;
                    vec![self.rescore()]
                }
                Err(e) => {
                    self.set_status(e.to_string(), Severity::Error);
                    Vec::new()
                }
            },
            Msg::Table(path, rendered) => {
                // A table read for a task since left is dropped.
                if self.work.task.table.as_ref() == Some(&path) {
                    self.panes.scene.table = Some((path, rendered));
                }
                Vec::new()
            }
            Msg::SceneImage(result) => {
                match result {
                    Ok(img) => self.panes.scene.image = Some(img),
                    Err(e) => self.image_status(e.to_string()),
                }
                self.panes.scene.protocol = None;
                self.panes.scene.requested = None;
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
                if self.panes.scene.requested != Some(rect) {
                    // For an image or an area since replaced.
                    return Vec::new();
                }
                self.panes.scene.requested = None;
                match encoded {
                    Ok(protocol) => self.panes.scene.protocol = Some((rect, protocol)),
                    Err(e) => {
                        self.panes.scene.enabled = false;
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
                self.saving.saved = Some(result);
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
        if self.too_small() {
            // Nothing is drawn but the request to enlarge the window: only
            // the key it names acts, so nothing changes unseen.
            if keymap::action(&self.pane_contexts(), &key) == Some(Action::Quit) {
                self.quit = true;
            }
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
        // A priced `R` waits for the next key only: `R` sends it, any other
        // key keeps the cache (also while the price is still being made, so
        // that "pricing…" is not left on the status line).
        let fresh = std::mem::take(&mut self.runs.fresh);
        if fresh != FreshRun::Idle && action != Action::RunAll {
            self.set_status("R: nothing sent, the cache kept", Severity::Info);
        }
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
            | Action::StepUp
            | Action::Undo => return self.step_command(list, action),
            Action::Quit => self.quit = true,
            Action::NextPane => self.focus_step(1),
            Action::PreviousPane => self.focus_step(-1),
            Action::Help => {
                let screen = Rect::new(0, 0, self.size.0, self.size.1);
                self.overlay = Some(Overlay::Help(Help::new(screen)));
            }
            Action::Zoom => self.panes.zoom = !self.panes.zoom,
            Action::Escape => {
                if self.messages.notice.is_some() {
                    self.messages.notice = None;
                } else if self.panes.zoom {
                    self.panes.zoom = false;
                } else if !self.panes.search.is_empty() {
                    self.panes.search.clear();
                } else {
                    self.messages.status = None;
                }
            }
            Action::Search => {
                self.editing = Editing::Search(single_line_editor(&self.panes.search));
            }
            Action::NextHit => self.jump_to_search(),
            Action::Move(delta) => self.move_selection(self.focus, delta),
            Action::GraphEnter
            | Action::GraphBack
            | Action::GraphNode(_)
            | Action::GraphSelect(_)
            | Action::GraphStep(_)
            | Action::GraphZoom(_)
            | Action::GraphMode => {
                let body = self.pane_rect(Pane::Graph).map(graph::body);
                self.panes.graph.on_action(action, body.unwrap_or_default());
            }
            Action::GraphList => {
                self.panes.graph.toggle_list(self.focus == Pane::Graph);
                self.focus = Pane::Graph;
            }
            Action::PromptStep(step) => self.step_prompt_agent(step),
            Action::EditPrompt => {
                self.panes
                    .prompt
                    .editor
                    .move_cursor(ratatui_textarea::CursorMove::Bottom);
                self.panes
                    .prompt
                    .editor
                    .move_cursor(ratatui_textarea::CursorMove::End);
                self.editing = Editing::Prompt;
            }
            Action::PromptOf(position) => {
                if let Some(&agent) = self.work.approach.roles().get(position) {
                    self.show_prompt_of(agent);
                }
            }
            Action::Run => return self.start_run(false),
            Action::RunAll => match fresh {
                FreshRun::Confirm => return self.start_run(true),
                FreshRun::Pricing => self.runs.fresh = FreshRun::Pricing,
                FreshRun::Idle => return self.price_fresh_run(),
            },
            Action::CancelRun => return self.cancel_run(),
            Action::ChooseGroundTruth => self.open_ground_truth_picker(),
            Action::NextApproach => return self.cycle_approach(),
            Action::NextSamples => self.next_samples(),
            Action::PublishedPlan => {
                self.load_published_plan();
                if self.panes.plan.items.is_empty() {
                    self.set_status(
                        format!("this task has no published {} plan", self.work.approach),
                        Severity::Info,
                    );
                }
                return vec![self.rescore()];
            }
            Action::ModelForm => self.open_model_form(),
            Action::SavePromptSet => self.open_save_prompt_set(),
            Action::LoadPromptSet => return self.list_prompt_sets(),
            Action::ToggleImage => {
                self.panes.scene.enabled = !self.panes.scene.enabled;
                self.saving.session_dirty = true;
            }
            Action::NextTheme => {
                if !self.looks.no_color && !self.looks.themes.is_empty() {
                    let i = self
                        .looks
                        .themes
                        .iter()
                        .position(|t| t.name == self.looks.theme.name)
                        .map_or(0, |i| (i + 1) % self.looks.themes.len());
                    let background = self.looks.theme.picture_background();
                    self.looks.theme = self.looks.themes[i].clone();
                    if self.looks.theme.picture_background() != background {
                        // Encoded again, padded with the new background.
                        self.panes.scene.protocol = None;
                        self.panes.scene.requested = None;
                    }
                    self.saving.kept.theme = None;
                    self.saving.session_dirty = true;
                    self.set_status(format!("theme: {}", self.looks.theme.name), Severity::Info);
                } else if self.looks.no_color {
                    self.set_status("NO_COLOR is set: themes are off", Severity::Info);
                }
            }
            Action::Actions => {
                let screen = Rect::new(0, 0, self.size.0, self.size.1);
                let view = ActionsView::new(self.work.scores.clone(), screen);
                self.overlay = Some(Overlay::Actions(Box::new(view)));
            }
            Action::Corrupt => self.open_corrupt_picker(),
            Action::History => self.open_runs(),
            Action::Messages => {
                let screen = Rect::new(0, 0, self.size.0, self.size.1);
                self.overlay = Some(Overlay::Log(Box::new(MessageLog::new(
                    &self.messages.log,
                    screen,
                ))));
            }
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
            | Action::SkipItem => {}
        }
        Vec::new()
    }

    /// Opens the step editor on `list` (see [`Steps::open_edit`]).
    pub(crate) fn edit_step(&mut self, list: StepList, insert: Option<usize>) -> Vec<Cmd> {
        let steps = self.panes.steps_mut(list);
        let (index, inserted) = steps.open_edit(insert);
        let editor = single_line_editor(&steps.items[index]);
        self.editing = Editing::Step {
            list,
            index,
            editor,
            inserted,
        };
        Vec::new()
    }

    /// A key of the Steps context on `list`.
    pub(crate) fn step_command(&mut self, list: StepList, action: Action) -> Vec<Cmd> {
        let steps = self.panes.steps(list);
        let (sel, len) = (steps.selected, steps.len());
        match action {
            Action::EditStep => self.edit_step(list, None),
            Action::InsertAfter => self.edit_step(list, Some(sel + usize::from(len > 0))),
            Action::InsertBefore => self.edit_step(list, Some(sel)),
            Action::Undo => self.undo_step_edit(),
            _ => {
                let before = self.steps_before(list);
                if !self.panes.steps_mut(list).rearrange(action) {
                    return Vec::new();
                }
                self.panes.undo.push(before);
                vec![self.rescore()]
            }
        }
    }

    /// The list `list` as it is now, for [`StepUndo`] to keep before an edit.
    pub(crate) fn steps_before(&self, list: StepList) -> StepsBefore {
        StepsBefore {
            list,
            steps: self.panes.steps(list).clone(),
            plan_source: self.work.plan_source.clone(),
            ground_truth_source: self.work.ground_truth_source.clone(),
        }
    }

    /// `u`: puts back the step list the newest edit changed, with where
    /// its steps came from.
    fn undo_step_edit(&mut self) -> Vec<Cmd> {
        let Some(before) = self.panes.undo.pop() else {
            self.set_status("no step edit to undo", Severity::Info);
            return Vec::new();
        };
        match before.list {
            StepList::Plan => self.work.plan_source = before.plan_source,
            StepList::GroundTruth => self.work.ground_truth_source = before.ground_truth_source,
        }
        *self.panes.steps_mut(before.list) = before.steps;
        self.set_status(
            format!("undone ({} more can be undone)", self.panes.undo.len()),
            Severity::Info,
        );
        vec![self.rescore()]
    }

    pub(crate) fn focus_step(&mut self, step: isize) {
        let n = Pane::ALL.len() as isize;
        let i = (self.focus.index() as isize + step).rem_euclid(n) as usize;
        self.focus = Pane::ALL[i];
    }

    /// Shows the prompt of the next (`step` > 0) or previous agent of the
    /// approach, from its top.
    fn step_prompt_agent(&mut self, step: isize) {
        let shown = self.work.approach.roles();
        let idx = shown
            .iter()
            .position(|a| *a == self.panes.prompt.agent)
            .unwrap_or(0);
        let to = (idx as isize + step).clamp(0, shown.len().saturating_sub(1) as isize) as usize;
        self.show_prompt_of(shown[to]);
    }

    /// Shows `agent`'s prompt in the Prompt pane, from its top.
    fn show_prompt_of(&mut self, agent: AgentRole) {
        if agent != self.panes.prompt.agent {
            self.panes.prompt.store_editor(self.work.approach);
            self.panes.prompt.agent = agent;
            self.panes.prompt.load_editor(self.work.approach);
            self.panes.scroll.remove(&Pane::Prompt);
        }
    }

    pub(crate) fn move_selection(&mut self, pane: Pane, delta: isize) {
        let moved = |sel: usize, len: usize| -> usize {
            (sel as isize + delta).clamp(0, len.saturating_sub(1) as isize) as usize
        };
        match pane {
            Pane::Plan => {
                self.panes.plan.selected =
                    moved(self.panes.plan.selected, self.panes.plan.items.len())
            }
            Pane::GroundTruth => {
                self.panes.ground_truth.selected = moved(
                    self.panes.ground_truth.selected,
                    self.panes.ground_truth.items.len(),
                )
            }
            Pane::Graph => {
                let body = self.pane_rect(pane).map(graph::body);
                self.panes.graph.on_move(delta, body.unwrap_or_default());
            }
            Pane::Scene | Pane::Description | Pane::Scores | Pane::Prompt => {
                // A text pane scrolls within its text where its length is
                // known (drawn where it is now), so the way back is never
                // longer than the way there.
                let limit = self
                    .pane_rect(pane)
                    .map(|area| match pane {
                        Pane::Prompt => panes::prompt::scroll_limit(self, area),
                        Pane::Description => panes::description::scroll_limit(self, area),
                        Pane::Scene => panes::scene::scroll_limit(self, area),
                        _ => 500,
                    })
                    .unwrap_or(500);
                let s = self.panes.scroll.entry(pane).or_insert(0);
                *s = (i64::from(*s) + delta as i64).clamp(0, limit.min(500) as i64) as u16;
            }
        }
    }

    /// Where `pane` is drawn at the terminal's size now, if it is shown.
    fn pane_rect(&self, pane: Pane) -> Option<Rect> {
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        match pane_rects(screen, self.focus, self.panes.zoom) {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find_map(|(p, r)| (p == pane).then_some(r)),
            Screen::TooSmall => None,
        }
    }

    pub(crate) fn pane_at(&self, column: u16, row: u16) -> Option<(Pane, Rect)> {
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        match pane_rects(screen, self.focus, self.panes.zoom) {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find(|(_, r)| r.contains(Position::new(column, row))),
            Screen::TooSmall => None,
        }
    }

    /// Whether the terminal is below the smallest size the panes draw in.
    fn too_small(&self) -> bool {
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        pane_rects(screen, self.focus, self.panes.zoom) == Screen::TooSmall
    }

    pub(crate) fn on_mouse(&mut self, mouse: MouseEvent) -> Vec<Cmd> {
        if self.too_small() {
            return Vec::new();
        }
        if self.overlay.is_some() || !matches!(self.editing, Editing::None) {
            let wheel = match mouse.kind {
                MouseEventKind::ScrollDown => Some(Motion::Wheel(WHEEL_LINES)),
                MouseEventKind::ScrollUp => Some(Motion::Wheel(-WHEEL_LINES)),
                _ => None,
            };
            match (self.overlay.as_mut(), wheel) {
                (Some(overlay), Some(motion)) => {
                    if let Some(text) = overlay.scrolled_box() {
                        text.scroll_by(motion);
                    }
                }
                (Some(Overlay::Help(_)), None) if matches!(mouse.kind, MouseEventKind::Down(_)) => {
                    self.overlay = None
                }
                _ => {}
            }
            return Vec::new();
        }
        let Some((pane, rect)) = self.pane_at(mouse.column, mouse.row) else {
            return Vec::new();
        };
        if pane == Pane::Graph {
            if mouse.kind == MouseEventKind::Down(MouseButton::Left) {
                self.focus = pane;
            }
            self.panes.graph.on_mouse(mouse, graph::body(rect));
            return Vec::new();
        }
        match mouse.kind {
            MouseEventKind::Down(MouseButton::Left) => {
                self.focus = pane;
                let row = mouse.row.saturating_sub(rect.y + 1) as usize;
                let list = match pane {
                    Pane::Plan => Some(StepList::Plan),
                    Pane::GroundTruth => Some(StepList::GroundTruth),
                    _ => None,
                };
                if let Some(list) = list {
                    if let Some(target) = steps::step_at(self, list, rect, row) {
                        self.panes.steps_mut(list).selected = target;
                    }
                }
            }
            MouseEventKind::ScrollDown => self.move_selection(pane, 1),
            MouseEventKind::ScrollUp => self.move_selection(pane, -1),
            _ => {}
        }
        Vec::new()
    }
}
