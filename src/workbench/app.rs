//! The workbench's state ([`App`]) and how it starts ([`AppInit`]): the
//! Elm architecture's model. The panes and overlays keep their own parts
//! (see [`crate::workbench::panes`], [`crate::workbench::overlays`]); the
//! update function is in [`crate::workbench::update`].

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;

use crate::agents::config::AgentSettings;
use crate::agents::cost::PriceTable;
use crate::agents::{AgentRole, Approach, ProviderKind};
use crate::dataset::{Dataset, Task};
use crate::demo;
use crate::workbench::agents;
use crate::workbench::editing::Editing;
use crate::workbench::keymap::Context;
use crate::workbench::layout::{pane_rects, Screen};
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;
use crate::workbench::panes::graph::GraphPane;
use crate::workbench::panes::prompt::PromptPane;
use crate::workbench::panes::scene::scene_image_area;
use crate::workbench::panes::scene::ScenePane;
use crate::workbench::panes::steps::{demo_ground_truth, StepList, StepUndo, Steps};
use crate::workbench::panes::{Pane, Panes};
use crate::workbench::persist::Persist;
use crate::workbench::runs::Runs;
use crate::workbench::scene_image::ImageRequest;
use crate::workbench::scoring::{ModelSlot, ScoreOutcome, ScoreRequest};
use crate::workbench::session::{
    GroundTruthSource, PlanSource, Session, SessionError, SourceState,
};
use crate::workbench::shared::{LogEntry, Severity, LOG_MAX};
use crate::workbench::theme::Theme;

/// The order the approaches cycle in.
const APPROACH_CYCLE: [Approach; 4] = [
    Approach::MultiImage,
    Approach::SingleImage,
    Approach::MultiTable,
    Approach::SingleTable,
];

/// The task in use.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskView {
    /// The dataset task id; `None` for the built-in demo.
    pub id: Option<String>,
    /// The task text.
    pub text: String,
    /// The scene image file (the demo draws its own).
    pub image: Option<PathBuf>,
    /// The environment table file.
    pub table: Option<PathBuf>,
    /// Published plans by approach key.
    pub published: BTreeMap<String, Vec<String>>,
}

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

/// The session's data that is no pane's own: the task, the dataset, the
/// approach, the settings runs start from, where the plans came from and
/// their scores.
pub struct Workspace {
    /// The task.
    pub task: TaskView,
    /// The dataset, if loaded.
    pub dataset: Option<Dataset>,
    /// The approach.
    pub approach: Approach,
    /// How many samples `r` asks each agent for (the `S` key, `--samples`).
    pub samples: u32,
    /// The settings configured agents start with on a user's task.
    pub configured: BTreeMap<AgentRole, AgentSettings>,
    /// The config file's prices, for the cost of each run in the history
    /// (empty: every cost shows as `no price`).
    pub prices: PriceTable,
    /// The folder of the named prompt sets, if there is one.
    pub prompt_sets: Option<PathBuf>,
    /// The prompt set saved or loaded last (empty: none yet).
    pub prompt_set: String,
    /// Where the plan came from.
    pub plan_source: PlanSource,
    /// Where the ground-truth steps came from.
    pub ground_truth_source: GroundTruthSource,
    /// The latest scores.
    pub scores: Option<ScoreOutcome>,
    /// The generation of the latest score request.
    pub score_generation: u64,
    /// The PG2S models.
    pub models: ModelSlot,
    /// The sources opened in this session other than the one in use, each
    /// as it was left ([`crate::workbench::sources`]).
    pub parked: Vec<SourceState>,
    /// The step edits `u` can take back on each parked source, by task id
    /// (`None`: the demo); kept while the workbench runs, not saved.
    pub parked_undo: BTreeMap<Option<String>, StepUndo>,
}

/// How the workbench looks.
pub struct Looks {
    /// The theme in use.
    pub theme: Theme,
    /// The themes to cycle through.
    pub themes: Vec<Theme>,
    /// Whether `NO_COLOR` is in force.
    pub no_color: bool,
    /// Whether every frame is folded to ASCII (see [`AppInit::ascii`]).
    pub ascii: bool,
}

/// The status line's messages.
pub struct Messages {
    /// The latest status message.
    pub status: Option<(String, Severity)>,
    /// A message from the start (e.g. where an unreadable session file was
    /// moved) that stays in the status bar until Esc dismisses it.
    pub notice: Option<(String, Severity)>,
    /// Every status message and notice so far, oldest first (at most
    /// [`LOG_MAX`]): what `M` shows, since the status line keeps only the
    /// latest.
    pub log: Vec<LogEntry>,
    /// When the workbench started, for the log's times.
    pub started: std::time::Instant,
}

/// The session file's side of the workbench.
pub struct Saving {
    /// Set when something the session holds changed since the last save.
    pub session_dirty: bool,
    /// The loop's copies of the session for the saver.
    pub persist: Persist,
    /// The session file's state, for the status bar.
    pub saved: Option<Result<(), SessionError>>,
    /// The session's own settings that a start-up flag (or `NO_COLOR`)
    /// overrides for this start: saved in their place, so the next start
    /// without the flag gets them back, until the user changes the setting
    /// here.
    pub kept: Kept,
}

/// The session's values of the settings overridden at start-up (see
/// [`Saving::kept`]); `None` where nothing overrides the setting.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Kept {
    /// The session's theme, by name.
    pub theme: Option<String>,
    /// The session's number of samples.
    pub samples: Option<u32>,
}

pub(crate) fn demo_task() -> TaskView {
    TaskView {
        id: None,
        text: demo::TASK.trim().to_string(),
        image: None,
        table: None,
        published: BTreeMap::new(),
    }
}

pub(crate) fn task_view(task: &Task) -> TaskView {
    TaskView {
        id: Some(task.id.clone()),
        text: task.task.clone(),
        image: task.image.clone(),
        table: task.table.clone(),
        published: task.plans.clone(),
    }
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
                parked_undo: BTreeMap::new(),
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
        self.work
            .scores
            .as_ref()
            .is_none_or(|s| s.generation < self.work.score_generation)
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
        self.work.task.id.is_none()
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
        let editing = matches!(self.editing, Editing::Prompt);
        self.panes
            .prompt
            .text_of(self.work.approach, agent, editing)
    }

    /// Whether the Scene pane shows the task's table instead of its
    /// picture: on a table approach, for a task with a table file.
    pub fn shows_table(&self) -> bool {
        !self.work.approach.uses_image() && self.work.task.table.is_some()
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
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        let Screen::Panes { panes, .. } = pane_rects(screen, self.focus, self.panes.zoom) else {
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
