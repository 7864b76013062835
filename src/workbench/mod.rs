//! The terminal workbench: ratatui on crossterm, driven by tokio in the Elm
//! architecture. [`app`] is the model, [`message`] what happens to it,
//! [`update`] the one place it changes, [`render`] a pure function from it
//! to a frame, and [`runtime`] the loop that carries out the commands
//! `update` returns ([`headless`] carries them out synchronously, for tests
//! and benchmarks). Each pane ([`panes`]) and overlay ([`overlays`]) keeps
//! its state, keys and drawing in its own module; every key is declared
//! once in [`keymap`]. Agent runs, scoring, model loading, file reads and
//! session saves happen in background tasks that send messages; the loop
//! never waits on I/O.

pub mod agents;
pub mod annotate;
pub mod app;
pub mod component;
pub mod corrupting;
pub mod editing;
pub mod execute;
pub mod graph_layout;
pub mod graph_view;
pub mod graphics;
pub mod header;
pub mod headless;
pub mod keymap;
pub mod layout;
pub mod message;
pub mod overlays;
pub mod panes;
pub mod persist;
pub mod render;
pub mod run_diff;
pub mod runs;
pub mod runtime;
pub mod saver;
pub mod scene_image;
pub mod scoring;
pub mod scroll;
pub mod session;
pub mod shared;
pub mod snapshot;
pub mod terminal_query;
pub mod theme;
pub mod undo;
pub mod update;
pub mod workspace;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crate::agents::config::{AgentSettings, ConfigError};
use crate::agents::cost::PriceTable;
use crate::agents::AgentRole;
use crate::dataset::{Dataset, LineError};
use agents::Pipeline;
use scoring::ScorerLoader;

pub use headless::prepare_image;
pub use runtime::run;

/// How long scoring waits for typing to settle.
pub const SCORE_DEBOUNCE: Duration = Duration::from_millis(25);
/// The longest a change waits before the session is saved.
pub const SAVE_EVERY: Duration = Duration::from_millis(300);

/// What the workbench is started with.
pub struct Options {
    /// The dataset to choose tasks from (`--dataset`), loaded before the
    /// screen opens so that one that cannot be read is refused, with its
    /// lines that could not be used (said once at the start).
    pub dataset: Option<(Dataset, Vec<LineError>)>,
    /// The session file (`--session`, else [`session::default_path`]);
    /// `None` when there is no place for one, and nothing is saved.
    pub session: Option<PathBuf>,
    /// The themes to choose from (built-in and the user's), loaded once
    /// before the screen opens so that `--theme` is checked against them.
    pub themes: Vec<theme::Theme>,
    /// The user's theme files that could not be used, said at the start.
    pub theme_problems: Vec<String>,
    /// The theme to start with, by name.
    pub theme: Option<String>,
    /// Loads the PG2S models, in the background.
    pub scorer: ScorerLoader,
    /// Runs the agents.
    pub pipeline: Arc<dyn Pipeline>,
    /// The prompt templates' texts by name ([`agents::prompt_texts`]).
    pub prompts: BTreeMap<String, String>,
    /// How the scene image is drawn (`--graphics`): `auto` asks the terminal.
    pub graphics: graphics::Request,
    /// How long the terminal has to answer the start-up query.
    pub query_timeout: Duration,
    /// The config file's price table for the run history's costs, or why
    /// its `[prices]` section cannot be used (shown once at the start).
    pub prices: Result<PriceTable, ConfigError>,
    /// How many samples `r` asks each agent for, over the session's setting
    /// (`--samples`).
    pub samples: Option<u32>,
    /// The agents the config file and the environment configure, with the
    /// settings they start with on a user's task, or why the config cannot
    /// give them (shown once at the start; every agent then replays).
    pub configured: Result<BTreeMap<AgentRole, AgentSettings>, ConfigError>,
    /// The folder of the named prompt sets
    /// ([`crate::agents::prompt_sets::default_root`]).
    pub prompt_sets: Option<PathBuf>,
}

/// Why the workbench could not run.
#[derive(Debug, thiserror::Error)]
pub enum TuiError {
    /// The terminal could not be set up or drawn on.
    #[error("terminal: {0}")]
    Terminal(#[from] std::io::Error),
}
