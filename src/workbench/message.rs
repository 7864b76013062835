//! What happens to the workbench ([`Msg`]) and the work it asks the runtime
//! to do outside `update` ([`Cmd`]).

use std::path::PathBuf;
use std::sync::Arc;

use crossterm::event::{KeyEvent, MouseEvent};
use image::DynamicImage;
use ratatui::layout::Rect;

use crate::agents::cost::Estimate;
use crate::agents::pipeline::AgentEvent;
use crate::agents::prompt_sets::PromptSetError;
use crate::agents::prompts::PromptSet;
use crate::dataset::DatasetError;
use crate::workbench::agents::RunRequest;
use crate::workbench::corrupting::{CorruptError, CorruptRequest, Corrupted};
use crate::workbench::graphics::Drawing;
use crate::workbench::scene_image::SceneImageError;
use crate::workbench::scoring::{ModelSlot, SampleScoring, ScoreOutcome, ScoreRequest};
use crate::workbench::session::ScoreRecord;
use crate::workbench::session::SessionError;

/// Why a step file the workbench asked the runtime for could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read as text.
    #[error(transparent)]
    Text(#[from] DatasetError),
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
    /// The later samples of a run were scored: the run and each sample's
    /// index and scores.
    SamplesScored(u64, Vec<(u32, ScoreRecord)>),
    /// The models made progress loading.
    ModelsProgress(String),
    /// The models loaded ([`ModelSlot::Ready`]), or why not.
    ModelsLoaded(ModelSlot),
    /// A step file was read.
    StepFile(PathBuf, Result<String, ReadError>),
    /// The scene image was read.
    SceneImage(Result<Arc<DynamicImage>, SceneImageError>),
    /// The task's table file was rendered as its agents read it, or why it
    /// could not be.
    Table(PathBuf, Result<String, String>),
    /// The scene image was encoded for this area of the terminal.
    ImageReady(Rect, Result<Box<Drawing>, SceneImageError>),
    /// The session was saved, or why not.
    Saved(Result<(), SessionError>),
    /// The plan was corrupted, or why not.
    Corrupted(Result<Corrupted, CorruptError>),
    /// The prompt set of this name was saved in a folder, or why not.
    PromptSetSaved(String, Result<PathBuf, PromptSetError>),
    /// The names of the saved prompt sets, or why they cannot be listed.
    PromptSets(Result<Vec<String>, PromptSetError>),
    /// The prompt set of this name was read, or why not.
    PromptSetLoaded(String, Result<PromptSet, PromptSetError>),
    /// What asking every agent afresh (`R`) would cost, or why it could
    /// not be priced.
    FreshRunPriced(Result<Estimate, String>),
    /// The process was asked to stop (a signal).
    Quit,
}

/// A command for the runtime: work done outside `update`.
#[derive(Debug, Clone, PartialEq)]
pub enum Cmd {
    /// Start a run.
    StartRun(RunRequest),
    /// Price a run of every agent afresh before it is started (`R`).
    PriceFreshRun(RunRequest),
    /// Cancel a run.
    CancelRun(u64),
    /// Score the plan against the ground truth.
    Score(ScoreRequest),
    /// Score the later samples of a run.
    ScoreSamples(SampleScoring),
    /// Read a step file.
    ReadStepFile(PathBuf),
    /// Read the scene image.
    LoadImage(PathBuf),
    /// Read and render the task's table file.
    LoadTable(PathBuf),
    /// Corrupt the plan into a new run.
    Corrupt(CorruptRequest),
    /// Save `set` as the prompt set `name` under the folder `root`.
    SavePromptSet {
        /// The folder of the sets.
        root: PathBuf,
        /// The set's name (checked).
        name: String,
        /// Every template, as the workbench has it.
        set: PromptSet,
    },
    /// List the prompt sets saved under this folder.
    ListPromptSets(PathBuf),
    /// Read the prompt set `name` from the folder `root`.
    LoadPromptSet {
        /// The folder of the sets.
        root: PathBuf,
        /// The set's name.
        name: String,
    },
}
