//! The commands of `update` carried out to their end on the calling thread,
//! in order, with no terminal: the runtime that tests and benchmarks drive
//! the workbench with. It does what the loop's [`super::runtime`] does (runs
//! through the same [`Pipeline`], scoring with the same [`score_now`], the
//! same file readers), only synchronously, so that a test sees every
//! message a command produces before it asserts.

use std::path::Path;

use super::agents::{run_blocking, Pipeline};
use super::app::App;
use super::corrupting::{corrupt_plan, CorruptError, CorruptionModels};
use super::graphics::Graphics;
use super::message::{Cmd, Msg, ReadError};
use super::scene_image;
use super::scoring::{score_now, score_samples, ModelSlot};
use crate::agents::prompt_sets;

/// Reads a step file off the loop: the text, or why not.
pub fn read_step_file(path: &Path) -> Result<String, ReadError> {
    Ok(crate::dataset::read_text_within(
        path,
        crate::limits::MAX_STEP_FILE_BYTES,
        "a step file",
    )?)
}

/// Encodes the scene image for the area the app wants it in, if any, here
/// and now (the loop hands this to a task).
pub fn prepare_image(app: &mut App, graphics: &Graphics) {
    if let Some((area, image)) = app.request_image() {
        let encoded = scene_image::encode(graphics, &image, area).map(|(_, protocol)| protocol);
        app.update(Msg::ImageReady(area, encoded));
    }
}

/// Carries out commands with a pipeline and the PG2S models in a slot.
pub struct Headless<'a> {
    pipeline: &'a dyn Pipeline,
    models: ModelSlot,
    corruption: Result<CorruptionModels, CorruptError>,
}

impl<'a> Headless<'a> {
    /// A runner of `pipeline`'s runs, scoring with `models`.
    pub fn new(pipeline: &'a dyn Pipeline, models: ModelSlot) -> Self {
        Self {
            pipeline,
            models,
            corruption: Err(CorruptError::StillLoading),
        }
    }

    /// The same runner corrupting plans with `models` (without, a
    /// corruption says the models are still loading).
    pub fn with_corruption(self, models: CorruptionModels) -> Self {
        Self {
            corruption: Ok(models),
            ..self
        }
    }

    /// Carries out `cmds` and every command their messages lead to, each
    /// message shown to `seen` (which may change it, e.g. to fix timings)
    /// before `app` gets it. A cancel has nothing to stop: runs end before
    /// the next command.
    pub fn run(&self, app: &mut App, cmds: Vec<Cmd>, seen: &mut dyn FnMut(&mut Msg)) {
        let mut queue = std::collections::VecDeque::from(cmds);
        while let Some(cmd) = queue.pop_front() {
            let msgs = match cmd {
                Cmd::StartRun(request) => {
                    let run = request.run;
                    match run_blocking(self.pipeline, request) {
                        Ok((settings, events)) => {
                            app.run_accepted(run, settings);
                            events.into_iter().map(|e| Msg::Agent(run, e)).collect()
                        }
                        Err(reason) => {
                            app.run_refused(run, reason);
                            Vec::new()
                        }
                    }
                }
                Cmd::CancelRun(_) => Vec::new(),
                Cmd::Score(request) => vec![Msg::Scored(score_now(&self.models, &request))],
                Cmd::ScoreSamples(request) => vec![Msg::SamplesScored(
                    request.run,
                    score_samples(&self.models, &request),
                )],
                Cmd::ReadStepFile(path) => {
                    let text = read_step_file(&path);
                    vec![Msg::StepFile(path, text)]
                }
                Cmd::LoadImage(path) => vec![Msg::SceneImage(scene_image::read(&path))],
                Cmd::SavePromptSet { root, name, set } => {
                    let saved = prompt_sets::save(&root, &name, &set);
                    vec![Msg::PromptSetSaved(name, saved)]
                }
                Cmd::ListPromptSets(root) => vec![Msg::PromptSets(prompt_sets::list(&root))],
                Cmd::LoadPromptSet { root, name } => {
                    let loaded = prompt_sets::load(&root, &name);
                    vec![Msg::PromptSetLoaded(name, loaded)]
                }
                Cmd::Corrupt(request) => {
                    let result = match &self.corruption {
                        Ok(models) => corrupt_plan(models, &request),
                        Err(reason) => Err(reason.clone()),
                    };
                    vec![Msg::Corrupted(result)]
                }
            };
            for mut msg in msgs {
                seen(&mut msg);
                queue.extend(app.update(msg));
            }
        }
    }
}
