//! The workbench's state ([`App`]) and how it starts ([`AppInit`]): the
//! Elm architecture's model. The panes and overlays keep their own parts
//! (see [`crate::workbench::panes`], [`crate::workbench::overlays`]); the
//! update function is in [`crate::workbench::update`].

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use image::DynamicImage;
use ratatui::layout::Rect;

use crate::agents::config::AgentSettings;
use crate::agents::cost::PriceTable;
use crate::agents::prompts::template_name;
use crate::agents::{AgentRole, Approach, ProviderKind};
use crate::dataset::{Dataset, Task};
use crate::demo;
use crate::workbench::agents::{self, RunError};
use crate::workbench::editing::Editing;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::layout::{pane_rects_with, Screen};
use crate::workbench::message::Cmd;
use crate::workbench::overlays::pickers::{ground_truth_choices, GroundTruthChoice};
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::graph::GraphPane;
use crate::workbench::panes::prompt::PromptPane;
use crate::workbench::panes::scene::{scene_image_area, ScenePane};
use crate::workbench::panes::steps::{demo_ground_truth, StepList, StepUndo, Steps};
use crate::workbench::panes::{Pane, Panes, Shared};
use crate::workbench::persist::Persist;
use crate::workbench::runs::{fresh_agents, AgentStatus, AgentView, RunContext, Runs};
use crate::workbench::scene_image::ImageRequest;
use crate::workbench::scoring::{ModelSlot, ScoreRequest};
use crate::workbench::scroll::text_width;
use crate::workbench::session::{
    Draft, GroundTruthSource, PlanSource, RunState, Session, SourceState, SESSION_VERSION,
};
use crate::workbench::shared::{single_line_editor, LogEntry, Severity, LOG_MAX};
use crate::workbench::snapshot::Snapshot;
use crate::workbench::theme::Theme;
use crate::workbench::workspace::{demo_task, task_view, Kept, Looks, Messages, Saving, Workspace};

/// The order the approaches cycle in.
const APPROACH_CYCLE: [Approach; 4] = [
    Approach::MultiImage,
    Approach::SingleImage,
    Approach::MultiTable,
    Approach::SingleTable,
];

/// What the workbench starts from.
pub struct AppInit {
    /// The dataset, when one was given.
    pub dataset: Option<Dataset>,
    /// The themes available (at least one).
    pub themes: Vec<Theme>,
    /// The theme to start with, by name (`--theme`): it wins over the
    /// session's for this start, which the session keeps.
    pub theme: Option<String>,
    /// How many samples `r` asks for (`--samples`): wins over the session's
    /// for this start, which the session keeps.
    pub samples: Option<u32>,
    /// Whether `NO_COLOR` is in force.
    pub no_color: bool,
    /// Whether the locale cannot show UTF-8 (`LANG=C`): every frame is
    /// folded to ASCII.
    pub ascii: bool,
    /// The session to restore.
    pub session: Option<Session>,
    /// A message to show first.
    pub notice: Option<(String, Severity)>,
    /// The terminal's size.
    pub size: (u16, u16),
    /// Whether the PG2S models are known to be loading.
    pub models: ModelSlot,
    /// The prompt templates' texts by name: the built-in ones, or the
    /// user's where the user folder has one ([`agents::prompt_texts`]).
    pub prompts: BTreeMap<String, String>,
    /// The settings of the agents the config file and the environment
    /// configure ([`agents::ProviderConfig::configured_agents`]): on a
    /// user's task they start on these, the others on the demo's recording.
    pub configured: BTreeMap<AgentRole, AgentSettings>,
    /// The folder of the named prompt sets
    /// ([`crate::agents::prompt_sets::default_root`]); `None` when there is
    /// no config folder.
    pub prompt_sets: Option<PathBuf>,
}

impl AppInit {
    /// A start on the built-in demo with the built-in themes, no dataset,
    /// no session and the PG2S models reported missing for `reason`.
    pub fn demo(size: (u16, u16), reason: &str) -> AppInit {
        AppInit {
            dataset: None,
            themes: super::theme::load_themes(None).0,
            theme: None,
            samples: None,
            no_color: false,
            ascii: false,
            session: None,
            notice: None,
            size,
            models: ModelSlot::Unavailable(reason.to_string()),
            prompts: crate::agents::prompts::PromptSet::load(None)
                .map(|set| agents::prompt_texts(&set))
                .unwrap_or_default(),
            configured: BTreeMap::new(),
            prompt_sets: None,
        }
    }
}

/// The whole state of the workbench: the session's data, the focus and the
/// parts the screen is made of, each group in a struct of its own.
pub struct App {
    /// The terminal's size.
    pub size: (u16, u16),
    /// The focused pane.
    pub focus: Pane,
    /// A modal view, if open.
    pub overlay: Option<Overlay>,
    /// An editor, if in use.
    pub editing: Editing,
    /// The agents and the runs.
    pub runs: Runs,
    /// The task, the approach and where the plans came from.
    pub work: Workspace,
    /// The panes' own state.
    pub panes: Panes,
    /// How the workbench looks.
    pub looks: Looks,
    /// The status line's messages.
    pub messages: Messages,
    /// The session file's side: what changed, the copies, the last save.
    pub saving: Saving,
    /// Set when the user asked to quit.
    pub quit: bool,
}

impl App {
    /// A workbench in its starting state, with the commands that start it:
    /// the demo run on a fresh start, and the first scoring.
    pub fn new(init: AppInit) -> (App, Vec<Cmd>) {
        let flagged_theme = init
            .theme
            .as_deref()
            .and_then(|name| init.themes.iter().find(|t| t.name == name))
            .cloned();
        let theme = if init.no_color {
            Theme::no_color()
        } else {
            flagged_theme
                .clone()
                .or_else(|| init.themes.first().cloned())
                .unwrap_or_else(Theme::no_color)
        };
        let mut app = App {
            size: init.size,
            focus: Pane::Plan,
            overlay: None,
            editing: Editing::None,
            runs: Runs::new(),
            work: Workspace {
                task: demo_task(),
                dataset: init.dataset,
                approach: Approach::MultiImage,
                samples: 1,
                configured: init.configured,
                prices: PriceTable::default(),
                prompt_sets: init.prompt_sets,
                prompt_set: String::new(),
                plan_source: PlanSource::None,
                ground_truth_source: GroundTruthSource::Demo { index: 0 },
                scores: None,
                score_generation: 0,
                models: init.models,
                parked: Vec::new(),
            },
            panes: Panes {
                zoom: false,
                prompt: PromptPane::new(init.prompts),
                plan: Steps::default(),
                ground_truth: Steps::new(demo_ground_truth(0)),
                graph: GraphPane::default(),
                scene: ScenePane::demo(),
                scroll: BTreeMap::new(),
                search: String::new(),
                undo: StepUndo::default(),
                parked_undo: BTreeMap::new(),
            },
            looks: Looks {
                theme,
                themes: init.themes,
                no_color: init.no_color,
                ascii: init.ascii,
            },
            messages: Messages {
                status: None,
                log: init
                    .notice
                    .iter()
                    .map(|(text, severity)| LogEntry {
                        at: std::time::Duration::ZERO,
                        text: text.clone(),
                        severity: *severity,
                    })
                    .collect(),
                notice: init.notice,
                started: std::time::Instant::now(),
            },
            saving: Saving {
                session_dirty: false,
                persist: Persist::default(),
                saved: None,
                kept: Kept::default(),
            },
            quit: false,
        };
        let mut cmds = Vec::new();
        if let Some(session) = &init.session {
            if flagged_theme.is_some() || app.looks.no_color {
                app.saving.kept.theme = Some(session.theme.clone());
            }
            if init.samples.is_some() {
                app.saving.kept.samples = Some(session.samples);
            }
        }
        // The dataset given at start opens on the session's task when it
        // is one of its tasks, else on its first; without one, the demo.
        let dataset_task = app.work.dataset.as_ref().and_then(|d| {
            let saved = init
                .session
                .as_ref()
                .and_then(|s| s.current.task_id.as_deref());
            saved.and_then(|id| d.task(id)).or(d.tasks.first()).cloned()
        });
        match init.session {
            Some(session) => cmds.extend(app.restore(session, dataset_task.as_ref())),
            None => cmds.extend(app.open_source(dataset_task.as_ref())),
        }
        if let Some(theme) = flagged_theme.filter(|_| !app.looks.no_color) {
            app.looks.theme = theme;
        }
        if let Some(samples) = init.samples {
            app.work.samples = samples;
        }
        app.panes.prompt.load_editor(app.work.approach);
        cmds.push(app.rescore());
        (app, cmds)
    }

    pub(crate) fn rescore(&mut self) -> Cmd {
        self.work.score_generation += 1;
        self.saving.session_dirty = true;
        let (gt, pred) = self.scored_lists();
        Cmd::Score(ScoreRequest {
            generation: self.work.score_generation,
            gt,
            pred,
        })
    }

    /// Whether scores are being computed for the latest change.
    pub fn scoring(&self) -> bool {
        self.work.scoring()
    }

    pub(crate) fn set_status(&mut self, text: impl Into<String>, severity: Severity) {
        let text = text.into();
        self.log(text.clone(), severity);
        self.messages.status = Some((text, severity));
    }

    /// Keeps `text` in the message log (`M`) without showing it on the
    /// status line: what the header may have to shorten, said whole.
    pub fn log(&mut self, text: String, severity: Severity) {
        let log = &mut self.messages.log;
        if log.len() >= LOG_MAX {
            log.drain(..=log.len() - LOG_MAX);
        }
        log.push(LogEntry {
            at: self.messages.started.elapsed(),
            text,
            severity,
        });
        if let Some(Overlay::Log(view)) = &mut self.overlay {
            view.update(log);
        }
    }

    /// Whether the demo is what is loaded (no dataset task).
    pub fn is_demo(&self) -> bool {
        self.work.is_demo()
    }

    /// On a user's task, puts every agent still on the demo's recording
    /// (which has answers for the demo alone) on the provider the config
    /// file and the environment configure for it, if any.
    pub(crate) fn use_configured_providers(&mut self) {
        if self.is_demo() {
            return;
        }
        for (role, view) in self.runs.agents.iter_mut() {
            if let Some(chosen) = self.work.configured.get(role) {
                if view.settings.provider == ProviderKind::Replay {
                    view.settings = chosen.clone();
                }
            }
        }
    }

    pub(crate) fn load_published_plan(&mut self) {
        let key = self.work.approach.dataset_field();
        match (self.work.task.id.clone(), self.work.task.published.get(key)) {
            (Some(task), Some(steps)) => {
                self.panes.plan.items = steps.clone();
                self.work.plan_source = PlanSource::Published {
                    task,
                    approach: self.work.approach,
                };
            }
            _ => {
                self.panes.plan.items.clear();
                self.work.plan_source = PlanSource::None;
            }
        }
        self.panes.plan.selected = 0;
    }

    /// Switches the approach, the Prompt pane showing the same agent's
    /// template of the new approach (the planning agent when it has none).
    pub(crate) fn set_approach(&mut self, approach: Approach) {
        if matches!(self.editing, Editing::Prompt) {
            self.panes.prompt.store_editor(self.work.approach);
            self.editing = Editing::None;
        }
        self.work.approach = approach;
        if !approach.roles().contains(&self.panes.prompt.agent) {
            self.panes.prompt.agent = approach.planning_role();
        }
        self.panes.prompt.load_editor(self.work.approach);
    }

    pub(crate) fn cycle_approach(&mut self) -> Vec<Cmd> {
        let has_table = self.work.task.table.is_some();
        let published = &self.work.task.published;
        let start = APPROACH_CYCLE
            .iter()
            .position(|a| *a == self.work.approach)
            .unwrap_or(0);
        let next = (1..=4)
            .map(|k| APPROACH_CYCLE[(start + k) % 4])
            .find(|a| has_table || a.uses_image() || published.contains_key(a.dataset_field()))
            .unwrap_or(Approach::MultiImage);
        self.set_approach(next);
        self.saving.session_dirty = true;
        let mut note = format!("approach: {next}");
        if !has_table && !next.uses_image() {
            note.push_str(
                " · this task has no table file: the paper's plan is shown as a reference, and r needs a table",
            );
        } else if !has_table {
            note.push_str(" (the table approaches need a task with a table)");
        }
        self.set_status(note, Severity::Info);
        if matches!(self.work.plan_source, PlanSource::Published { .. }) {
            self.load_published_plan();
            return vec![self.rescore()];
        }
        Vec::new()
    }

    /// The plan and ground truth as scored: with the step being edited as typed.
    pub fn scored_lists(&self) -> (Vec<String>, Vec<String>) {
        let mut gt = self.panes.ground_truth.items.clone();
        let mut plan = self.panes.plan.items.clone();
        if let Editing::Step {
            list,
            index,
            editor,
            ..
        } = &self.editing
        {
            let target = match list {
                StepList::Plan => &mut plan,
                StepList::GroundTruth => &mut gt,
            };
            if let Some(step) = target.get_mut(*index) {
                *step = editor.lines().join(" ");
            }
        }
        gt.retain(|s| !s.trim().is_empty());
        plan.retain(|s| !s.trim().is_empty());
        (gt, plan)
    }

    /// Rebuilds the graph from the SKM's latest output.
    pub(crate) fn refresh_graph(&mut self) {
        let output = self
            .runs
            .agents
            .get(&AgentRole::Skm)
            .map(|v| v.output.as_str())
            .unwrap_or_default();
        self.panes.graph.set_output(output);
    }

    /// The text of `agent`'s prompt template in the current approach, with
    /// the editor's text when it is being edited.
    pub fn prompt_of(&self, agent: AgentRole) -> String {
        self.shared().prompt_of(agent)
    }

    /// What the panes draw from beside their own state.
    pub fn shared(&self) -> Shared<'_> {
        Shared {
            theme: &self.looks.theme,
            work: &self.work,
            runs: &self.runs,
            panes: &self.panes,
            editing: &self.editing,
            focus: self.focus,
            overlay_open: self.overlay.is_some(),
        }
    }

    /// What a run's record reads beyond the runs, as it stands.
    pub fn run_context(&self) -> RunContext {
        RunContext {
            approach: self.work.approach,
            task: self.work.task.text.clone(),
            prompts: self
                .work
                .approach
                .roles()
                .iter()
                .map(|&a| (a, self.prompt_of(a)))
                .collect(),
            plan: self.panes.plan.items.clone(),
            ground_truth: self.panes.ground_truth.items.clone(),
        }
    }

    /// Whether an agent's prompt or settings differ from those its output
    /// was made with.
    pub fn agent_changed(&self, agent: AgentRole) -> bool {
        self.shared().agent_changed(agent)
    }

    /// The agents a run re-executes: those whose inputs changed (every one
    /// when `all`), and the planner when a miner it reads re-runs.
    pub fn agents_to_run(&self, all: bool) -> Vec<AgentRole> {
        let mut out: Vec<AgentRole> = Vec::new();
        for &agent in self.work.approach.roles() {
            let upstream = agent == AgentRole::Planner && !out.is_empty();
            if all || upstream || self.agent_changed(agent) {
                out.push(agent);
            }
        }
        out
    }

    /// Takes the settings the pipeline resolved for a run it accepted
    /// ([`Runs::accepted`]); called by the runtime.
    pub fn run_accepted(&mut self, run: u64, settings: BTreeMap<AgentRole, AgentSettings>) {
        self.runs.accepted(run, settings);
    }

    /// Refuses a run the pipeline cannot do, saying why; called by the
    /// runtime.
    pub fn run_refused(&mut self, run: u64, reason: RunError) {
        if self.runs.refused(run) {
            self.set_status(reason.to_string(), Severity::Warn);
        }
    }

    /// When the screen must be drawn again for a retry's countdown or a
    /// silence to move ([`Runs::countdown_wake`]).
    pub fn countdown_wake(&self, now: std::time::Instant) -> Option<std::time::Instant> {
        self.runs.countdown_wake(now)
    }

    /// The ground truths the picker offers, with their labels.
    pub fn ground_truth_choices(&self) -> Vec<(GroundTruthChoice, String)> {
        ground_truth_choices(&self.work)
    }

    /// Whether the Scene pane shows the task's table instead of its
    /// picture.
    pub fn shows_table(&self) -> bool {
        self.work.shows_table()
    }

    pub(crate) fn load_scene(&mut self) -> Vec<Cmd> {
        self.panes.scene.protocol = None;
        self.panes.scene.requested = None;
        self.panes.scene.table = None;
        let table: Vec<Cmd> = self
            .work
            .task
            .table
            .iter()
            .cloned()
            .map(Cmd::LoadTable)
            .collect();
        if let Some(message) = self.panes.scene.message.take() {
            if self
                .messages
                .status
                .as_ref()
                .is_some_and(|(text, _)| *text == message)
            {
                self.messages.status = None;
            }
        }
        let image = match &self.work.task.image {
            Some(path) => {
                self.panes.scene.image = None;
                vec![Cmd::LoadImage(path.clone())]
            }
            None if self.is_demo() => {
                self.panes.scene.image =
                    Some(Arc::new(DynamicImage::ImageRgb8(demo::scene_image())));
                Vec::new()
            }
            None => {
                self.panes.scene.image = None;
                Vec::new()
            }
        };
        image.into_iter().chain(table).collect()
    }

    /// The terminal area the scene image is shown in now, when it is.
    pub fn image_area(&self) -> Option<Rect> {
        if !self.panes.scene.enabled || self.panes.scene.image.is_none() || self.shows_table() {
            return None;
        }
        let Screen::Panes { panes, .. } = self.screen_layout() else {
            return None;
        };
        let (_, rect) = panes.into_iter().find(|(p, _)| *p == Pane::Scene)?;
        let inner = scene_image_area(rect);
        (inner.width > 0 && inner.height > 0).then_some(inner)
    }

    /// Where a picture is on the screen and whether it is held back (an
    /// overlay is open), when one is drawn: a picture kitty placed directly
    /// must be taken off whenever this changes.
    pub fn picture_shown(&self) -> Option<(Rect, bool)> {
        let area = self.image_area()?;
        let drawn = matches!(&self.panes.scene.protocol, Some((r, _)) if *r == area);
        drawn.then_some((area, self.overlay.is_some()))
    }

    /// The terminal area the scene image should be encoded for, when it is
    /// shown and not yet encoded for that area.
    pub fn image_area_wanted(&self) -> Option<Rect> {
        let inner = self.image_area()?;
        let encoded = matches!(&self.panes.scene.protocol, Some((r, _)) if *r == inner);
        (!encoded && self.panes.scene.requested != Some(inner)).then_some(inner)
    }

    /// Shows `text` on the status line as a message about the scene image:
    /// it goes away with the image.
    pub(crate) fn image_status(&mut self, text: String) {
        self.set_status(text.clone(), Severity::Warn);
        self.panes.scene.message = Some(text);
    }

    /// Notes that the scene is being encoded for `area` and returns what the
    /// encoding needs (the area, the image, the theme's background for the
    /// cells it does not fill), when the image is wanted in an area it is
    /// not encoded (or being encoded) for: the loop hands it to a task.
    pub fn request_image(&mut self) -> Option<ImageRequest> {
        let area = self.image_area_wanted()?;
        let image = self.panes.scene.image.clone()?;
        self.panes.scene.requested = Some(area);
        Some(ImageRequest {
            area,
            image,
            background: self.looks.theme.picture_background(),
        })
    }

    /// Where everything is drawn at the terminal's size now.
    pub fn screen_layout(&self) -> Screen {
        self.layout_in(Rect::new(0, 0, self.size.0, self.size.1))
    }

    /// Where everything is drawn in `area`: the status line takes two rows
    /// while its messages do not fit on one.
    pub fn layout_in(&self, area: Rect) -> Screen {
        let rows = self.status_rows(area.width);
        pane_rects_with(area, self.focus, self.panes.zoom, rows)
    }

    /// The status line's messages as shown: the start notice (saying how to
    /// dismiss it), then the latest status message.
    pub fn status_messages(&self) -> Vec<(String, Severity)> {
        let dismiss = keymap::key_of(Context::Panes, Action::Escape);
        self.messages
            .notice
            .as_ref()
            .map(|(text, severity)| (format!("{text} ({dismiss} dismisses)"), *severity))
            .into_iter()
            .chain(self.messages.status.clone())
            .collect()
    }

    /// The shortest hints the status line starts with when a message needs
    /// the room: the mode, if any, and where the keys are listed.
    pub fn short_hints(&self) -> String {
        self.key_context()
            .mode()
            .map_or("? keys".to_string(), |m| format!("{m}: ? keys"))
    }

    /// How many rows the status line takes `width` columns wide: two while
    /// its messages do not fit on one beside the shortest hints, else one.
    pub fn status_rows(&self, width: u16) -> u16 {
        let messages: usize = self
            .status_messages()
            .iter()
            .map(|(text, _)| text_width(text) + 2)
            .sum();
        let search = match &self.editing {
            Editing::Search(_) => text_width(&self.panes.search) + 1,
            _ => 0,
        };
        let one_line = text_width(&self.short_hints()) + 2 + search + messages;
        if messages > 0 && one_line > usize::from(width) {
            2
        } else {
            1
        }
    }

    /// Whether an editor (step, prompt or search) has the keyboard.
    pub fn is_editing(&self) -> bool {
        !matches!(self.editing, Editing::None)
    }

    /// The context that has the keyboard: the open editor's (editors come
    /// first, see `on_key`), else the open overlay's, else the panes'.
    pub fn key_context(&self) -> Context {
        match (&self.editing, &self.overlay) {
            (Editing::None, Some(overlay)) => overlay.context().unwrap_or(Context::Panes),
            (editing, _) => editing.context(),
        }
    }

    /// The contexts whose bindings apply with no editor or overlay open,
    /// the focused pane's first.
    pub fn pane_contexts(&self) -> Vec<Context> {
        let pane = match self.focus {
            Pane::Plan | Pane::GroundTruth => Some(Context::Steps),
            Pane::Graph => Some(self.panes.graph.context()),
            Pane::Prompt => Some(Context::Prompt),
            _ => None,
        };
        let plan = (self.focus == Pane::Plan).then_some(Context::Plan);
        plan.into_iter()
            .chain(pane)
            .chain([Context::Panes])
            .collect()
    }
}

/// The session: the copy the saver writes, and restoring one.
impl App {
    /// Called by the loop after each batch of messages: the copy of the
    /// session for the saver when one is due (at once when an edit was just
    /// committed, else at most every [`SNAPSHOT_EVERY`]), and otherwise the
    /// instant to ask again, if a change waits.
    pub fn poll_snapshot(&mut self, now: Instant) -> (Option<Session>, Option<Instant>) {
        let changed = std::mem::take(&mut self.saving.session_dirty);
        match self.saving.persist.due(changed, self.is_editing(), now) {
            Snapshot::Take => (Some(self.to_session()), None),
            Snapshot::WaitUntil(at) => (None, Some(at)),
            Snapshot::Idle => (None, None),
        }
    }

    /// The session as it stands, for saving.
    pub fn to_session(&self) -> Session {
        let mut prompts = self.panes.prompt.texts.clone();
        if matches!(self.editing, Editing::Prompt) {
            prompts.insert(
                template_name(self.work.approach, self.panes.prompt.agent),
                self.panes.prompt.editor_text(),
            );
        }
        prompts.retain(|name, text| self.panes.prompt.defaults.get(name) != Some(text));
        let draft = match &self.editing {
            Editing::Step {
                list,
                index,
                editor,
                ..
            } => Some(Draft {
                target: list.key().to_string(),
                index: *index,
                text: editor.lines().join(" "),
            }),
            _ => None,
        };
        Session {
            version: SESSION_VERSION,
            current: self.source_state(),
            parked: self.work.parked.clone(),
            prompts,
            theme: self
                .saving
                .kept
                .theme
                .clone()
                .unwrap_or_else(|| self.looks.theme.name.clone()),
            image: self.panes.scene.enabled,
            samples: self.saving.kept.samples.unwrap_or(self.work.samples),
            draft,
        }
    }

    /// Puts a saved session in place with `task` in use (`None`: the
    /// demo): the session's source for it when it has one, else a fresh
    /// start on it; every other source the session holds is parked, kept
    /// for when it is opened again. The draft comes back only on the
    /// source it was typed in.
    pub(crate) fn restore(&mut self, s: Session, task: Option<&Task>) -> Vec<Cmd> {
        for (name, text) in s.prompts {
            if let Some(prompt) = self.panes.prompt.texts.get_mut(&name) {
                *prompt = text;
            }
        }
        if let Some(theme) = self.looks.themes.iter().find(|t| t.name == s.theme) {
            if !self.looks.no_color {
                self.looks.theme = theme.clone();
            }
        }
        self.panes.scene.enabled = s.image;
        let wanted = task.map(|t| t.id.clone());
        let same = s.current.task_id == wanted;
        let kept = (!same).then(|| s.current.task_id.clone()).flatten();
        self.work.parked = s.parked;
        self.work.parked.retain(|p| p.task_id != s.current.task_id);
        self.work.parked.push(s.current);
        let cmds = self.open_source(task);
        if let Some(id) = kept {
            // A start notice, so that the demo's first run does not hide it.
            let opened = wanted.as_deref().unwrap_or("the demo");
            let text = format!(
                "{opened} opened; the session's task {id} and its runs are kept for when it is opened again ({} hides this)",
                keymap::key_of(Context::Panes, Action::Escape)
            );
            self.messages.notice.get_or_insert((text, Severity::Info));
        }
        self.work.samples = s.samples;
        let draft = s.draft.filter(|_| same);
        if let Some(draft) = draft {
            let list = if draft.target == StepList::GroundTruth.key() {
                StepList::GroundTruth
            } else {
                StepList::Plan
            };
            let len = self.panes.steps(list).len();
            let inserted = draft.index >= len;
            if inserted {
                self.panes.steps_mut(list).items.push(String::new());
            }
            let index = draft.index.min(len);
            self.editing = Editing::Step {
                list,
                index,
                editor: single_line_editor(&draft.text),
                inserted,
            };
            self.focus = match list {
                StepList::Plan => Pane::Plan,
                StepList::GroundTruth => Pane::GroundTruth,
            };
        }
        cmds
    }
}

/// The sources of plans: the one in use, parking it, opening another.
impl App {
    /// The source in use as the session keeps it, the run in flight
    /// included (as running, restored as cancelled).
    pub(crate) fn source_state(&self) -> SourceState {
        let agents = &self.runs.agents;
        let context = self.runs.active.as_ref().map(|_| self.run_context());
        SourceState {
            task_id: self.work.task.id.clone(),
            approach: self.work.approach,
            ground_truth_source: self.work.ground_truth_source.clone(),
            ground_truth: self.panes.ground_truth.items.clone(),
            plan_source: self.work.plan_source.clone(),
            plan: self.panes.plan.items.clone(),
            settings: agents
                .iter()
                .map(|(a, v)| (*a, v.settings.clone()))
                .collect(),
            outputs: agents
                .iter()
                .filter(|(_, v)| v.status == AgentStatus::Done)
                .map(|(a, v)| (*a, v.output.clone()))
                .collect(),
            ran_with: agents
                .iter()
                .filter_map(|(a, v)| v.ran_with.clone().map(|r| (*a, r)))
                .collect(),
            runs: self
                .runs
                .history
                .iter()
                .cloned()
                .chain(
                    self.runs
                        .active
                        .as_ref()
                        .zip(context.as_ref())
                        .map(|(active, context)| {
                            self.runs.record(active, RunState::Running, context)
                        }),
                )
                .collect(),
        }
    }

    /// Opens another source (`None`: the demo) from the picker: the one in
    /// use is parked as it is, and the other comes back as it was left, or
    /// fresh when it was never opened. Refused while a run is in flight,
    /// since its answers belong to the source it started on.
    pub(crate) fn switch_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        if self.runs.active.is_some() {
            self.set_status(
                "a run is in flight: x cancels it before another task opens",
                Severity::Warn,
            );
            return Vec::new();
        }
        let parked = self.source_state();
        let undo = std::mem::take(&mut self.panes.undo);
        self.panes.parked_undo.insert(parked.task_id.clone(), undo);
        self.work.parked.retain(|p| p.task_id != parked.task_id);
        self.work.parked.push(parked);
        self.saving.session_dirty = true;
        let mut cmds = self.open_source(task);
        cmds.push(self.rescore());
        cmds
    }

    /// Puts `task` (`None`: the demo) in use: its parked state when the
    /// session has one, else a fresh start on it (the demo runs its
    /// recording, a dataset task shows its published plan).
    pub(crate) fn open_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        let id = task.map(|t| t.id.clone());
        self.panes.undo = self.panes.parked_undo.remove(&id).unwrap_or_default();
        match self.work.parked.iter().position(|p| p.task_id == id) {
            Some(at) => {
                let state = self.work.parked.remove(at);
                self.apply_source(state, task)
            }
            None => self.fresh_source(task),
        }
    }

    /// A source opened for the first time: no runs, no answers.
    fn fresh_source(&mut self, task: Option<&Task>) -> Vec<Cmd> {
        self.runs.history.clear();
        self.runs.awaiting_scores = None;
        match task {
            Some(task) => {
                for view in self.runs.agents.values_mut() {
                    *view = AgentView::idle(view.settings.clone());
                }
                self.work.task = task_view(task);
                self.panes.ground_truth.replace(task.ground_truth.clone());
                self.work.ground_truth_source = GroundTruthSource::Dataset {
                    task: task.id.clone(),
                };
                let published = task.plans.contains_key(self.work.approach.dataset_field());
                if !self.work.approach.uses_image() && task.table.is_none() && !published {
                    self.set_approach(Approach::MultiImage);
                }
                self.use_configured_providers();
                self.refresh_graph();
                self.load_published_plan();
                self.load_scene()
            }
            None => {
                self.runs.agents = fresh_agents();
                self.work.task = demo_task();
                self.set_approach(Approach::MultiImage);
                self.panes.ground_truth.replace(demo_ground_truth(0));
                self.work.ground_truth_source = GroundTruthSource::Demo { index: 0 };
                self.panes.plan.replace(Vec::new());
                self.work.plan_source = PlanSource::None;
                self.refresh_graph();
                let mut cmds = self.load_scene();
                cmds.extend(self.start_run(false));
                cmds
            }
        }
    }

    /// Puts a saved source in use: its task, lists, answers and runs (a run
    /// saved in flight comes back cancelled); each agent's pane shows the
    /// time and tokens of its latest good call.
    pub(crate) fn apply_source(&mut self, s: SourceState, task: Option<&Task>) -> Vec<Cmd> {
        self.work.task = task.map_or_else(demo_task, task_view);
        self.set_approach(s.approach);
        self.work.ground_truth_source = s.ground_truth_source;
        self.panes.ground_truth.replace(s.ground_truth);
        self.work.plan_source = s.plan_source;
        self.panes.plan.replace(s.plan);
        for (agent, view) in self.runs.agents.iter_mut() {
            let settings = s.settings.get(agent).unwrap_or(&view.settings).clone();
            *view = AgentView::idle(settings);
            if let Some(out) = s.outputs.get(agent) {
                view.output = out.clone();
                view.status = AgentStatus::Done;
            }
            view.ran_with = s.ran_with.get(agent).cloned();
        }
        self.use_configured_providers();
        self.runs.history = s.runs;
        self.runs.awaiting_scores = None;
        for run in &mut self.runs.history {
            if run.state == RunState::Running {
                run.state = RunState::Cancelled;
                run.reason =
                    Some("cancelled: the workbench stopped during the run, not scored".into());
            }
        }
        for (agent, view) in self.runs.agents.iter_mut() {
            let last = self.runs.history.iter().rev().find_map(|r| {
                r.calls()
                    .find(|a| a.role == *agent && a.output.is_some() && a.error.is_none())
            });
            if let Some(record) = last.filter(|_| view.status == AgentStatus::Done) {
                view.usage = record.usage;
                view.duration_ms = record.elapsed_ms;
                view.cached = record.cached;
            }
        }
        self.refresh_graph();
        self.load_scene()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn configured_planner() -> BTreeMap<AgentRole, AgentSettings> {
        let live = AgentSettings::new(ProviderKind::Openai, "local", 0.0, 512);
        BTreeMap::from([(AgentRole::Planner, live)])
    }

    fn providers(app: &App) -> Vec<String> {
        [AgentRole::Skm, AgentRole::Gkm, AgentRole::Planner]
            .map(|r| app.runs.agents[&r].settings.provider.to_string())
            .to_vec()
    }

    #[test]
    fn the_demo_replays_and_a_users_task_starts_on_the_configured_providers() {
        let (demo, _) = App::new(AppInit {
            configured: configured_planner(),
            ..AppInit::demo((120, 40), "no models in this test")
        });
        assert_eq!(providers(&demo), ["replay"; 3]);

        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
        let (dataset, _) = Dataset::load(std::path::Path::new(root)).unwrap();
        let (app, _) = App::new(AppInit {
            dataset: Some(dataset),
            configured: configured_planner(),
            ..AppInit::demo((120, 40), "no models in this test")
        });
        assert!(!app.is_demo());
        assert_eq!(providers(&app), ["replay", "replay", "openai"]);
    }
}
