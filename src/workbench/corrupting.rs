//! Corrupting the plan from the Plan pane (`c`): the request the app makes,
//! the work a blocking task does with [`crate::corrupt`] and the English
//! pipeline and word vectors the scorer's loader already loaded, and the
//! answer that becomes a new run.

use std::sync::{Arc, RwLock};

use crate::corrupt::{Corrupter, Kind, Language, Vocabulary};
use crate::dataset::{Corruption, Pair};
use crate::nlp::en::EnPipeline;
use crate::nlp::wordvec::WordVectorTable;

/// What the swaps need, loaded once beside the PG2S models and shared.
#[derive(Clone)]
pub struct CorruptionModels {
    /// The English pipeline (the same one S_goal frames steps with).
    pub parser: Arc<EnPipeline>,
    /// The word vectors (the same ones S_goal compares words with).
    pub vectors: Arc<WordVectorTable>,
    /// The objects, places and verb pairs the swaps draw from.
    pub vocabulary: Arc<Vocabulary>,
}

/// The corruption models once loaded, else why not (still loading, or the
/// reason they cannot be).
pub type SharedCorruptionModels = Arc<RwLock<Result<CorruptionModels, CorruptError>>>;

/// Why the plan was not corrupted: one line for the status bar.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CorruptError {
    /// The loader has not finished: the slot says so until it is done.
    #[error(
        "the English pipeline and word vectors are still loading; try again when the status bar says models ready"
    )]
    StillLoading,
    /// The models or the vocabularies could not be loaded: the loader's
    /// words, saying what to do.
    #[error("{0}")]
    Unavailable(String),
    /// The kind does not apply to this plan (with the corrupter's reason,
    /// when it gave one).
    #[error("{kind} cannot corrupt this plan{}", .reason.as_ref().map_or_else(String::new, |r| format!(": {r}")))]
    NotApplicable {
        /// The kind asked for.
        kind: Kind,
        /// Why it does not apply.
        reason: Option<String>,
    },
}

/// A plan to corrupt into run `run`.
#[derive(Debug, Clone, PartialEq)]
pub struct CorruptRequest {
    /// The id the new run gets.
    pub run: u64,
    /// How to corrupt it.
    pub kind: Kind,
    /// The seed (the number of runs so far, so the same session gives the
    /// same corruption).
    pub seed: u64,
    /// The plan as it is in the Plan pane.
    pub plan: Vec<String>,
    /// Other tasks' plans, which `insert` draws a step from.
    pub others: Vec<Vec<String>>,
}

/// A corrupted plan, ready to become run `run`.
#[derive(Debug, Clone, PartialEq)]
pub struct Corrupted {
    /// The id the new run gets.
    pub run: u64,
    /// The plan it was made from.
    pub source: Vec<String>,
    /// The corrupted plan.
    pub plan: Vec<String>,
    /// The kind, seed and edits.
    pub corruption: Corruption,
}

/// Corrupts the request's plan, the way `mapvlm corrupt` does an item of
/// its own; the error says why the kind does not apply.
pub fn corrupt_plan(
    models: &CorruptionModels,
    request: &CorruptRequest,
) -> Result<Corrupted, CorruptError> {
    let corrupter = Corrupter {
        language: Language {
            parser: &models.parser,
            vectors: &models.vectors,
        },
        vocabulary: &models.vocabulary,
        seed: request.seed,
    };
    let mut items = vec![Pair::new("plan", Vec::new(), request.plan.clone())];
    if request.kind == Kind::Insert {
        // Steps for `insert` come from the other plans (items without a
        // task count as other tasks).
        items.extend(
            request
                .others
                .iter()
                .enumerate()
                .map(|(i, plan)| Pair::new(format!("other-{i}"), Vec::new(), plan.clone())),
        );
    }
    let (written, skipped) = corrupter.corrupt_items(&items, &[], &[request.kind]);
    let corrupted = written
        .into_iter()
        .find(|p| p.source.as_deref() == Some("plan"));
    match corrupted {
        Some(Pair {
            pred,
            corruption: Some(corruption),
            ..
        }) => Ok(Corrupted {
            run: request.run,
            source: request.plan.clone(),
            plan: pred,
            corruption,
        }),
        _ => Err(skipped.iter().find(|s| s.item == "plan").map_or(
            CorruptError::NotApplicable {
                kind: request.kind,
                reason: None,
            },
            |s| CorruptError::NotApplicable {
                kind: s.kind,
                reason: Some(s.reason.to_string()),
            },
        )),
    }
}
