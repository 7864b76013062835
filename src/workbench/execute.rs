//! Carrying out a command of `update`: the one function ([`execute`]) with
//! the one `match` over [`Cmd`], used by the loop ([`super::runtime`]) and
//! by the tests and benchmarks ([`super::headless`]). What differs between
//! the two is only where the work runs (a background task, or here and
//! now), which a [`Carrier`] says.

use std::path::Path;

use super::agents::{Pipeline, RunError, RunRequest};
use super::app::App;
use super::corrupting::{corrupt_plan, CorruptError, CorruptionModels};
use super::message::{Cmd, Msg, ReadError};
use super::scene_image;
use super::scoring::{loaded_models, score_samples, ModelSlot, ScoreRequest, SharedModels};
use crate::agents::prompt_sets;

/// Work done off `update` that answers with messages (reading a file,
/// scoring samples, corrupting a plan): the carrier runs it where it runs
/// work and hands the messages to `update`.
pub type Job = Box<dyn FnOnce() -> Vec<Msg> + Send>;

/// Where the PG2S models are for a job: a slot as it is (the tests), or
/// the slot the loader fills, waited for until loaded (the loop).
#[derive(Clone)]
pub enum Models {
    /// These, as they are.
    Fixed(ModelSlot),
    /// The loader's slot, read when loaded.
    Shared(SharedModels),
}

impl Models {
    /// The models once loaded (or why they are not); blocks while the
    /// loader's slot is still loading, so call it inside a job.
    pub fn wait(&self) -> ModelSlot {
        match self {
            Models::Fixed(slot) => slot.clone(),
            Models::Shared(shared) => loaded_models(shared),
        }
    }
}

/// What carries commands out: the loop's runtime or the tests' headless
/// runner. Each says where work runs; [`execute`] says what the work is.
pub trait Carrier {
    /// The pipeline runs go through.
    fn pipeline(&self) -> &dyn Pipeline;
    /// The PG2S models jobs score with.
    fn models(&self) -> Models;
    /// The models the Plan pane's corruptions use, as they are now.
    fn corruption(&self) -> Result<CorruptionModels, CorruptError>;
    /// Runs `job` and hands its messages to `update`.
    fn spawn(&mut self, job: Job);
    /// Starts a run the pipeline accepted, its events going to `update`.
    fn start_run(&mut self, request: RunRequest) -> Result<(), RunError>;
    /// Stops a run, if it is still going.
    fn cancel_run(&mut self, run: u64);
    /// Scores the plan against the ground truth (the loop debounces).
    fn score(&mut self, request: ScoreRequest);
}

/// Reads a step file off the loop: the text, or why not.
pub fn read_step_file(path: &Path) -> Result<String, ReadError> {
    Ok(crate::dataset::read_text_within(
        path,
        crate::limits::MAX_STEP_FILE_BYTES,
        "a step file",
    )?)
}

/// Carries out `cmd` for `app` with `carrier`: the one place that says what
/// each command does.
pub fn execute(cmd: Cmd, app: &mut App, carrier: &mut dyn Carrier) {
    match cmd {
        Cmd::StartRun(request) => {
            let run = request.run;
            match carrier.pipeline().check(&request) {
                Ok(settings) => app.run_accepted(run, settings),
                Err(reason) => return app.run_refused(run, reason),
            }
            if let Err(reason) = carrier.start_run(request) {
                app.run_refused(run, reason);
            }
        }
        Cmd::PriceFreshRun(request) => {
            let price = carrier.pipeline().estimate(&request, &app.work.prices);
            carrier.spawn(Box::new(move || {
                vec![Msg::FreshRunPriced(price().map_err(|e| e.to_string()))]
            }));
        }
        Cmd::CancelRun(run) => carrier.cancel_run(run),
        Cmd::Score(request) => carrier.score(request),
        Cmd::ScoreSamples(request) => {
            let models = carrier.models();
            carrier.spawn(Box::new(move || {
                let scores = score_samples(&models.wait(), &request);
                vec![Msg::SamplesScored(request.run, scores)]
            }));
        }
        Cmd::ReadStepFile(path) => carrier.spawn(Box::new(move || {
            let text = read_step_file(&path);
            vec![Msg::StepFile(path, text)]
        })),
        Cmd::LoadTable(path) => carrier.spawn(Box::new(move || {
            let rendered = crate::agents::prompts::render_table(&path).map_err(|e| e.to_string());
            vec![Msg::Table(path, rendered)]
        })),
        Cmd::LoadImage(path) => carrier.spawn(Box::new(move || {
            vec![Msg::SceneImage(scene_image::read(&path))]
        })),
        Cmd::SavePromptSet { root, name, set } => carrier.spawn(Box::new(move || {
            let saved = prompt_sets::save(&root, &name, &set);
            vec![Msg::PromptSetSaved(name, saved)]
        })),
        Cmd::ListPromptSets(root) => carrier.spawn(Box::new(move || {
            vec![Msg::PromptSets(prompt_sets::list(&root))]
        })),
        Cmd::LoadPromptSet { root, name } => carrier.spawn(Box::new(move || {
            let loaded = prompt_sets::load(&root, &name);
            vec![Msg::PromptSetLoaded(name, loaded)]
        })),
        Cmd::Corrupt(request) => {
            let models = carrier.corruption();
            carrier.spawn(Box::new(move || {
                let result = models.and_then(|m| corrupt_plan(&m, &request));
                vec![Msg::Corrupted(result)]
            }));
        }
    }
}
