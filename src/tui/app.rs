//! The workbench's state, the messages that change it and the update
//! function (the Elm architecture): `update` is the only place state changes,
//! and it answers with commands the runtime carries out in the background.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind};
use image::DynamicImage;
use ratatui::layout::{Position, Rect};
use ratatui_image::protocol::Protocol;
use ratatui_textarea::TextArea;

use super::agents::{self, planning_role, role_label, roles, AgentEvent, RunRequest};
use super::component;
use super::graph_view::GraphView;
use super::help::{Close, Help};
use super::keymap::{self, Action, Context};
use super::scoring::{Pg2sOutcome, ScoreOutcome, ScoreRequest};
use super::theme::Theme;
use super::ui::layout::{pane_rects, Screen};
use crate::agents::graph::{parse_triples, KnowledgeGraph};
use crate::agents::prompts::template_name;
use crate::agents::{AgentRole, Approach};
use crate::dataset::{Dataset, Task};
use crate::demo;
use crate::plan::parse_steps;
use crate::session::{
    AgentRecord, AgentSettings, Draft, GroundTruthSource, PlanSource, RunRecord, ScoreRecord,
    Session, Usage, SESSION_VERSION,
};

/// The order the approaches cycle in.
const APPROACH_CYCLE: [Approach; 4] = [
    Approach::MultiImage,
    Approach::SingleImage,
    Approach::MultiTable,
    Approach::SingleTable,
];

/// The panes, each with the title users and tests find it by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pane {
    /// The scene image.
    Scene,
    /// The SKM's knowledge graph.
    Graph,
    /// The GKM's grounded description.
    Description,
    /// The plan, with its matches.
    Plan,
    /// The ground truth.
    GroundTruth,
    /// The scores and the history of runs.
    Scores,
    /// The prompt editor.
    Prompt,
}

impl Pane {
    /// The panes in focus order.
    pub const ALL: [Pane; 7] = [
        Pane::Scene,
        Pane::Graph,
        Pane::Description,
        Pane::Plan,
        Pane::GroundTruth,
        Pane::Scores,
        Pane::Prompt,
    ];

    /// The pane's title.
    pub fn title(self) -> &'static str {
        match self {
            Pane::Scene => "Scene",
            Pane::Graph => "Knowledge Graph (SKM)",
            Pane::Description => "Grounded Description (GKM)",
            Pane::Plan => "Plan",
            Pane::GroundTruth => "Ground Truth",
            Pane::Scores => "Scores",
            Pane::Prompt => "Prompt",
        }
    }

    /// A short name for the tab strip of narrow terminals.
    pub fn short(self) -> &'static str {
        match self {
            Pane::Scene => "Scene",
            Pane::Graph => "Graph",
            Pane::Description => "GKM",
            Pane::Plan => "Plan",
            Pane::GroundTruth => "Truth",
            Pane::Scores => "Scores",
            Pane::Prompt => "Prompt",
        }
    }

    fn index(self) -> usize {
        Pane::ALL.iter().position(|p| *p == self).unwrap_or(0)
    }
}

/// What an agent is doing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AgentStatus {
    /// Nothing has run.
    Idle,
    /// Queued behind the agents it reads.
    Waiting,
    /// Writing.
    Running,
    /// Finished.
    Done,
    /// Failed, with the reason.
    Failed(String),
    /// Cancelled by the user.
    Cancelled,
}

/// One agent as the workbench sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentView {
    /// What it is doing.
    pub status: AgentStatus,
    /// Its latest output (growing while it runs).
    pub output: String,
    /// Its provider and model.
    pub settings: AgentSettings,
    /// The prompt and settings its output was made with.
    pub ran_with: Option<(String, AgentSettings)>,
    /// Token use of its latest call.
    pub usage: Usage,
    /// Wall time of its latest call in milliseconds.
    pub duration_ms: u64,
}

/// Which step list an editor works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepList {
    /// The plan.
    Plan,
    /// The ground truth.
    GroundTruth,
}

impl StepList {
    fn key(self) -> &'static str {
        match self {
            StepList::Plan => "plan",
            StepList::GroundTruth => "ground_truth",
        }
    }
}

/// An editor in use.
#[derive(Debug, Clone)]
pub enum Editing {
    /// No editor: keys are commands.
    None,
    /// Editing one step.
    Step {
        /// The list.
        list: StepList,
        /// The step's index.
        index: usize,
        /// The editor.
        editor: TextArea<'static>,
        /// Whether the step was inserted for this edit (Esc removes it).
        inserted: bool,
    },
    /// Editing the selected agent's prompt.
    Prompt,
    /// Typing a search.
    Search(TextArea<'static>),
}

impl Editing {
    /// The key context of this editor ([`Context::Panes`] when none is open).
    pub fn context(&self) -> Context {
        match self {
            Editing::None => Context::Panes,
            Editing::Step { .. } => Context::StepEditor,
            Editing::Prompt => Context::PromptEditor,
            Editing::Search(_) => Context::Search,
        }
    }
}

/// A modal view over the panes.
#[derive(Debug, Clone)]
pub enum Overlay {
    /// Every key.
    Help,
    /// Choose a ground truth.
    GroundTruthPicker {
        /// The highlighted choice.
        selected: usize,
    },
    /// Type the path of a step file.
    StepFilePath(Box<TextArea<'static>>),
    /// Provider, model, temperature and token limit of an agent.
    ModelForm {
        /// The agent.
        agent: AgentRole,
        /// One editor per field.
        fields: Vec<TextArea<'static>>,
        /// The field with focus.
        field: usize,
    },
    /// The history of runs.
    Runs {
        /// The highlighted run.
        selected: usize,
        /// A run marked for comparison.
        marked: Option<usize>,
    },
    /// Two runs side by side.
    Compare {
        /// Index of the left run.
        left: usize,
        /// Index of the right run.
        right: usize,
    },
    /// The framed actions and their matches.
    Actions,
}

/// A ground truth the picker offers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GroundTruthChoice {
    /// A demo ground truth.
    Demo(usize),
    /// A dataset task, by index.
    Task(usize),
    /// Read a step file.
    File,
    /// Type a new one.
    Typed,
}

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

/// How important a status message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// For information.
    Info,
    /// Something needs the user.
    Warn,
    /// Something failed.
    Error,
}

/// Where the PG2S models stand.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ModelStatus {
    /// Loading, with the latest progress line.
    Loading(String),
    /// Loaded.
    Ready,
    /// Missing, with the reason.
    Unavailable(String),
}

/// The graph view's position.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GraphCursor {
    /// The node in the centre.
    pub node: usize,
    /// The highlighted neighbour.
    pub neighbour: usize,
    /// Nodes visited before, for going back.
    pub back: Vec<usize>,
}

/// How the Knowledge Graph pane draws the graph (`v` switches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum GraphMode {
    /// Every node and labelled edge, laid out in layers.
    #[default]
    Whole,
    /// One node with its incoming and outgoing edges.
    Neighbourhood,
}

/// The run in flight.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveRun {
    /// Its id.
    pub id: u64,
    /// When it started (Unix seconds).
    pub started_unix: u64,
    /// The agents it runs.
    pub agents: Vec<AgentRole>,
}

/// A message: something that happened.
pub enum Msg {
    /// A key was pressed.
    Key(KeyEvent),
    /// The mouse was used.
    Mouse(MouseEvent),
    /// The terminal was resized.
    Resize(u16, u16),
    /// Text was pasted.
    Paste(String),
    /// An agent of a run reported.
    Agent(u64, AgentEvent),
    /// Scores arrived.
    Scored(ScoreOutcome),
    /// The models made progress loading.
    ModelsProgress(String),
    /// The models loaded, or why not.
    ModelsLoaded(Result<(), String>),
    /// A step file was read.
    StepFile(PathBuf, Result<String, String>),
    /// The scene image was read.
    SceneImage(Result<Arc<DynamicImage>, String>),
    /// The scene image was encoded for this area of the terminal.
    ImageReady(Rect, Box<Protocol>),
    /// The session was saved, or why not.
    Saved(Result<(), String>),
    /// The process was asked to stop (a signal).
    Quit,
}

/// A command for the runtime: work done outside `update`.
#[derive(Debug, Clone, PartialEq)]
pub enum Cmd {
    /// Start a run.
    StartRun(RunRequest),
    /// Cancel a run.
    CancelRun(u64),
    /// Score the plan against the ground truth.
    Score(ScoreRequest),
    /// Read a step file.
    ReadStepFile(PathBuf),
    /// Read the scene image.
    LoadImage(PathBuf),
}

/// What the workbench starts from.
pub struct AppInit {
    /// The dataset, when one was given.
    pub dataset: Option<Dataset>,
    /// The themes available (at least one).
    pub themes: Vec<Theme>,
    /// The theme to start with, by name.
    pub theme: Option<String>,
    /// Whether `NO_COLOR` is in force.
    pub no_color: bool,
    /// The session to restore.
    pub session: Option<Session>,
    /// A message to show first.
    pub notice: Option<(String, Severity)>,
    /// The terminal's size.
    pub size: (u16, u16),
    /// Whether the PG2S models are known to be loading.
    pub models: ModelStatus,
    /// The prompt templates' texts by name: the built-in ones, or the
    /// user's where the user folder has one ([`agents::prompt_texts`]).
    pub prompts: BTreeMap<String, String>,
}

impl AppInit {
    /// A start on the built-in demo with the built-in themes, no dataset,
    /// no session and the PG2S models reported missing for `reason`.
    pub fn demo(size: (u16, u16), reason: &str) -> AppInit {
        AppInit {
            dataset: None,
            themes: super::theme::load_themes(None).0,
            theme: None,
            no_color: false,
            session: None,
            notice: None,
            size,
            models: ModelStatus::Unavailable(reason.to_string()),
            prompts: crate::agents::prompts::PromptSet::load(None)
                .map(|set| agents::prompt_texts(&set))
                .unwrap_or_default(),
        }
    }
}

/// The whole state of the workbench.
pub struct App {
    /// The terminal's size.
    pub size: (u16, u16),
    /// The focused pane.
    pub focus: Pane,
    /// Whether the focused pane fills the screen.
    pub zoom: bool,
    /// The theme in use.
    pub theme: Theme,
    /// The themes to cycle through.
    pub themes: Vec<Theme>,
    /// Whether `NO_COLOR` is in force.
    pub no_color: bool,
    /// A modal view, if open.
    pub overlay: Option<Overlay>,
    /// An editor, if in use.
    pub editing: Editing,
    /// The task.
    pub task: TaskView,
    /// The dataset, if loaded.
    pub dataset: Option<Dataset>,
    /// The approach.
    pub approach: Approach,
    /// The agents.
    pub agents: BTreeMap<AgentRole, AgentView>,
    /// Every prompt template's text by name, as edited.
    pub prompts: BTreeMap<String, String>,
    /// The templates' texts the workbench started with.
    pub default_prompts: BTreeMap<String, String>,
    /// The agent whose prompt the Prompt pane shows.
    pub prompt_agent: AgentRole,
    /// The prompt editor, holding the selected agent's prompt.
    pub prompt_editor: TextArea<'static>,
    /// The plan steps.
    pub plan: Vec<String>,
    /// Where the plan came from.
    pub plan_source: PlanSource,
    /// The selected plan step.
    pub plan_selected: usize,
    /// The ground-truth steps.
    pub ground_truth: Vec<String>,
    /// Where they came from.
    pub ground_truth_source: GroundTruthSource,
    /// The selected ground-truth step.
    pub ground_truth_selected: usize,
    /// The latest scores.
    pub scores: Option<ScoreOutcome>,
    /// The generation of the latest score request.
    pub score_generation: u64,
    /// The PG2S models.
    pub models: ModelStatus,
    /// Every run.
    pub runs: Vec<RunRecord>,
    /// The run in flight.
    pub active_run: Option<ActiveRun>,
    /// A finished run waiting for its scores: (index in `runs`, generation).
    pub run_awaiting_scores: Option<(usize, u64)>,
    /// The knowledge graph of the SKM output.
    pub graph: KnowledgeGraph,
    /// The graph view's position.
    pub graph_cursor: GraphCursor,
    /// The whole-graph view: layout, selection, zoom and pan.
    pub graph_view: GraphView,
    /// Which of the two graph drawings the pane shows.
    pub graph_mode: GraphMode,
    /// The search, highlighted in every pane.
    pub search: String,
    /// The latest status message.
    pub status: Option<(String, Severity)>,
    /// Whether the scene image is shown.
    pub image_enabled: bool,
    /// The scene image.
    pub scene: Option<Arc<DynamicImage>>,
    /// The scene image encoded for an area of the terminal.
    pub scene_protocol: Option<(Rect, Box<Protocol>)>,
    /// Scroll offsets of the text panes.
    pub scroll: BTreeMap<Pane, u16>,
    /// Set when the user asked to quit.
    pub quit: bool,
    /// Set when something the session holds changed since the last save.
    pub session_dirty: bool,
    /// The session file's state, for the status bar.
    pub saved: Option<Result<(), String>>,
}

fn demo_task() -> TaskView {
    TaskView {
        id: None,
        text: demo::TASK.trim().to_string(),
        image: None,
        table: None,
        published: BTreeMap::new(),
    }
}

fn task_view(task: &Task) -> TaskView {
    TaskView {
        id: Some(task.id.clone()),
        text: task.task.clone(),
        image: task.image.clone(),
        table: task.table.clone(),
        published: task.plans.clone(),
    }
}

fn demo_ground_truth(index: usize) -> Vec<String> {
    parse_steps(if index == 1 {
        demo::GROUND_TRUTH_B
    } else {
        demo::GROUND_TRUTH
    })
}

fn single_line_editor(text: &str) -> TextArea<'static> {
    let mut editor = TextArea::new(vec![text.to_string()]);
    editor.move_cursor(ratatui_textarea::CursorMove::End);
    editor
}

fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

fn fresh_agents() -> BTreeMap<AgentRole, AgentView> {
    AgentRole::ALL
        .iter()
        .map(|&a| {
            (
                a,
                AgentView {
                    status: AgentStatus::Idle,
                    output: String::new(),
                    settings: agents::demo_settings(),
                    ran_with: None,
                    usage: Usage::default(),
                    duration_ms: 0,
                },
            )
        })
        .collect()
}

impl App {
    /// A workbench in its starting state, with the commands that start it:
    /// the demo run on a fresh start, and the first scoring.
    pub fn new(init: AppInit) -> (App, Vec<Cmd>) {
        let theme = if init.no_color {
            Theme::no_color()
        } else {
            init.theme
                .as_deref()
                .and_then(|name| init.themes.iter().find(|t| t.name == name))
                .or(init.themes.first())
                .cloned()
                .unwrap_or_else(Theme::no_color)
        };
        let mut app = App {
            size: init.size,
            focus: Pane::Plan,
            zoom: false,
            theme,
            themes: init.themes,
            no_color: init.no_color,
            overlay: None,
            editing: Editing::None,
            task: demo_task(),
            dataset: init.dataset,
            approach: Approach::MultiImage,
            agents: fresh_agents(),
            prompts: init.prompts.clone(),
            default_prompts: init.prompts,
            prompt_agent: AgentRole::Skm,
            prompt_editor: TextArea::default(),
            plan: Vec::new(),
            plan_source: PlanSource::None,
            plan_selected: 0,
            ground_truth: demo_ground_truth(0),
            ground_truth_source: GroundTruthSource::Demo { index: 0 },
            ground_truth_selected: 0,
            scores: None,
            score_generation: 0,
            models: init.models,
            runs: Vec::new(),
            active_run: None,
            run_awaiting_scores: None,
            graph: KnowledgeGraph::default(),
            graph_cursor: GraphCursor::default(),
            graph_view: GraphView::default(),
            graph_mode: GraphMode::default(),
            search: String::new(),
            status: init.notice,
            image_enabled: true,
            scene: Some(Arc::new(DynamicImage::ImageRgb8(demo::scene_image()))),
            scene_protocol: None,
            scroll: BTreeMap::new(),
            quit: false,
            session_dirty: false,
            saved: None,
        };
        let notice = app.status.clone();
        let mut cmds = Vec::new();
        match init.session {
            Some(session) => cmds.extend(app.restore(session)),
            None => match app.dataset.as_ref().and_then(|d| d.tasks.first()).cloned() {
                Some(task) => cmds.extend(app.switch_task(&task)),
                None => cmds.extend(app.start_run(false)),
            },
        }
        if notice.is_some() {
            app.status = notice;
        }
        app.load_prompt_editor();
        cmds.push(app.rescore());
        (app, cmds)
    }

    /// The session as it stands, for saving.
    pub fn to_session(&self) -> Session {
        let mut prompts = self.prompts.clone();
        if matches!(self.editing, Editing::Prompt) {
            prompts.insert(self.prompt_name(self.prompt_agent), self.editor_text());
        }
        prompts.retain(|name, text| self.default_prompts.get(name) != Some(text));
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
            task_id: self.task.id.clone(),
            approach: self.approach,
            ground_truth_source: self.ground_truth_source.clone(),
            ground_truth: self.ground_truth.clone(),
            plan_source: self.plan_source.clone(),
            plan: self.plan.clone(),
            prompts,
            settings: self
                .agents
                .iter()
                .map(|(a, v)| (*a, v.settings.clone()))
                .collect(),
            outputs: self
                .agents
                .iter()
                .filter(|(_, v)| v.status == AgentStatus::Done)
                .map(|(a, v)| (*a, v.output.clone()))
                .collect(),
            ran_with: self
                .agents
                .iter()
                .filter_map(|(a, v)| v.ran_with.clone().map(|r| (*a, r)))
                .collect(),
            theme: self.theme.name.clone(),
            image: self.image_enabled,
            runs: self.runs.clone(),
            draft,
        }
    }

    fn restore(&mut self, s: Session) -> Vec<Cmd> {
        let mut cmds = Vec::new();
        if let Some(id) = &s.task_id {
            match self.dataset.as_ref().and_then(|d| d.task(id)).cloned() {
                Some(task) => {
                    self.task = task_view(&task);
                    cmds.extend(self.load_scene());
                }
                None => self.set_status(
                    format!("the session's task {id} is not in the loaded dataset; showing the demo task"),
                    Severity::Warn,
                ),
            }
        }
        self.set_approach(s.approach);
        self.ground_truth_source = s.ground_truth_source;
        self.ground_truth = s.ground_truth;
        self.plan_source = s.plan_source;
        self.plan = s.plan;
        for (name, text) in s.prompts {
            if let Some(prompt) = self.prompts.get_mut(&name) {
                *prompt = text;
            }
        }
        for (agent, view) in self.agents.iter_mut() {
            if let Some(st) = s.settings.get(agent) {
                view.settings = st.clone();
            }
            if let Some(out) = s.outputs.get(agent) {
                view.output = out.clone();
                view.status = AgentStatus::Done;
            }
            view.ran_with = s.ran_with.get(agent).cloned();
        }
        if let Some(theme) = self.themes.iter().find(|t| t.name == s.theme) {
            if !self.no_color {
                self.theme = theme.clone();
            }
        }
        self.image_enabled = s.image;
        self.runs = s.runs;
        self.refresh_graph();
        if let Some(draft) = s.draft {
            let list = if draft.target == StepList::GroundTruth.key() {
                StepList::GroundTruth
            } else {
                StepList::Plan
            };
            let len = self.steps(list).len();
            let inserted = draft.index >= len;
            if inserted {
                self.steps_mut(list).push(String::new());
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

    /// The ground truths the picker offers, with their labels.
    pub fn ground_truth_choices(&self) -> Vec<(GroundTruthChoice, String)> {
        let mut out = Vec::new();
        if self.task.id.is_none() {
            out.push((
                GroundTruthChoice::Demo(0),
                "Demo: annotator A's ground truth".to_string(),
            ));
            out.push((
                GroundTruthChoice::Demo(1),
                "Demo: annotator B's ground truth".to_string(),
            ));
        }
        if let Some(ds) = &self.dataset {
            for (i, t) in ds.tasks.iter().enumerate() {
                out.push((GroundTruthChoice::Task(i), format!("{} · {}", t.id, t.task)));
            }
        }
        out.push((GroundTruthChoice::File, "Load a step file…".to_string()));
        out.push((
            GroundTruthChoice::Typed,
            "Type a new ground truth".to_string(),
        ));
        out
    }

    /// The steps of a list.
    pub fn steps(&self, list: StepList) -> &Vec<String> {
        match list {
            StepList::Plan => &self.plan,
            StepList::GroundTruth => &self.ground_truth,
        }
    }

    fn steps_mut(&mut self, list: StepList) -> &mut Vec<String> {
        match list {
            StepList::Plan => &mut self.plan,
            StepList::GroundTruth => &mut self.ground_truth,
        }
    }

    fn selected_mut(&mut self, list: StepList) -> &mut usize {
        match list {
            StepList::Plan => &mut self.plan_selected,
            StepList::GroundTruth => &mut self.ground_truth_selected,
        }
    }

    /// The plan and ground truth as scored: with the step being edited as typed.
    pub fn scored_lists(&self) -> (Vec<String>, Vec<String>) {
        let mut gt = self.ground_truth.clone();
        let mut plan = self.plan.clone();
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

    fn rescore(&mut self) -> Cmd {
        self.score_generation += 1;
        self.session_dirty = true;
        let (gt, pred) = self.scored_lists();
        Cmd::Score(ScoreRequest {
            generation: self.score_generation,
            gt,
            pred,
        })
    }

    /// Whether scores are being computed for the latest change.
    pub fn scoring(&self) -> bool {
        self.scores
            .as_ref()
            .is_none_or(|s| s.generation < self.score_generation)
    }

    fn set_status(&mut self, text: impl Into<String>, severity: Severity) {
        self.status = Some((text.into(), severity));
    }

    fn refresh_graph(&mut self) {
        let output = self
            .agents
            .get(&AgentRole::Skm)
            .map(|v| v.output.as_str())
            .unwrap_or_default();
        self.graph = KnowledgeGraph::from_triples(&parse_triples(output).triples);
        if self.graph_cursor.node >= self.graph.nodes.len() {
            self.graph_cursor = GraphCursor::default();
        }
        self.graph_view.set_graph(&self.graph);
    }

    /// The name of `agent`'s prompt template in the current approach.
    pub fn prompt_name(&self, agent: AgentRole) -> String {
        template_name(self.approach, agent)
    }

    /// The text of `agent`'s prompt template in the current approach, with
    /// the editor's text when it is being edited.
    pub fn prompt_of(&self, agent: AgentRole) -> String {
        if agent == self.prompt_agent && matches!(self.editing, Editing::Prompt) {
            return self.editor_text();
        }
        self.prompts
            .get(&self.prompt_name(agent))
            .cloned()
            .unwrap_or_default()
    }

    fn editor_text(&self) -> String {
        self.prompt_editor.lines().join("\n")
    }

    fn load_prompt_editor(&mut self) {
        let text = self
            .prompts
            .get(&self.prompt_name(self.prompt_agent))
            .cloned()
            .unwrap_or_default();
        self.prompt_editor = TextArea::new(text.lines().map(str::to_string).collect());
        self.prompt_editor
            .set_wrap_mode(ratatui_textarea::WrapMode::Word);
    }

    fn store_prompt_editor(&mut self) {
        let text = self.editor_text();
        self.prompts
            .insert(self.prompt_name(self.prompt_agent), text);
    }

    /// Whether an agent's prompt or settings differ from those its output was made with.
    pub fn agent_changed(&self, agent: AgentRole) -> bool {
        let Some(v) = self.agents.get(&agent) else {
            return false;
        };
        let prompt = self.prompt_of(agent);
        v.status != AgentStatus::Done || v.ran_with.as_ref() != Some(&(prompt, v.settings.clone()))
    }

    /// The agents a run re-executes: those whose inputs changed, and the
    /// planner when a miner it reads re-runs.
    pub fn agents_to_run(&self, all: bool) -> Vec<AgentRole> {
        let mut out: Vec<AgentRole> = Vec::new();
        for &agent in roles(self.approach) {
            let upstream = agent == AgentRole::Planner && !out.is_empty();
            if all || upstream || self.agent_changed(agent) {
                out.push(agent);
            }
        }
        out
    }

    /// Whether the demo is what is loaded (no dataset task).
    pub fn is_demo(&self) -> bool {
        self.task.id.is_none()
    }

    /// The note shown when the selected agent's prompt was edited but only
    /// recorded outputs can be replayed.
    pub fn provider_note(&self) -> Option<String> {
        let agent = self.prompt_agent;
        let view = self.agents.get(&agent)?;
        let prompt = self.prompt_of(agent);
        let why = if self.approach != Approach::MultiImage {
            "the demo's recording has only the multi-image approach"
        } else {
            "this prompt was edited and the demo's recording has no answer for it"
        };
        (view.settings.provider == agents::REPLAY_PROVIDER
            && !agents::is_recorded_prompt(self.approach, agent, &prompt))
        .then(|| agents::provider_needed(agent, why))
    }

    fn start_run(&mut self, all: bool) -> Vec<Cmd> {
        if self.active_run.is_some() {
            self.set_status("a run is in flight: x cancels it", Severity::Warn);
            return Vec::new();
        }
        if matches!(self.editing, Editing::Prompt) {
            self.store_prompt_editor();
        }
        let to_run = self.agents_to_run(all);
        if to_run.is_empty() {
            self.set_status(
                "nothing changed since the last run: R re-runs every agent",
                Severity::Info,
            );
            return Vec::new();
        }
        let id = self.runs.iter().map(|r| r.id).max().unwrap_or(0) + 1;
        let approach_agents = roles(self.approach);
        let request = RunRequest {
            run: id,
            approach: self.approach,
            task: self.task.text.clone(),
            agents: to_run.clone(),
            prompts: approach_agents
                .iter()
                .map(|a| (*a, self.prompt_of(*a)))
                .collect(),
            settings: approach_agents
                .iter()
                .filter_map(|a| self.agents.get(a).map(|v| (*a, v.settings.clone())))
                .collect(),
            demo: self.is_demo(),
            image: self.task.image.clone(),
            table: self.task.table.clone(),
        };
        for &agent in &to_run {
            if let Some(v) = self.agents.get_mut(&agent) {
                v.status = AgentStatus::Waiting;
                v.output.clear();
            }
        }
        self.active_run = Some(ActiveRun {
            id,
            started_unix: unix_now(),
            agents: to_run.clone(),
        });
        let names: Vec<&str> = to_run.iter().map(|a| role_label(*a)).collect();
        self.set_status(format!("run {id}: {}", names.join(", ")), Severity::Info);
        vec![Cmd::StartRun(request)]
    }

    /// Refuses a run the pipeline cannot do; called by the runtime.
    pub fn run_refused(&mut self, run: u64, reason: String) {
        if self.active_run.as_ref().is_some_and(|r| r.id == run) {
            if let Some(active) = self.active_run.take() {
                for agent in active.agents {
                    if let Some(v) = self.agents.get_mut(&agent) {
                        v.status = AgentStatus::Idle;
                    }
                }
            }
            self.set_status(reason, Severity::Warn);
        }
    }

    fn finish_run(&mut self, cancelled: bool) -> Vec<Cmd> {
        let Some(active) = self.active_run.take() else {
            return Vec::new();
        };
        let agents = active
            .agents
            .iter()
            .filter_map(|a| {
                let v = self.agents.get(a)?;
                Some(AgentRecord {
                    agent: *a,
                    settings: v.settings.clone(),
                    prompt: self.prompt_of(*a),
                    output: v.output.clone(),
                    duration_ms: v.duration_ms,
                    usage: v.usage,
                    error: match &v.status {
                        AgentStatus::Failed(e) => Some(e.clone()),
                        _ => None,
                    },
                })
            })
            .collect();
        self.runs.push(RunRecord {
            id: active.id,
            started_unix: active.started_unix,
            approach: self.approach,
            task: self.task.text.clone(),
            agents,
            plan: self.plan.clone(),
            ground_truth: self.ground_truth.clone(),
            scores: None,
            cancelled,
        });
        let cmd = self.rescore();
        self.run_awaiting_scores = Some((self.runs.len() - 1, self.score_generation));
        vec![cmd]
    }

    fn on_agent(&mut self, run: u64, event: AgentEvent) -> Vec<Cmd> {
        if self.active_run.as_ref().is_none_or(|r| r.id != run) {
            return Vec::new();
        }
        match event {
            AgentEvent::Started(agent) => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Running;
                    v.output.clear();
                }
                if agent == planning_role(self.approach) {
                    if matches!(
                        self.editing,
                        Editing::Step {
                            list: StepList::Plan,
                            ..
                        }
                    ) {
                        self.editing = Editing::None;
                    }
                    self.plan.clear();
                    self.plan_source = PlanSource::Run { run };
                }
                Vec::new()
            }
            AgentEvent::Token { agent, text } => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.output.push_str(&text);
                }
                match agent {
                    AgentRole::Skm => {
                        self.refresh_graph();
                        Vec::new()
                    }
                    AgentRole::Planner | AgentRole::Single => {
                        self.plan = parse_steps(&self.agents[&agent].output);
                        vec![self.rescore()]
                    }
                    AgentRole::Gkm => Vec::new(),
                }
            }
            AgentEvent::Finished {
                agent,
                output,
                usage,
                duration_ms,
            } => {
                let prompt = self.prompt_of(agent);
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.output = output;
                    v.status = AgentStatus::Done;
                    v.usage = usage;
                    v.duration_ms = duration_ms;
                    v.ran_with = Some((prompt, v.settings.clone()));
                }
                self.session_dirty = true;
                let mut cmds = Vec::new();
                match agent {
                    AgentRole::Skm => self.refresh_graph(),
                    AgentRole::Planner | AgentRole::Single => {
                        self.plan = parse_steps(&self.agents[&agent].output);
                        self.plan_selected = 0;
                    }
                    AgentRole::Gkm => {}
                }
                let all_done = self.active_run.as_ref().is_some_and(|r| {
                    r.agents.iter().all(|a| {
                        self.agents
                            .get(a)
                            .is_some_and(|v| v.status == AgentStatus::Done)
                    })
                });
                if all_done {
                    let id = run;
                    cmds.extend(self.finish_run(false));
                    self.set_status(format!("run {id} finished"), Severity::Info);
                }
                cmds
            }
            AgentEvent::Failed { agent, error } => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.status = AgentStatus::Failed(error.clone());
                }
                self.set_status(
                    format!("{} failed: {error}", role_label(agent)),
                    Severity::Error,
                );
                let mut cmds = vec![Cmd::CancelRun(run)];
                cmds.extend(self.finish_run(false));
                cmds
            }
        }
    }

    fn cancel_run(&mut self) -> Vec<Cmd> {
        let Some(id) = self.active_run.as_ref().map(|r| r.id) else {
            self.set_status("no run in flight", Severity::Info);
            return Vec::new();
        };
        for v in self.agents.values_mut() {
            if matches!(v.status, AgentStatus::Running | AgentStatus::Waiting) {
                v.status = AgentStatus::Cancelled;
            }
        }
        self.set_status(format!("run {id} cancelled"), Severity::Warn);
        let mut cmds = vec![Cmd::CancelRun(id)];
        cmds.extend(self.finish_run(true));
        cmds
    }

    fn on_scored(&mut self, outcome: ScoreOutcome) {
        if outcome.generation > self.score_generation {
            return;
        }
        if let Some((index, generation)) = self.run_awaiting_scores {
            if outcome.generation >= generation {
                if let Some(run) = self.runs.get_mut(index) {
                    let report = match &outcome.pg2s {
                        Pg2sOutcome::Ready(r) => Some(r),
                        _ => None,
                    };
                    run.scores = Some(ScoreRecord {
                        kas: outcome.kas.kas,
                        s_plan: report.map(|r| r.s_plan),
                        s_goal: report.and_then(|r| r.s_goal()),
                        pg2s: report.and_then(|r| r.pg2s()),
                    });
                }
                self.run_awaiting_scores = None;
                self.session_dirty = true;
            }
        }
        if self
            .scores
            .as_ref()
            .is_none_or(|s| s.generation <= outcome.generation)
        {
            self.scores = Some(outcome);
        }
    }

    /// Switches to a dataset task: its ground truth, image and published plan.
    fn switch_task(&mut self, task: &Task) -> Vec<Cmd> {
        self.task = task_view(task);
        self.ground_truth = task.ground_truth.clone();
        self.ground_truth_source = GroundTruthSource::Dataset {
            task: task.id.clone(),
        };
        self.ground_truth_selected = 0;
        if !self.approach.uses_image() && self.task.table.is_none() {
            self.set_approach(Approach::MultiImage);
        }
        for v in self.agents.values_mut() {
            v.output.clear();
            v.status = AgentStatus::Idle;
            v.ran_with = None;
        }
        self.refresh_graph();
        self.load_published_plan();
        self.load_scene()
    }

    fn load_scene(&mut self) -> Vec<Cmd> {
        self.scene_protocol = None;
        match &self.task.image {
            Some(path) => {
                self.scene = None;
                vec![Cmd::LoadImage(path.clone())]
            }
            None if self.is_demo() => {
                self.scene = Some(Arc::new(DynamicImage::ImageRgb8(demo::scene_image())));
                Vec::new()
            }
            None => {
                self.scene = None;
                Vec::new()
            }
        }
    }

    fn load_published_plan(&mut self) {
        let key = self.approach.dataset_field();
        match (self.task.id.clone(), self.task.published.get(key)) {
            (Some(task), Some(steps)) => {
                self.plan = steps.clone();
                self.plan_source = PlanSource::Published {
                    task,
                    approach: self.approach,
                };
            }
            _ => {
                self.plan.clear();
                self.plan_source = PlanSource::None;
            }
        }
        self.plan_selected = 0;
    }

    fn choose_ground_truth(&mut self, choice: GroundTruthChoice) -> Vec<Cmd> {
        self.overlay = None;
        match choice {
            GroundTruthChoice::Demo(index) => {
                self.ground_truth = demo_ground_truth(index);
                self.ground_truth_source = GroundTruthSource::Demo { index };
            }
            GroundTruthChoice::Task(index) => {
                let Some(task) = self
                    .dataset
                    .as_ref()
                    .and_then(|d| d.tasks.get(index))
                    .cloned()
                else {
                    return Vec::new();
                };
                let mut cmds = self.switch_task(&task);
                cmds.push(self.rescore());
                return cmds;
            }
            GroundTruthChoice::File => {
                self.overlay = Some(Overlay::StepFilePath(Box::default()));
                return Vec::new();
            }
            GroundTruthChoice::Typed => {
                self.ground_truth = vec![String::new()];
                self.ground_truth_source = GroundTruthSource::Typed;
                self.focus = Pane::GroundTruth;
                self.editing = Editing::Step {
                    list: StepList::GroundTruth,
                    index: 0,
                    editor: TextArea::default(),
                    inserted: true,
                };
            }
        }
        self.ground_truth_selected = 0;
        vec![self.rescore()]
    }

    /// Switches the approach, the Prompt pane showing the same agent's
    /// template of the new approach (the planning agent when it has none).
    fn set_approach(&mut self, approach: Approach) {
        if matches!(self.editing, Editing::Prompt) {
            self.store_prompt_editor();
            self.editing = Editing::None;
        }
        self.approach = approach;
        if !roles(approach).contains(&self.prompt_agent) {
            self.prompt_agent = planning_role(approach);
        }
        self.load_prompt_editor();
    }

    fn cycle_approach(&mut self) -> Vec<Cmd> {
        let has_table = self.task.table.is_some();
        let start = APPROACH_CYCLE
            .iter()
            .position(|a| *a == self.approach)
            .unwrap_or(0);
        let next = (1..=4)
            .map(|k| APPROACH_CYCLE[(start + k) % 4])
            .find(|a| has_table || a.uses_image())
            .unwrap_or(Approach::MultiImage);
        self.set_approach(next);
        self.session_dirty = true;
        let mut note = format!("approach: {next}");
        if !has_table {
            note.push_str(" (the table approaches need a task with a table)");
        }
        self.set_status(note, Severity::Info);
        if matches!(self.plan_source, PlanSource::Published { .. }) {
            self.load_published_plan();
            return vec![self.rescore()];
        }
        Vec::new()
    }

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
            Msg::ModelsProgress(line) => {
                self.models = ModelStatus::Loading(line);
                Vec::new()
            }
            Msg::ModelsLoaded(result) => {
                self.models = match result {
                    Ok(()) => ModelStatus::Ready,
                    Err(reason) => ModelStatus::Unavailable(reason),
                };
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
                    self.ground_truth = steps;
                    self.ground_truth_source = GroundTruthSource::File { path };
                    self.ground_truth_selected = 0;
                    vec![self.rescore()]
                }
                Err(e) => {
                    self.set_status(e, Severity::Error);
                    Vec::new()
                }
            },
            Msg::SceneImage(result) => {
                match result {
                    Ok(img) => self.scene = Some(img),
                    Err(e) => self.set_status(e, Severity::Warn),
                }
                self.scene_protocol = None;
                Vec::new()
            }
            Msg::ImageReady(rect, protocol) => {
                self.scene_protocol = Some((rect, protocol));
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

    fn on_paste(&mut self, text: &str) -> Vec<Cmd> {
        let flat = text.replace(['\r', '\n'], " ");
        match &mut self.editing {
            Editing::Step { editor, .. } => {
                editor.insert_str(&flat);
                vec![self.rescore()]
            }
            Editing::Prompt => {
                self.prompt_editor.insert_str(text);
                self.session_dirty = true;
                Vec::new()
            }
            Editing::Search(editor) => {
                editor.insert_str(&flat);
                self.search = editor.lines().join("");
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    fn on_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
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

    fn on_editor_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let action = keymap::action(&[self.editing.context()], &key);
        match std::mem::replace(&mut self.editing, Editing::None) {
            Editing::Step {
                list,
                index,
                mut editor,
                inserted,
            } => match action {
                Some(Action::Accept) => {
                    let text = editor.lines().join(" ").trim().to_string();
                    let steps = self.steps_mut(list);
                    if text.is_empty() {
                        if index < steps.len() {
                            steps.remove(index);
                        }
                    } else if let Some(step) = steps.get_mut(index) {
                        *step = text;
                    }
                    let len = self.steps(list).len();
                    *self.selected_mut(list) = index.min(len.saturating_sub(1));
                    if list == StepList::GroundTruth
                        && !matches!(self.ground_truth_source, GroundTruthSource::Typed)
                    {
                        self.ground_truth_source = GroundTruthSource::Typed;
                    }
                    vec![self.rescore()]
                }
                Some(Action::Leave) => {
                    if inserted && index < self.steps(list).len() {
                        self.steps_mut(list).remove(index);
                    }
                    let len = self.steps(list).len();
                    *self.selected_mut(list) = index.min(len.saturating_sub(1));
                    vec![self.rescore()]
                }
                _ => {
                    editor.input(key);
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
                    self.store_prompt_editor();
                    self.session_dirty = true;
                    if let Some(note) = self.provider_note() {
                        self.set_status(note, Severity::Warn);
                    }
                    return Vec::new();
                }
                if action == Some(Action::RunFromEditor) {
                    self.store_prompt_editor();
                    self.session_dirty = true;
                    return self.start_run(false);
                }
                self.prompt_editor.input(key);
                self.editing = Editing::Prompt;
                self.session_dirty = true;
                Vec::new()
            }
            Editing::Search(mut editor) => {
                match action {
                    Some(Action::Leave) => self.search.clear(),
                    Some(Action::Accept) => self.jump_to_search(),
                    _ => {
                        editor.input(key);
                        self.search = editor.lines().join("");
                        self.editing = Editing::Search(editor);
                    }
                }
                Vec::new()
            }
            Editing::None => Vec::new(),
        }
    }

    /// Moves the focused list's selection to the next step holding the search.
    fn jump_to_search(&mut self) {
        let needle = self.search.to_lowercase();
        if needle.is_empty() {
            return;
        }
        let list = match self.focus {
            Pane::GroundTruth => StepList::GroundTruth,
            _ => StepList::Plan,
        };
        let steps = self.steps(list);
        let start = match list {
            StepList::Plan => self.plan_selected,
            StepList::GroundTruth => self.ground_truth_selected,
        };
        let n = steps.len();
        let hit = (1..=n).map(|k| (start + k) % n.max(1)).find(|&i| {
            steps
                .get(i)
                .is_some_and(|s| s.to_lowercase().contains(&needle))
        });
        match hit {
            Some(i) => *self.selected_mut(list) = i,
            None => self.set_status(format!("no step holds “{}”", self.search), Severity::Info),
        }
    }

    fn on_overlay_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        let Some(overlay) = self.overlay.take() else {
            return Vec::new();
        };
        let down = matches!(key.code, KeyCode::Down | KeyCode::Char('j'));
        let up = matches!(key.code, KeyCode::Up | KeyCode::Char('k'));
        match overlay {
            Overlay::Help => {
                let Close = component::dispatch(&mut Help, &key);
                Vec::new()
            }
            Overlay::Actions | Overlay::Compare { .. } => {
                if !matches!(key.code, KeyCode::Esc | KeyCode::Char('q') | KeyCode::Enter) {
                    self.overlay = Some(overlay);
                }
                Vec::new()
            }
            Overlay::GroundTruthPicker { selected } => {
                let choices = self.ground_truth_choices();
                let last = choices.len().saturating_sub(1);
                match key.code {
                    KeyCode::Enter => {
                        if let Some((choice, _)) = choices.get(selected) {
                            return self.choose_ground_truth(choice.clone());
                        }
                    }
                    KeyCode::Esc | KeyCode::Char('q') => {}
                    _ => {
                        let selected = if down {
                            (selected + 1).min(last)
                        } else if up {
                            selected.saturating_sub(1)
                        } else {
                            selected
                        };
                        self.overlay = Some(Overlay::GroundTruthPicker { selected });
                    }
                }
                Vec::new()
            }
            Overlay::StepFilePath(mut editor) => match key.code {
                KeyCode::Enter => {
                    let path = PathBuf::from(editor.lines().join("").trim());
                    vec![Cmd::ReadStepFile(path)]
                }
                KeyCode::Esc => Vec::new(),
                _ => {
                    editor.input(key);
                    self.overlay = Some(Overlay::StepFilePath(editor));
                    Vec::new()
                }
            },
            Overlay::ModelForm {
                agent,
                mut fields,
                field,
            } => match key.code {
                KeyCode::Esc => Vec::new(),
                KeyCode::Enter => {
                    self.apply_model_form(agent, &fields);
                    Vec::new()
                }
                KeyCode::Tab | KeyCode::Down => {
                    self.overlay = Some(Overlay::ModelForm {
                        agent,
                        field: (field + 1) % fields.len(),
                        fields,
                    });
                    Vec::new()
                }
                KeyCode::BackTab | KeyCode::Up => {
                    let n = fields.len();
                    self.overlay = Some(Overlay::ModelForm {
                        agent,
                        field: (field + n - 1) % n,
                        fields,
                    });
                    Vec::new()
                }
                _ => {
                    if let Some(f) = fields.get_mut(field) {
                        f.input(key);
                    }
                    self.overlay = Some(Overlay::ModelForm {
                        agent,
                        fields,
                        field,
                    });
                    Vec::new()
                }
            },
            Overlay::Runs { selected, marked } => {
                let last = self.runs.len().saturating_sub(1);
                match key.code {
                    KeyCode::Esc | KeyCode::Char('q') => Vec::new(),
                    KeyCode::Char(' ') | KeyCode::Char('m') => {
                        self.overlay = Some(Overlay::Runs {
                            selected,
                            marked: if marked == Some(selected) {
                                None
                            } else {
                                Some(selected)
                            },
                        });
                        Vec::new()
                    }
                    KeyCode::Char('c') => {
                        let left = marked.unwrap_or(selected.saturating_sub(1));
                        self.overlay = if self.runs.len() >= 2 && left != selected {
                            Some(Overlay::Compare {
                                left,
                                right: selected,
                            })
                        } else {
                            self.set_status(
                                "mark a run with space, select another, then press c",
                                Severity::Info,
                            );
                            Some(Overlay::Runs { selected, marked })
                        };
                        Vec::new()
                    }
                    KeyCode::Enter => {
                        if let Some(run) = self.runs.get(selected) {
                            self.plan = run.plan.clone();
                            self.plan_source = PlanSource::Run { run: run.id };
                            self.plan_selected = 0;
                            let id = run.id;
                            self.set_status(format!("plan of run {id} loaded"), Severity::Info);
                            return vec![self.rescore()];
                        }
                        Vec::new()
                    }
                    _ => {
                        let selected = if down {
                            (selected + 1).min(last)
                        } else if up {
                            selected.saturating_sub(1)
                        } else {
                            selected
                        };
                        self.overlay = Some(Overlay::Runs { selected, marked });
                        Vec::new()
                    }
                }
            }
        }
    }

    fn apply_model_form(&mut self, agent: AgentRole, fields: &[TextArea<'static>]) {
        let text = |i: usize| {
            fields
                .get(i)
                .map(|f| f.lines().join("").trim().to_string())
                .unwrap_or_default()
        };
        let temperature = text(2).parse::<f32>();
        let max_tokens = text(3).parse::<u32>();
        match (temperature, max_tokens) {
            (Ok(temperature), Ok(max_tokens)) if !text(0).is_empty() && !text(1).is_empty() => {
                if let Some(v) = self.agents.get_mut(&agent) {
                    v.settings = AgentSettings {
                        provider: text(0),
                        model: text(1),
                        temperature,
                        max_tokens,
                    };
                }
                self.session_dirty = true;
                self.set_status(
                    format!("{}: {} / {} (r runs what changed)", role_label(agent), text(0), text(1)),
                    Severity::Info,
                );
            }
            _ => self.set_status(
                format!("{}: not changed: provider and model must be set, the temperature a number, the token limit a whole number", role_label(agent)),
                Severity::Warn,
            ),
        }
    }

    fn open_model_form(&mut self, agent: AgentRole) {
        let Some(v) = self.agents.get(&agent) else {
            return;
        };
        let fields = vec![
            single_line_editor(&v.settings.provider),
            single_line_editor(&v.settings.model),
            single_line_editor(&v.settings.temperature.to_string()),
            single_line_editor(&v.settings.max_tokens.to_string()),
        ];
        self.overlay = Some(Overlay::ModelForm {
            agent,
            fields,
            field: 0,
        });
    }

    fn focus_step(&mut self, step: isize) {
        let n = Pane::ALL.len() as isize;
        let i = (self.focus.index() as isize + step).rem_euclid(n) as usize;
        self.focus = Pane::ALL[i];
    }

    fn move_selection(&mut self, pane: Pane, delta: isize) {
        let moved = |sel: usize, len: usize| -> usize {
            (sel as isize + delta).clamp(0, len.saturating_sub(1) as isize) as usize
        };
        match pane {
            Pane::Plan => self.plan_selected = moved(self.plan_selected, self.plan.len()),
            Pane::GroundTruth => {
                self.ground_truth_selected =
                    moved(self.ground_truth_selected, self.ground_truth.len())
            }
            Pane::Graph => {
                let n = self.graph_neighbours().len();
                self.graph_cursor.neighbour = moved(self.graph_cursor.neighbour, n);
            }
            Pane::Prompt => {
                let shown = roles(self.approach);
                let idx = shown
                    .iter()
                    .position(|a| *a == self.prompt_agent)
                    .unwrap_or(0);
                let next = shown[moved(idx, shown.len())];
                if next != self.prompt_agent {
                    self.store_prompt_editor();
                    self.prompt_agent = next;
                    self.load_prompt_editor();
                }
            }
            Pane::Scene | Pane::Description | Pane::Scores => {
                let s = self.scroll.entry(pane).or_insert(0);
                *s = (i64::from(*s) + delta as i64).clamp(0, 500) as u16;
            }
        }
    }

    /// The neighbours of the graph view's node in the order the view lists
    /// them: the sources of the edges into it, then the targets of the edges
    /// out of it (a neighbour joined both ways appears twice).
    pub fn graph_neighbours(&self) -> Vec<usize> {
        let node = self.graph_cursor.node;
        self.graph
            .incoming(node)
            .map(|e| e.from)
            .chain(self.graph.outgoing(node).map(|e| e.to))
            .collect()
    }

    fn graph_enter(&mut self) {
        let neighbours = self.graph_neighbours();
        if let Some(&next) = neighbours.get(self.graph_cursor.neighbour) {
            let here = self.graph_cursor.node;
            self.graph_cursor.back.push(here);
            self.graph_cursor.node = next;
            self.graph_cursor.neighbour = 0;
        }
    }

    fn graph_back(&mut self) {
        if let Some(prev) = self.graph_cursor.back.pop() {
            self.graph_cursor.node = prev;
            self.graph_cursor.neighbour = 0;
        }
    }

    fn edit_step(&mut self, list: StepList, insert: Option<usize>) -> Vec<Cmd> {
        let (index, inserted) = match insert {
            Some(at) => {
                let at = at.min(self.steps(list).len());
                self.steps_mut(list).insert(at, String::new());
                (at, true)
            }
            None => {
                let sel = match list {
                    StepList::Plan => self.plan_selected,
                    StepList::GroundTruth => self.ground_truth_selected,
                };
                if sel >= self.steps(list).len() {
                    self.steps_mut(list).push(String::new());
                    (self.steps(list).len() - 1, true)
                } else {
                    (sel, false)
                }
            }
        };
        *self.selected_mut(list) = index;
        let text = self.steps(list)[index].clone();
        self.editing = Editing::Step {
            list,
            index,
            editor: single_line_editor(&text),
            inserted,
        };
        Vec::new()
    }

    fn step_command(&mut self, list: StepList, action: Action) -> Vec<Cmd> {
        let sel = match list {
            StepList::Plan => self.plan_selected,
            StepList::GroundTruth => self.ground_truth_selected,
        };
        let len = self.steps(list).len();
        match action {
            Action::EditStep => self.edit_step(list, None),
            Action::InsertAfter => self.edit_step(list, Some(sel + usize::from(len > 0))),
            Action::InsertBefore => self.edit_step(list, Some(sel)),
            Action::DeleteStep if sel < len => {
                self.steps_mut(list).remove(sel);
                *self.selected_mut(list) = sel.min(len.saturating_sub(2));
                vec![self.rescore()]
            }
            Action::StepDown if sel + 1 < len => {
                self.steps_mut(list).swap(sel, sel + 1);
                *self.selected_mut(list) = sel + 1;
                vec![self.rescore()]
            }
            Action::StepUp if sel > 0 && sel < len => {
                self.steps_mut(list).swap(sel, sel - 1);
                *self.selected_mut(list) = sel - 1;
                vec![self.rescore()]
            }
            _ => Vec::new(),
        }
    }

    /// Whether an editor (step, prompt or search) has the keyboard.
    pub fn is_editing(&self) -> bool {
        !matches!(self.editing, Editing::None)
    }

    /// The contexts whose bindings apply with no editor or overlay open,
    /// the focused pane's first.
    pub fn pane_contexts(&self) -> Vec<Context> {
        let pane = match self.focus {
            Pane::Plan | Pane::GroundTruth => Some(Context::Steps),
            Pane::Graph => Some(match self.graph_mode {
                GraphMode::Whole => Context::WholeGraph,
                GraphMode::Neighbourhood => Context::Graph,
            }),
            Pane::Prompt => Some(Context::Prompt),
            _ => None,
        };
        pane.into_iter().chain([Context::Panes]).collect()
    }

    fn on_command_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
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
                if self.zoom {
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
            Action::GraphEnter => self.graph_enter(),
            Action::GraphBack => self.graph_back(),
            Action::GraphNode(step) => {
                let n = self.graph.nodes.len().max(1) as isize;
                self.graph_cursor = GraphCursor {
                    node: (self.graph_cursor.node as isize + step).rem_euclid(n) as usize,
                    ..GraphCursor::default()
                };
            }
            Action::GraphSelect(step) => {
                if step > 0 {
                    self.graph_view.select_next();
                } else {
                    self.graph_view.select_prev();
                }
            }
            Action::GraphStep(direction) => {
                self.graph_view.step(direction);
            }
            Action::GraphZoom(step) => {
                if step > 0 {
                    self.graph_view.zoom_in();
                } else {
                    self.graph_view.zoom_out();
                }
            }
            Action::GraphMode => {
                self.graph_mode = match self.graph_mode {
                    GraphMode::Whole => GraphMode::Neighbourhood,
                    GraphMode::Neighbourhood => GraphMode::Whole,
                };
            }
            Action::PromptStep(step) => self.move_selection(Pane::Prompt, step),
            Action::EditPrompt => {
                self.prompt_editor
                    .move_cursor(ratatui_textarea::CursorMove::Bottom);
                self.prompt_editor
                    .move_cursor(ratatui_textarea::CursorMove::End);
                self.editing = Editing::Prompt;
            }
            Action::PromptOf(position) => {
                if let Some(&agent) = roles(self.approach).get(position) {
                    self.store_prompt_editor();
                    self.prompt_agent = agent;
                    self.load_prompt_editor();
                }
            }
            Action::Run => return self.start_run(false),
            Action::RunAll => return self.start_run(true),
            Action::CancelRun => return self.cancel_run(),
            Action::ChooseGroundTruth => {
                let choices = self.ground_truth_choices();
                let selected = choices
                    .iter()
                    .position(|(c, _)| match (c, &self.ground_truth_source) {
                        (GroundTruthChoice::Demo(i), GroundTruthSource::Demo { index }) => {
                            i == index
                        }
                        (GroundTruthChoice::Task(i), GroundTruthSource::Dataset { task }) => self
                            .dataset
                            .as_ref()
                            .and_then(|d| d.tasks.get(*i))
                            .is_some_and(|t| &t.id == task),
                        _ => false,
                    })
                    .unwrap_or(0);
                self.overlay = Some(Overlay::GroundTruthPicker { selected });
            }
            Action::NextApproach => return self.cycle_approach(),
            Action::PublishedPlan => {
                self.load_published_plan();
                if self.plan.is_empty() {
                    self.set_status(
                        format!("this task has no published {} plan", self.approach),
                        Severity::Info,
                    );
                }
                return vec![self.rescore()];
            }
            Action::ModelForm => {
                let agent = if self.focus == Pane::Prompt {
                    self.prompt_agent
                } else {
                    match self.focus {
                        Pane::Graph => AgentRole::Skm,
                        Pane::Description => AgentRole::Gkm,
                        _ => planning_role(self.approach),
                    }
                };
                self.open_model_form(agent);
            }
            Action::ToggleImage => {
                self.image_enabled = !self.image_enabled;
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
            Action::Actions => self.overlay = Some(Overlay::Actions),
            Action::History => {
                self.overlay = Some(Overlay::Runs {
                    selected: self.runs.len().saturating_sub(1),
                    marked: None,
                })
            }
            Action::Accept | Action::Leave | Action::RunFromEditor => {}
        }
        Vec::new()
    }

    fn pane_at(&self, column: u16, row: u16) -> Option<(Pane, Rect)> {
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        match pane_rects(screen, self.focus, self.zoom) {
            Screen::Panes { panes, .. } => panes
                .into_iter()
                .find(|(_, r)| r.contains(Position::new(column, row))),
            Screen::TooSmall => None,
        }
    }

    fn on_mouse(&mut self, mouse: MouseEvent) -> Vec<Cmd> {
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
                            super::ui::list_window(self.plan_selected, self.plan.len(), 2, height)
                                .0;
                        let target = first + row / 2;
                        if target < self.plan.len() {
                            self.plan_selected = target;
                        }
                    }
                    Pane::GroundTruth => {
                        let first = super::ui::list_window(
                            self.ground_truth_selected,
                            self.ground_truth.len(),
                            2,
                            height,
                        )
                        .0;
                        let target = first + row / 2;
                        if target < self.ground_truth.len() {
                            self.ground_truth_selected = target;
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

    /// The terminal area the scene image should be encoded for, when it is
    /// shown and not yet encoded for that area.
    pub fn image_area_wanted(&self) -> Option<Rect> {
        if !self.image_enabled || self.scene.is_none() {
            return None;
        }
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        let Screen::Panes { panes, .. } = pane_rects(screen, self.focus, self.zoom) else {
            return None;
        };
        let (_, rect) = panes.into_iter().find(|(p, _)| *p == Pane::Scene)?;
        let inner = super::ui::scene_image_area(rect);
        if inner.width == 0 || inner.height == 0 {
            return None;
        }
        match &self.scene_protocol {
            Some((r, _)) if *r == inner => None,
            _ => Some(inner),
        }
    }
}
