//! The update function: applies one message, routing keys through the key
//! table to the editor, overlay or pane that has them.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use crossterm::event::{KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Position, Rect};
use ratatui_textarea::TextArea;

use crate::agents::config::AgentSettings;
use crate::agents::cost::Estimate;
use crate::agents::pipeline::AgentEvent;
use crate::agents::prompt_sets::PromptSetError;
use crate::agents::prompts::PromptSet;
use crate::agents::AgentRole;
use crate::corrupt::Kind;
use crate::plan::{bounded_steps, parse_steps};
use crate::workbench::agents::{prompt_texts, RunRequest};
use crate::workbench::app::App;
use crate::workbench::component::{self, Component, Input};
use crate::workbench::corrupting::{CorruptError, Corrupted};
use crate::workbench::editing::Editing;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::layout::Screen;
use crate::workbench::message::{Cmd, Msg};
use crate::workbench::overlays::actions::ActionsView;
use crate::workbench::overlays::corrupt::{
    corrupt_request, corrupted_run, corrupted_status, CorruptPicker,
};
use crate::workbench::overlays::help::Help;
use crate::workbench::overlays::log::MessageLog;
use crate::workbench::overlays::model_form::{agent_in_question, FormOutcome, ModelForm};
use crate::workbench::overlays::pickers::{GroundTruthChoice, GroundTruthPicker};
use crate::workbench::overlays::prompt_sets::{SetName, SetOutcome, SetPicker};
use crate::workbench::overlays::runs::{RunsOutcome, RunsOverlay};
use crate::workbench::overlays::{Overlay, Picked};
use crate::workbench::panes::graph;
use crate::workbench::panes::steps::{self, demo_ground_truth, StepList, StepsBefore};
use crate::workbench::panes::{self, Pane};
use crate::workbench::runs::{AgentChange, FreshRun, KeptPlan, SAMPLE_STEPS};
use crate::workbench::scoring::{ModelSlot, ScoreOutcome};
use crate::workbench::session::{GroundTruthSource, PlanSource, RunState, ScoreRecord};
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
            return self.on_overlay_input(Input::Key(key));
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
            Action::HalfPage(delta) => {
                let half = self
                    .pane_rect(self.focus)
                    .map_or(1, |r| (r.height.saturating_sub(2) / 2).max(1));
                self.move_selection(self.focus, delta.saturating_mul(half as isize));
            }
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
            sel.saturating_add_signed(delta).min(len.saturating_sub(1))
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
                let shared = self.shared();
                let limit = self
                    .pane_rect(pane)
                    .map(|area| match pane {
                        Pane::Prompt => panes::prompt::scroll_limit(&shared, area),
                        Pane::Description => panes::description::scroll_limit(&shared, area),
                        Pane::Scene => panes::scene::scroll_limit(&shared, area),
                        _ => panes::scores::scroll_limit(&shared, area),
                    })
                    .unwrap_or(0);
                let s = self.panes.scroll.entry(pane).or_insert(0);
                let to = usize::from(*s).saturating_add_signed(delta).min(limit);
                *s = u16::try_from(to).unwrap_or(u16::MAX);
            }
        }
    }

    /// Where `pane` is drawn at the terminal's size now, if it is shown.
    fn pane_rect(&self, pane: Pane) -> Option<Rect> {
        match self.screen_layout() {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find_map(|(p, r)| (p == pane).then_some(r)),
            Screen::TooSmall => None,
        }
    }

    pub(crate) fn pane_at(&self, column: u16, row: u16) -> Option<(Pane, Rect)> {
        match self.screen_layout() {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find(|(_, r)| r.contains(Position::new(column, row))),
            Screen::TooSmall => None,
        }
    }

    /// Whether the terminal is below the smallest size the panes draw in.
    fn too_small(&self) -> bool {
        self.screen_layout() == Screen::TooSmall
    }

    pub(crate) fn on_mouse(&mut self, mouse: MouseEvent) -> Vec<Cmd> {
        if self.too_small() {
            return Vec::new();
        }
        if self.overlay.is_some() {
            let screen = Rect::new(0, 0, self.size.0, self.size.1);
            return self.on_overlay_input(Input::Mouse(mouse, screen));
        }
        if !matches!(self.editing, Editing::None) {
            return Vec::new();
        }
        let click = mouse.kind == MouseEventKind::Down(MouseButton::Left);
        if let Screen::Panes {
            tabs: Some(tabs), ..
        } = self.screen_layout()
        {
            if click && tabs.contains(Position::new(mouse.column, mouse.row)) {
                if let Some(pane) = Pane::tab_at(tabs.x, mouse.column) {
                    self.focus = pane;
                }
                return Vec::new();
            }
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
                if pane == Pane::Prompt {
                    let shared = self.shared();
                    if let Some(agent) =
                        panes::prompt::agent_at(&shared, rect, mouse.column, mouse.row)
                    {
                        self.show_prompt_of(agent);
                    }
                }
                let row = mouse.row.saturating_sub(rect.y + 1) as usize;
                let list = match pane {
                    Pane::Plan => Some(StepList::Plan),
                    Pane::GroundTruth => Some(StepList::GroundTruth),
                    _ => None,
                };
                if let Some(list) = list {
                    if let Some(target) = steps::step_at(&self.shared(), list, rect, row) {
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

/// The editors: a key or a paste while one has the keyboard, and the search.
impl App {
    pub(crate) fn on_editor_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let action = keymap::action(&[self.editing.context()], &key);
        match std::mem::replace(&mut self.editing, Editing::None) {
            Editing::Step {
                list,
                index,
                mut editor,
                inserted,
            } => match action {
                Some(Action::Accept) => {
                    let text = editor.lines().join(" ");
                    let mut before = self.steps_before(list);
                    if inserted {
                        before.steps.items.remove(index);
                    }
                    self.panes.steps_mut(list).commit(index, &text);
                    if self.panes.steps(list).items != before.steps.items {
                        self.panes.undo.push(before);
                    }
                    if list == StepList::GroundTruth {
                        self.work.ground_truth_source = GroundTruthSource::Typed;
                    }
                    vec![self.rescore()]
                }
                Some(Action::Leave) => {
                    self.panes.steps_mut(list).discard(index, inserted);
                    vec![self.rescore()]
                }
                _ => {
                    if action == Some(Action::Undo) {
                        editor.undo();
                    } else {
                        editor.input(key);
                    }
                    self.editing = Editing::Step {
                        list,
                        index,
                        editor,
                        inserted,
                    };
                    vec![self.rescore()]
                }
            },
            Editing::Prompt => {
                if action == Some(Action::Leave) {
                    self.panes.prompt.store_editor(self.work.approach);
                    self.saving.session_dirty = true;
                    if let Some(note) = self.shared().provider_note() {
                        self.set_status(note, Severity::Warn);
                    }
                    return Vec::new();
                }
                if action == Some(Action::RunFromEditor) {
                    self.panes.prompt.store_editor(self.work.approach);
                    self.saving.session_dirty = true;
                    return self.start_run(false);
                }
                self.panes.prompt.editor.input(key);
                self.editing = Editing::Prompt;
                self.saving.session_dirty = true;
                Vec::new()
            }
            Editing::Search(mut editor) => {
                match action {
                    Some(Action::Leave) => self.panes.search.clear(),
                    Some(Action::Accept) => self.jump_to_search(),
                    _ => {
                        editor.input(key);
                        self.panes.search = editor.lines().join("");
                        self.editing = Editing::Search(editor);
                    }
                }
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    pub(crate) fn on_paste(&mut self, text: &str) -> Vec<Cmd> {
        let flat = text.replace(['\r', '\n'], " ");
        match &mut self.editing {
            Editing::Step { editor, .. } => {
                editor.insert_str(&flat);
                vec![self.rescore()]
            }
            Editing::Prompt => {
                self.panes.prompt.editor.insert_str(text);
                self.saving.session_dirty = true;
                Vec::new()
            }
            Editing::Search(editor) => {
                editor.insert_str(&flat);
                self.panes.search = editor.lines().join("");
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    /// Moves the focused list's selection to the next step holding the search.
    pub(crate) fn jump_to_search(&mut self) {
        if self.panes.search.is_empty() {
            return;
        }
        let list = match self.focus {
            Pane::GroundTruth => StepList::GroundTruth,
            _ => StepList::Plan,
        };
        let hit = self.panes.steps(list).next_hit(&self.panes.search);
        match hit {
            Some(i) => self.panes.steps_mut(list).selected = i,
            None => self.set_status(
                format!("no step holds “{}”", self.panes.search),
                Severity::Info,
            ),
        }
    }
}

/// The overlays: a key or the mouse while one is open, handed to it.
impl App {
    /// A key or the mouse while an overlay is open: a key looked up in the
    /// overlay's context, both handled by the overlay's component.
    pub(crate) fn on_overlay_input(&mut self, input: Input) -> Vec<Cmd> {
        let Some(overlay) = self.overlay.take() else {
            return Vec::new();
        };
        match overlay {
            Overlay::Help(help) => {
                let _ = self.pick(help, &input, Overlay::Help);
                Vec::new()
            }
            Overlay::Actions(view) => {
                // A viewer chooses nothing: it is put back or closed.
                let _ = self.pick(*view, &input, |v| Overlay::Actions(Box::new(v)));
                Vec::new()
            }
            Overlay::Log(view) => {
                let _ = self.pick(*view, &input, |v| Overlay::Log(Box::new(v)));
                Vec::new()
            }
            Overlay::GroundTruthPicker(picker) => {
                match self.pick(picker, &input, Overlay::GroundTruthPicker) {
                    Some(choice) => self.choose_ground_truth(choice),
                    None => Vec::new(),
                }
            }
            Overlay::CorruptPicker(picker) => {
                match self.pick(picker, &input, Overlay::CorruptPicker) {
                    Some(kind) => self.corrupt_with(kind),
                    None => Vec::new(),
                }
            }
            Overlay::StepFilePath(prompt) => {
                match self.pick(*prompt, &input, |p| Overlay::StepFilePath(Box::new(p))) {
                    Some(path) => vec![Cmd::ReadStepFile(path)],
                    None => Vec::new(),
                }
            }
            Overlay::ModelForm(form) => self.on_model_form_input(form, &input),
            Overlay::PromptSetName(prompt) => self.on_set_name_input(prompt, &input),
            Overlay::PromptSetPicker(picker) => self.on_set_picker_input(picker, &input),
            Overlay::Runs(mut view) => {
                let outcome = component::deliver(view.as_mut(), &input);
                self.on_runs_outcome(view, outcome)
            }
        }
    }

    /// Hands `input` to the open picker or prompt `overlay`: puts it back
    /// (made an [`Overlay`] by `reopen`) while it stays open, and returns
    /// what it chose.
    fn pick<C, T>(
        &mut self,
        mut overlay: C,
        input: &Input,
        reopen: impl FnOnce(C) -> Overlay,
    ) -> Option<T>
    where
        C: Component<Outcome = Picked<T>>,
    {
        match component::deliver(&mut overlay, input) {
            Picked::Open => {
                self.overlay = Some(reopen(overlay));
                None
            }
            Picked::Cancelled => None,
            Picked::Chosen(choice) => Some(choice),
        }
    }
}

/// The model form: opening it and what saving it changes.
impl App {
    /// A key of the open model form; the form closes when saved or cancelled.
    pub(crate) fn on_model_form_input(&mut self, mut form: ModelForm, input: &Input) -> Vec<Cmd> {
        match component::deliver(&mut form, input) {
            FormOutcome::Open => self.overlay = Some(Overlay::ModelForm(form)),
            FormOutcome::Cancelled => {}
            FormOutcome::Saved { agents, settings } => self.apply_settings(&agents, settings),
        }
        Vec::new()
    }

    fn apply_settings(&mut self, agents: &[AgentRole], settings: AgentSettings) {
        for agent in agents {
            if let Some(view) = self.runs.agents.get_mut(agent) {
                view.settings = settings.clone();
            }
        }
        self.saving.session_dirty = true;
        let who = match agents {
            [one] => one.label().to_string(),
            _ => "every agent".to_string(),
        };
        self.set_status(
            format!(
                "{who}: {} / {} (r runs what changed)",
                settings.provider, settings.model
            ),
            Severity::Info,
        );
    }

    /// Opens the model form for the agent in question
    /// ([`agent_in_question`]).
    pub(crate) fn open_model_form(&mut self) {
        let agent = agent_in_question(&self.messages, self.focus, self.panes.prompt.agent);
        if let Some(view) = self.runs.agents.get(&agent) {
            self.overlay = Some(Overlay::ModelForm(ModelForm::new(agent, &view.settings)));
        }
    }
}

/// The run history: opening it, keeping it current, and what it asks for.
impl App {
    /// Opens the run history, the latest run selected.
    pub(crate) fn open_runs(&mut self) {
        let view = RunsOverlay::new(&self.runs.history, &self.work.prices);
        self.overlay = Some(Overlay::Runs(Box::new(view)));
    }

    /// Gives an open run history the runs again, after one was added or scored.
    pub(crate) fn refresh_runs(&mut self) {
        if let Some(Overlay::Runs(view)) = &mut self.overlay {
            view.set_runs(&self.runs.history);
        }
    }

    /// Carries out what a key in the run history asked for.
    pub(crate) fn on_runs_outcome(
        &mut self,
        view: Box<RunsOverlay>,
        outcome: RunsOutcome,
    ) -> Vec<Cmd> {
        match outcome {
            RunsOutcome::Stay => self.overlay = Some(Overlay::Runs(view)),
            RunsOutcome::Close => {}
            RunsOutcome::Note(note) => {
                self.set_status(note, Severity::Info);
                self.overlay = Some(Overlay::Runs(view));
            }
            RunsOutcome::Load(index) => {
                if let Some(run) = self.runs.history.get(index) {
                    self.panes.plan.replace(run.plan.clone());
                    self.work.plan_source = PlanSource::Run { run: run.id };
                    let id = run.id;
                    self.set_status(format!("plan of run {id} loaded"), Severity::Info);
                    return vec![self.rescore()];
                }
            }
        }
        Vec::new()
    }
}

/// The prompt sets: saving the prompts as one, listing and loading them.
impl App {
    /// `S`: asks for the name to save the prompts under.
    pub(crate) fn open_save_prompt_set(&mut self) {
        self.overlay = Some(Overlay::PromptSetName(Box::new(SetName::new(
            &self.work.prompt_set,
        ))));
    }

    /// `L`: lists the saved sets, to choose one from.
    pub(crate) fn list_prompt_sets(&mut self) -> Vec<Cmd> {
        match self.work.prompt_sets.clone() {
            Some(root) => vec![Cmd::ListPromptSets(root)],
            None => {
                self.set_status(PromptSetError::NoFolder.to_string(), Severity::Warn);
                Vec::new()
            }
        }
    }

    /// A key of the open name prompt.
    fn on_set_name_input(&mut self, mut prompt: Box<SetName>, input: &Input) -> Vec<Cmd> {
        match component::deliver(prompt.as_mut(), input) {
            SetOutcome::Open => self.overlay = Some(Overlay::PromptSetName(prompt)),
            SetOutcome::Cancelled => {}
            SetOutcome::Chosen(name) => return self.save_prompt_set(name),
        }
        Vec::new()
    }

    /// A key of the open set picker.
    fn on_set_picker_input(&mut self, mut picker: SetPicker, input: &Input) -> Vec<Cmd> {
        match component::deliver(&mut picker, input) {
            SetOutcome::Open => self.overlay = Some(Overlay::PromptSetPicker(picker)),
            SetOutcome::Cancelled => {}
            SetOutcome::Chosen(name) => {
                if !picker.confirmed(&name, self.panes.prompt.has_unsaved_edits()) {
                    self.overlay = Some(Overlay::PromptSetPicker(picker));
                    return Vec::new();
                }
                if let Some(root) = self.work.prompt_sets.clone() {
                    return vec![Cmd::LoadPromptSet { root, name }];
                }
            }
        }
        Vec::new()
    }

    fn save_prompt_set(&mut self, name: String) -> Vec<Cmd> {
        let Some(root) = self.work.prompt_sets.clone() else {
            self.set_status(PromptSetError::NoFolder.to_string(), Severity::Warn);
            return Vec::new();
        };
        let set = PromptSet::load(None)
            .and_then(|set| set.with_texts(&self.panes.prompt.texts, "the workbench"));
        match set {
            Ok(set) => vec![Cmd::SavePromptSet { root, name, set }],
            Err(e) => {
                self.set_status(format!("prompt set {name} not saved: {e}"), Severity::Warn);
                Vec::new()
            }
        }
    }

    /// The sets saved so far arrived: a picker over them, or why not.
    pub(crate) fn on_prompt_sets(&mut self, listed: Result<Vec<String>, PromptSetError>) {
        match listed {
            Ok(names) if names.is_empty() => {
                let root = self.work.prompt_sets.clone().unwrap_or_default();
                self.set_status(
                    format!(
                        "no prompt set in {} yet: S in the Prompt pane saves one",
                        root.display()
                    ),
                    Severity::Info,
                );
            }
            Ok(names) => self.overlay = Some(Overlay::PromptSetPicker(SetPicker::new(names))),
            Err(e) => self.set_status(e.to_string(), Severity::Warn),
        }
    }

    /// A set was saved in `dir`, or why not.
    pub(crate) fn on_prompt_set_saved(
        &mut self,
        name: String,
        saved: Result<PathBuf, PromptSetError>,
    ) {
        match saved {
            Ok(dir) => {
                self.set_status(
                    format!(
                        "prompt set {name} saved in {} (eval --prompts that folder runs it)",
                        dir.display()
                    ),
                    Severity::Info,
                );
                self.work.prompt_set = name;
                self.panes.prompt.kept = self.panes.prompt.texts.clone();
            }
            Err(e) => self.set_status(format!("prompt set {name} not saved: {e}"), Severity::Error),
        }
    }

    /// A set was read: its templates replace the workbench's prompts.
    pub(crate) fn on_prompt_set_loaded(
        &mut self,
        name: String,
        loaded: Result<PromptSet, PromptSetError>,
    ) {
        match loaded {
            Ok(set) => {
                let texts: BTreeMap<String, String> = prompt_texts(&set);
                for (template, text) in texts {
                    self.panes.prompt.texts.insert(template, text);
                }
                self.panes.prompt.kept = self.panes.prompt.texts.clone();
                self.panes.prompt.load_editor(self.work.approach);
                self.saving.session_dirty = true;
                self.set_status(
                    format!("prompt set {name} loaded (r runs what changed)"),
                    Severity::Info,
                );
                self.work.prompt_set = name;
            }
            Err(e) => self.set_status(format!("prompt set {name} not loaded: {e}"), Severity::Warn),
        }
    }
}

/// The corruption picker (`c`) and the run a corruption makes.
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
        self.set_status(format!("corrupting the plan: {kind}…"), Severity::Info);
        let request = corrupt_request(kind, &self.work, &self.runs, &self.panes.plan.items);
        vec![Cmd::Corrupt(request)]
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
        let status = corrupted_status(&corrupted);
        let run = corrupted_run(corrupted, &self.work, &self.panes.ground_truth.items);
        self.panes.plan.items = run.plan.clone();
        self.panes.plan.selected = 0;
        self.work.plan_source = PlanSource::Run { run: run.id };
        self.runs.history.push(run);
        let cmd = self.rescore();
        self.runs.awaiting_scores = Some((self.runs.history.len() - 1, self.work.score_generation));
        self.set_status(status, Severity::Info);
        vec![cmd]
    }
}

/// The ground-truth picker: opening it and what it chose.
impl App {
    /// `g`: opens the ground-truth picker on the ground truth in use.
    pub(crate) fn open_ground_truth_picker(&mut self) {
        self.overlay = Some(Overlay::GroundTruthPicker(GroundTruthPicker::open(
            &self.work,
        )));
    }

    /// What the ground-truth picker chose: another ground truth, another
    /// source (a dataset task, the demo), a step file's path prompt, or an
    /// empty one to type.
    pub(crate) fn choose_ground_truth(&mut self, choice: GroundTruthChoice) -> Vec<Cmd> {
        self.overlay = None;
        match choice {
            GroundTruthChoice::Demo(_) if !self.is_demo() => return self.switch_source(None),
            GroundTruthChoice::Demo(index) => {
                self.panes.ground_truth.items = demo_ground_truth(index);
                self.work.ground_truth_source = GroundTruthSource::Demo { index };
            }
            GroundTruthChoice::Task(index) => {
                let Some(task) = self
                    .work
                    .dataset
                    .as_ref()
                    .and_then(|d| d.tasks.get(index))
                    .cloned()
                else {
                    return Vec::new();
                };
                if self.work.task.id.as_ref() != Some(&task.id) {
                    return self.switch_source(Some(&task));
                }
                self.panes.ground_truth.items = task.ground_truth.clone();
                self.work.ground_truth_source = GroundTruthSource::Dataset { task: task.id };
            }
            GroundTruthChoice::File => {
                self.overlay = Some(Overlay::StepFilePath(Box::default()));
                return Vec::new();
            }
            GroundTruthChoice::Typed => {
                self.panes.ground_truth.items = vec![String::new()];
                self.work.ground_truth_source = GroundTruthSource::Typed;
                self.focus = Pane::GroundTruth;
                self.editing = Editing::Step {
                    list: StepList::GroundTruth,
                    index: 0,
                    editor: TextArea::default(),
                    inserted: true,
                };
            }
        }
        self.panes.ground_truth.selected = 0;
        vec![self.rescore()]
    }
}

/// The runs: starting, pricing, the agents' events, finishing, cancelling
/// and scoring, carried on from [`Runs`]' answers to the panes.
impl App {
    /// `r` (`all` false: the agents whose inputs changed) or a run of
    /// every agent afresh that was priced and, if it costs anything,
    /// confirmed (see [`App::price_fresh_run`]).
    pub(crate) fn start_run(&mut self, all: bool) -> Vec<Cmd> {
        match self.run_request(all) {
            Some(request) => self.launch_run(request),
            None => Vec::new(),
        }
    }

    /// `R`: prices asking every agent afresh first; the answer
    /// ([`App::on_fresh_run_priced`]) starts the run, or asks for a second
    /// `R` when it costs something.
    pub(crate) fn price_fresh_run(&mut self) -> Vec<Cmd> {
        match self.run_request(true) {
            Some(request) => {
                self.runs.fresh = FreshRun::Pricing;
                self.set_status("R: pricing a run of every agent afresh…", Severity::Info);
                vec![Cmd::PriceFreshRun(request)]
            }
            None => Vec::new(),
        }
    }

    /// What asking every agent afresh would cost arrived: nothing to pay
    /// (every answer recorded, or free) starts the run; otherwise the
    /// estimate is shown and a second `R` sends it. Ignored when another
    /// key came between (the user moved on).
    pub(crate) fn on_fresh_run_priced(&mut self, priced: Result<Estimate, String>) -> Vec<Cmd> {
        if self.runs.fresh != FreshRun::Pricing {
            return Vec::new();
        }
        self.runs.fresh = FreshRun::Idle;
        let estimate = match priced {
            Ok(estimate) => estimate,
            // The run fails the same way, and says so where runs do.
            Err(_) => return self.start_run(true),
        };
        if estimate.usd <= 0.0 {
            let cmds = self.start_run(true);
            if let Some((text, _)) = self
                .messages
                .status
                .as_mut()
                .filter(|_| !cmds.is_empty() && !estimate.unpriced.is_empty())
            {
                let _ = write!(
                    text,
                    " · {} requests afresh{}",
                    estimate.requests,
                    estimate.unpriced_suffix()
                );
            }
            return cmds;
        }
        self.runs.fresh = FreshRun::Confirm;
        self.set_status(
            format!(
                "R asks every agent afresh, past the cache: {} requests, ~${:.4}{}; R again sends them, any other key keeps the cache",
                estimate.requests,
                estimate.usd,
                estimate.unpriced_suffix()
            ),
            Severity::Warn,
        );
        Vec::new()
    }

    /// The request of a run (`all`: every agent, afresh), or `None` with
    /// the reason on the status line.
    fn run_request(&mut self, all: bool) -> Option<RunRequest> {
        if self.runs.active.is_some() {
            self.set_status("a run is in flight: x cancels it", Severity::Warn);
            return None;
        }
        if !self.work.approach.uses_image() && self.work.task.table.is_none() {
            self.set_status(
                format!(
                    "the {} approach reads the task's environment table, and this task has none: give it a `table` file in tasks.jsonl, or press a for an image approach (the Plan pane shows the paper's plan as a reference)",
                    self.work.approach
                ),
                Severity::Warn,
            );
            return None;
        }
        if matches!(self.editing, Editing::Prompt) {
            self.panes.prompt.store_editor(self.work.approach);
        }
        // More samples than the last run asked for: every agent runs, its
        // earlier samples answered from the cache.
        let more_samples = self
            .runs
            .history
            .last()
            .is_some_and(|r| r.samples.len() as u32 + 1 < self.work.samples);
        let to_run = self.agents_to_run(all || more_samples);
        if to_run.is_empty() {
            self.set_status(
                "nothing changed since the last run: R re-runs every agent",
                Severity::Info,
            );
            return None;
        }
        let approach_agents = self.work.approach.roles();
        Some(RunRequest {
            run: self.runs.next_id(),
            approach: self.work.approach,
            task: self.work.task.text.clone(),
            agents: to_run,
            prompts: approach_agents
                .iter()
                .map(|a| (*a, self.prompt_of(*a)))
                .collect(),
            settings: approach_agents
                .iter()
                .filter_map(|a| self.runs.agents.get(a).map(|v| (*a, v.settings.clone())))
                .collect(),
            demo: self.is_demo(),
            image: self.work.task.image.clone(),
            table: self.work.task.table.clone(),
            samples: self.work.samples,
            fresh: all,
        })
    }

    /// Marks the request's agents waiting and the run in flight, keeping
    /// the plan it may replace, and asks for it to start.
    fn launch_run(&mut self, request: RunRequest) -> Vec<Cmd> {
        let kept = KeptPlan {
            items: self.panes.plan.items.clone(),
            source: self.work.plan_source.clone(),
            selected: self.panes.plan.selected,
        };
        self.runs.launch(request.run, &request.agents, kept);
        let names: Vec<&str> = request.agents.iter().map(|a| a.label()).collect();
        let samples = match self.work.samples {
            1 => String::new(),
            n => format!(" ({n} samples)"),
        };
        self.set_status(
            format!("run {}: {}{samples}", request.run, names.join(", ")),
            Severity::Info,
        );
        vec![Cmd::StartRun(request)]
    }

    /// Ends the run in flight and keeps its record: finished when every
    /// agent answered (then scored), else cancelled (`cancelled`) or
    /// failed, never scored, and the Plan pane gets back the plan it showed
    /// before the run.
    pub(crate) fn finish_run(&mut self, cancelled: bool) -> Vec<Cmd> {
        let context = self.run_context();
        let Some(ended) = self.runs.end(cancelled, &context) else {
            return Vec::new();
        };
        self.saving.session_dirty = true;
        let severity = match ended.state {
            RunState::Finished => Severity::Info,
            RunState::Failed => Severity::Error,
            _ => Severity::Warn,
        };
        let mut cmds = Vec::new();
        if ended.state.is_scored() {
            cmds.push(self.rescore());
            self.runs.awaiting_scores =
                Some((self.runs.history.len() - 1, self.work.score_generation));
            cmds.extend(self.runs.sample_scoring(ended.id).map(Cmd::ScoreSamples));
        } else {
            self.panes.plan.items = ended.kept.items;
            self.work.plan_source = ended.kept.source;
            self.panes.plan.selected = ended.kept.selected;
            cmds.push(self.rescore());
        }
        self.refresh_runs();
        self.set_status(ended.status, severity);
        cmds
    }

    /// Steps the number of samples `r` asks for through [`SAMPLE_STEPS`].
    pub(crate) fn next_samples(&mut self) {
        let next = SAMPLE_STEPS
            .iter()
            .find(|&&n| n > self.work.samples)
            .copied()
            .unwrap_or(SAMPLE_STEPS[0]);
        self.work.samples = next;
        self.saving.kept.samples = None;
        self.saving.session_dirty = true;
        self.set_status(
            format!("samples per run: {next} (r asks each agent {next} times)"),
            Severity::Info,
        );
    }

    /// An agent's event of run `run`: its view changes ([`Runs::on_event`]),
    /// and the graph, the plan and the run follow.
    pub(crate) fn on_agent(&mut self, run: u64, event: AgentEvent) -> Vec<Cmd> {
        if let AgentEvent::Sampled { record } = &event {
            if !self.runs.add_sample(run, record) {
                return Vec::new();
            }
            self.saving.session_dirty = true;
            self.refresh_runs();
            return self
                .runs
                .sample_scoring(run)
                .map(Cmd::ScoreSamples)
                .into_iter()
                .collect();
        }
        let prompt = match &event {
            AgentEvent::Finished { role, .. } => Some(self.prompt_of(*role)),
            _ => None,
        };
        match self.runs.on_event(run, event, prompt) {
            AgentChange::Nothing => Vec::new(),
            AgentChange::Started(agent) => {
                if agent == self.work.approach.planning_role() {
                    if matches!(
                        self.editing,
                        Editing::Step {
                            list: StepList::Plan,
                            ..
                        }
                    ) {
                        self.editing = Editing::None;
                    }
                    self.panes.plan.items.clear();
                    self.work.plan_source = PlanSource::Run { run };
                }
                Vec::new()
            }
            AgentChange::Retrying(text) => {
                self.set_status(text, Severity::Warn);
                Vec::new()
            }
            AgentChange::Output(agent) => match agent {
                AgentRole::Skm => {
                    self.refresh_graph();
                    Vec::new()
                }
                AgentRole::Planner | AgentRole::Single => {
                    self.panes.plan.items = bounded_steps(self.runs.output(agent)).0;
                    vec![self.rescore()]
                }
                AgentRole::Gkm => Vec::new(),
            },
            AgentChange::Finished { agent, all_done } => {
                self.saving.session_dirty = true;
                match agent {
                    AgentRole::Skm => self.refresh_graph(),
                    AgentRole::Planner | AgentRole::Single => {
                        self.panes.plan.items = bounded_steps(self.runs.output(agent)).0;
                        self.panes.plan.selected = 0;
                    }
                    AgentRole::Gkm => {}
                }
                if all_done {
                    return self.finish_run(false);
                }
                Vec::new()
            }
            AgentChange::Failed => {
                let mut cmds = vec![Cmd::CancelRun(run)];
                cmds.extend(self.finish_run(false));
                cmds
            }
        }
    }

    /// `x`: cancels the run in flight.
    pub(crate) fn cancel_run(&mut self) -> Vec<Cmd> {
        let Some(id) = self.runs.active.as_ref().map(|r| r.id) else {
            self.set_status("no run in flight", Severity::Info);
            return Vec::new();
        };
        let mut cmds = vec![Cmd::CancelRun(id)];
        cmds.extend(self.finish_run(true));
        cmds
    }

    /// Scores arrived: the latest are shown, and a finished run that
    /// awaited them keeps them.
    pub(crate) fn on_scored(&mut self, outcome: ScoreOutcome) {
        if outcome.generation > self.work.score_generation {
            return;
        }
        if self.runs.scored(&outcome) {
            self.refresh_runs();
            self.saving.session_dirty = true;
        }
        if self
            .work
            .scores
            .as_ref()
            .is_none_or(|s| s.generation <= outcome.generation)
        {
            if let Some(Overlay::Actions(view)) = &mut self.overlay {
                view.scores = Some(outcome.clone());
            }
            self.work.scores = Some(outcome);
        }
    }

    /// The later samples of run `run` were scored.
    pub(crate) fn on_samples_scored(&mut self, run: u64, scores: Vec<(u32, ScoreRecord)>) {
        if self.runs.samples_scored(run, scores) {
            self.saving.session_dirty = true;
            self.refresh_runs();
        }
    }
}
