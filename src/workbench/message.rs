//! What happens to the workbench ([`Msg`]) and the work it asks the runtime
//! to do outside `update` ([`Cmd`]).

use std::path::PathBuf;
use std::sync::Arc;

use crossterm::event::{KeyEvent, MouseEvent};
use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui_image::protocol::Protocol;

use crate::agents::pipeline::AgentEvent;
use crate::workbench::agents::RunRequest;
use crate::workbench::scoring::{ModelSlot, ScoreOutcome, ScoreRequest};

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
    /// The models loaded ([`ModelSlot::Ready`]), or why not.
    ModelsLoaded(ModelSlot),
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
