//! The commands of `update` carried out to their end on the calling thread,
//! in order, with no terminal: the runtime that tests and benchmarks drive
//! the workbench with. It carries each command out with the loop's own
//! [`execute`], only doing the work here and now instead of in background
//! tasks, so that a test sees every message a command produces before it
//! asserts.

use std::collections::VecDeque;

use super::agents::{run_events, Pipeline, RunError, RunRequest};
use super::app::App;
use super::corrupting::{CorruptError, CorruptionModels};
use super::execute::{execute, Carrier, Job, Models};
use super::graphics::Graphics;
use super::message::{Cmd, Msg};
use super::scene_image;
use super::scoring::{score_now, ModelSlot, ScoreRequest};

/// Encodes the scene image for the area the app wants it in, if any, here
/// and now (the loop hands this to a task).
pub fn prepare_image(app: &mut App, graphics: &Graphics) {
    if let Some(request) = app.request_image() {
        let area = request.area;
        let encoded = scene_image::encode(graphics, &request.image, area, request.background)
            .map(|(_, protocol)| protocol);
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
    /// the next command. Of the score requests queued together only the
    /// last is carried out, as in the loop.
    pub fn run(&self, app: &mut App, cmds: Vec<Cmd>, seen: &mut dyn FnMut(&mut Msg)) {
        let mut queue = VecDeque::from(cmds);
        let mut here = HereAndNow {
            headless: self,
            answers: Vec::new(),
        };
        while let Some(cmd) = queue.pop_front() {
            // A score request with a later one queued is out of date: as
            // the loop's latest-only channel does, only the last is scored.
            let outdated = matches!(cmd, Cmd::Score(_))
                && queue.iter().any(|later| matches!(later, Cmd::Score(_)));
            if outdated {
                continue;
            }
            execute(cmd, app, &mut here);
            for mut msg in std::mem::take(&mut here.answers) {
                seen(&mut msg);
                queue.extend(app.update(msg));
            }
        }
    }
}

/// The [`Carrier`] of [`Headless`]: every job done at once, its messages
/// kept for `update` in order.
struct HereAndNow<'h, 'a> {
    headless: &'h Headless<'a>,
    answers: Vec<Msg>,
}

impl Carrier for HereAndNow<'_, '_> {
    fn pipeline(&self) -> &dyn Pipeline {
        self.headless.pipeline
    }

    fn models(&self) -> Models {
        Models::Fixed(self.headless.models.clone())
    }

    fn corruption(&self) -> Result<CorruptionModels, CorruptError> {
        self.headless.corruption.clone()
    }

    fn spawn(&mut self, job: Job) {
        self.answers.extend(job());
    }

    fn start_run(&mut self, request: RunRequest) -> Result<(), RunError> {
        let run = request.run;
        let events = run_events(self.headless.pipeline, request)?;
        self.answers
            .extend(events.into_iter().map(|e| Msg::Agent(run, e)));
        Ok(())
    }

    fn cancel_run(&mut self, _run: u64) {}

    fn score(&mut self, request: ScoreRequest) {
        let scored = score_now(&self.headless.models, &request);
        self.answers.push(Msg::Scored(scored));
    }
}
