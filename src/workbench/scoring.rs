//! Live scoring: a background worker that takes the latest plan and ground
//! truth, waits a moment for typing to settle, and computes KAS and (once the
//! models have loaded in the background) PG2S.

use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

use tokio::sync::{mpsc::UnboundedSender, watch};

use super::corrupting::{CorruptError, CorruptionModels, SharedCorruptionModels};
use crate::metrics::kas::{kas, KasReport};
use crate::metrics::pg2s::{Pg2sReport, Pg2sScorer};
use crate::workbench::session::ScoreRecord;

/// A plan and ground truth to score; `generation` orders requests so a late
/// answer to an old request is ignored.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreRequest {
    /// Increases with every change of plan or ground truth.
    pub generation: u64,
    /// The ground-truth steps.
    pub gt: Vec<String>,
    /// The predicted steps.
    pub pred: Vec<String>,
}

/// The PG2S half of a score.
#[derive(Debug, Clone, PartialEq)]
pub enum Pg2sOutcome {
    /// Computed.
    Ready(Box<Pg2sReport>),
    /// Not computed yet: the models are still loading or are missing (the reason).
    Waiting(String),
    /// The scorer failed on this input.
    Failed(String),
}

/// The scores of one request.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreOutcome {
    /// The request's generation.
    pub generation: u64,
    /// KAS with its per-step scores.
    pub kas: KasReport,
    /// PG2S with its matches, or why not.
    pub pg2s: Pg2sOutcome,
    /// How long scoring took, in milliseconds.
    pub millis: f64,
}

/// Where the PG2S models stand: shared by the loader and the scoring worker
/// (which scores with the loaded scorer) and held by the app (which shows
/// the state in the status bar).
#[derive(Clone)]
pub enum ModelSlot {
    /// Loading, with the latest progress line.
    Loading(String),
    /// Loaded.
    Ready(Arc<Pg2sScorer>),
    /// Not available, with the reason and what to do.
    Unavailable(String),
}

/// The models slot shared by the loader, the worker and the app.
pub type SharedModels = Arc<RwLock<ModelSlot>>;

/// What the loader loads: the PG2S scorer and, in the types the Plan
/// pane's corruptions need, the English pipeline and word vectors it holds.
pub struct Loaded {
    /// The scorer.
    pub scorer: Pg2sScorer,
    /// The same parser and vectors for corrupting plans, or why not.
    pub corruption: Result<CorruptionModels, CorruptError>,
}

/// Why the PG2S models could not be loaded: the Scores pane shows it and
/// scoring waits (KAS still scores).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LoadError {
    /// The model pack could not be read or a model could not be built: the
    /// loader's words, causes included, saying what to do.
    #[error("{reason}")]
    Models {
        /// What went wrong.
        reason: String,
    },
}

/// Loads the PG2S scorer; called on a blocking thread, reporting progress
/// lines through the callback.
pub type ScorerLoader =
    Box<dyn FnOnce(&dyn Fn(String)) -> Result<Loaded, LoadError> + Send + 'static>;

/// Scores one request now, with whatever models the slot holds.
pub fn score_now(models: &ModelSlot, request: &ScoreRequest) -> ScoreOutcome {
    let started = Instant::now();
    let kas = kas(&request.gt, &request.pred);
    let pg2s = match models {
        ModelSlot::Ready(scorer) => match scorer.score(&request.gt, &request.pred) {
            Ok(report) => Pg2sOutcome::Ready(Box::new(report)),
            Err(e) => Pg2sOutcome::Failed(e.to_string()),
        },
        ModelSlot::Loading(progress) => Pg2sOutcome::Waiting(format!("models loading: {progress}")),
        ModelSlot::Unavailable(reason) => Pg2sOutcome::Waiting(reason.clone()),
    };
    ScoreOutcome {
        generation: request.generation,
        kas,
        pg2s,
        millis: started.elapsed().as_secs_f64() * 1000.0,
    }
}

/// The later samples of a run to score against the run's ground truth
/// (the first is scored live, as the Plan pane shows it).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleScoring {
    /// The run's id.
    pub run: u64,
    /// The ground-truth steps.
    pub gt: Vec<String>,
    /// Each sample's index and plan.
    pub plans: Vec<(u32, Vec<String>)>,
}

/// The scores a run keeps of an outcome.
pub fn score_record(outcome: &ScoreOutcome) -> ScoreRecord {
    let report = match &outcome.pg2s {
        Pg2sOutcome::Ready(r) => Some(r),
        _ => None,
    };
    ScoreRecord {
        kas: outcome.kas.kas,
        s_plan: report.map(|r| r.s_plan),
        s_goal: report.and_then(|r| r.s_goal()),
        pg2s: report.and_then(|r| r.pg2s()),
    }
}

/// Scores each sample of `request` with whatever models the slot holds:
/// each sample's index and scores.
pub fn score_samples(models: &ModelSlot, request: &SampleScoring) -> Vec<(u32, ScoreRecord)> {
    request
        .plans
        .iter()
        .map(|(sample, plan)| {
            let one = ScoreRequest {
                generation: 0,
                gt: request.gt.clone(),
                pred: plan.clone(),
            };
            (*sample, score_record(&score_now(models, &one)))
        })
        .collect()
}

/// The models in `models` once they are no longer loading (checked every
/// 200 ms), for scoring that must not go without PG2S only because the
/// models were still loading.
pub fn loaded_models(models: &SharedModels) -> ModelSlot {
    loop {
        let slot = models
            .read()
            .map(|s| s.clone())
            .unwrap_or_else(|p| p.into_inner().clone());
        if !matches!(slot, ModelSlot::Loading(_)) {
            return slot;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Runs the scoring worker until the request channel closes: after each
/// change it waits `debounce`, then scores the latest request on a blocking
/// thread and sends the outcome.
pub async fn worker(
    mut requests: watch::Receiver<Option<ScoreRequest>>,
    models: SharedModels,
    debounce: Duration,
    send: impl Fn(ScoreOutcome) + Send + 'static,
) {
    while requests.changed().await.is_ok() {
        tokio::time::sleep(debounce).await;
        let Some(request) = requests.borrow_and_update().clone() else {
            continue;
        };
        let slot = models
            .read()
            .map(|s| s.clone())
            .unwrap_or_else(|p| p.into_inner().clone());
        match tokio::task::spawn_blocking(move || score_now(&slot, &request)).await {
            Ok(outcome) => send(outcome),
            Err(_) => continue,
        }
    }
}

/// Loads the models on a blocking thread, keeping the slot's progress line
/// current, puts the corruption models in `corruption`, and sends `done`
/// the final slot.
pub fn spawn_loader(
    loader: ScorerLoader,
    models: SharedModels,
    corruption: SharedCorruptionModels,
    done: UnboundedSender<ModelSlot>,
) {
    tokio::task::spawn_blocking(move || {
        let progress_slot = models.clone();
        let progress = move |line: String| {
            if let Ok(mut slot) = progress_slot.write() {
                *slot = ModelSlot::Loading(line);
            }
        };
        let (slot, language) = match loader(&progress) {
            Ok(loaded) => (ModelSlot::Ready(Arc::new(loaded.scorer)), loaded.corruption),
            Err(error) => (
                ModelSlot::Unavailable(error.to_string()),
                Err(CorruptError::Unavailable(error.to_string())),
            ),
        };
        if let Ok(mut shared) = corruption.write() {
            *shared = language;
        }
        if let Ok(mut shared) = models.write() {
            *shared = slot.clone();
        }
        let _ = done.send(slot);
    });
}
