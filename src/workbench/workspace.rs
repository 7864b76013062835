//! The session's data that no pane owns — the task, the dataset, the
//! approach, where the plans came from and their scores — and the
//! workbench's looks, status messages and saving: the parts of
//! [`crate::workbench::app::App`] every component may read. A leaf below
//! the panes, so reading them never makes an import circle.

use std::collections::BTreeMap;
use std::path::PathBuf;

use crate::agents::config::AgentSettings;
use crate::agents::cost::PriceTable;
use crate::agents::{AgentRole, Approach};
use crate::dataset::{Dataset, Task};
use crate::demo;
use crate::workbench::persist::Persist;
use crate::workbench::scoring::{ModelSlot, ScoreOutcome};
use crate::workbench::session::{GroundTruthSource, PlanSource, SessionError, SourceState};
use crate::workbench::shared::{LogEntry, Severity};
use crate::workbench::theme::Theme;

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
}

impl Workspace {
    /// Whether the demo is what is loaded (no dataset task).
    pub fn is_demo(&self) -> bool {
        self.task.id.is_none()
    }

    /// Whether scores are being computed for the latest change.
    pub fn scoring(&self) -> bool {
        self.scores
            .as_ref()
            .is_none_or(|s| s.generation < self.score_generation)
    }

    /// Whether the Scene pane shows the task's table instead of its
    /// picture: on a table approach, for a task with a table file.
    pub fn shows_table(&self) -> bool {
        !self.approach.uses_image() && self.task.table.is_some()
    }
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

/// The built-in demo as the task in use.
pub fn demo_task() -> TaskView {
    TaskView {
        id: None,
        text: demo::TASK.trim().to_string(),
        image: None,
        table: None,
        published: BTreeMap::new(),
    }
}

/// A dataset task as the task in use.
pub fn task_view(task: &Task) -> TaskView {
    TaskView {
        id: Some(task.id.clone()),
        text: task.task.clone(),
        image: task.image.clone(),
        table: task.table.clone(),
        published: task.plans.clone(),
    }
}
