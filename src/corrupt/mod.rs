//! Typed, seeded corruptions of plans (`annotate.md` §2): an object, place
//! or action swapped, steps reordered, dropped, repeated, taken from another
//! task or cut off, each recorded with its edits so that a metric's reaction
//! can be measured against a known damage.

pub mod blind;
mod draw;
mod structure;
mod swap;
mod vocab;

use std::collections::HashSet;
use std::fmt;
use std::str::FromStr;

use crate::dataset::{Corruption, Edit, Pair, SwappedWords};

pub use swap::{Language, NounClass};

/// The version of the corruption algorithm, recorded in every corruption:
/// the same seed gives the same file only under the same version. 2: no
/// swap between words that name the same thing, the task's object swapped
/// when the plan names it, `insert` from another trial and goal in the
/// plan's style, `duplicate` and `reorder` of more than navigation,
/// verb-swap similarity over the phrases.
pub const ALGORITHM: u32 = 2;

/// The root verbs of a step that only moves the agent (when every verb of
/// the step is one of them): `duplicate` never repeats such a step and
/// `reorder` never swaps two of them, since people take either for no
/// change.
pub const NAVIGATION_VERBS: [&str; 17] = [
    "walk", "go", "turn", "move", "head", "navigate", "proceed", "approach", "return", "step",
    "face", "come", "rotate", "travel", "continue", "enter", "back",
];
pub use vocab::{user_vocabulary_dir, Action, Vocabulary, VocabularyError, VOCABULARY_FILES};

/// Whether `step` only moves the agent (every verb one of
/// [`NAVIGATION_VERBS`], the root among them), as `duplicate` and `reorder`
/// decide it.
pub fn is_navigation_only(parser: &crate::nlp::en::EnPipeline, step: &str) -> bool {
    swap::parse_plan(parser, &[step.to_string()])
        .first()
        .is_some_and(swap::navigation_only)
}

/// A kind of corruption, named as on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// An object noun is replaced in every step by another object.
    ObjectSwap,
    /// A place or receptacle is replaced in every step by another one.
    PlaceSwap,
    /// A step's root verb becomes its opposite or a wrong action.
    VerbSwap,
    /// Two steps trade places.
    Reorder,
    /// One step is removed.
    Drop,
    /// One step is repeated.
    Duplicate,
    /// A step from another task's plan is inserted.
    Insert,
    /// The plan stops after half its steps.
    Truncate,
}

impl Kind {
    /// Every kind, in the order of the spec (the default of `--kinds`).
    pub const ALL: [Kind; 8] = [
        Self::ObjectSwap,
        Self::PlaceSwap,
        Self::VerbSwap,
        Self::Reorder,
        Self::Drop,
        Self::Duplicate,
        Self::Insert,
        Self::Truncate,
    ];

    /// The name on the command line, in item ids and in records.
    pub fn name(self) -> &'static str {
        match self {
            Self::ObjectSwap => "object-swap",
            Self::PlaceSwap => "place-swap",
            Self::VerbSwap => "verb-swap",
            Self::Reorder => "reorder",
            Self::Drop => "drop",
            Self::Duplicate => "duplicate",
            Self::Insert => "insert",
            Self::Truncate => "truncate",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let wanted = s.trim().to_ascii_lowercase().replace('_', "-");
        Self::ALL
            .into_iter()
            .find(|k| k.name() == wanted)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|k| k.name()).collect();
                format!("unknown kind `{s}`: use {}", names.join(", "))
            })
    }
}

/// A corrupted plan and what was changed to make it.
#[derive(Debug, Clone, PartialEq)]
pub struct Changed {
    /// The corrupted steps.
    pub steps: Vec<String>,
    /// One edit per changed step of the source plan.
    pub edits: Vec<Edit>,
    /// For swaps, the word-vector cosine of the two words.
    pub similarity: Option<f64>,
    /// For swaps, the two words.
    pub words: Option<SwappedWords>,
    /// For object and place swaps, whether the word names a thing of the task.
    pub touches_task: Option<bool>,
    /// For `reorder`, whether the two steps were neighbours.
    pub adjacent: Option<bool>,
}

impl Changed {
    fn new(steps: Vec<String>, edits: Vec<Edit>) -> Self {
        Changed {
            steps,
            edits,
            similarity: None,
            words: None,
            touches_task: None,
            adjacent: None,
        }
    }
}

/// Why a kind could not corrupt a plan (the item is then skipped, never
/// copied unchanged).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Unchanged {
    /// No noun of the class with a word vector is a direct object or object
    /// of a preposition.
    #[error("no {} noun (a direct object or object of a preposition, listed in {} and with a word vector)", match .0 { NounClass::Object => "object", NounClass::Place => "place" }, match .0 { NounClass::Object => "objects.txt", NounClass::Place => "places.txt" })]
    NoNoun(NounClass),
    /// Every word of the vocabulary is already in the plan or has no vector.
    #[error("every other word of the vocabulary that has a word vector is already in the plan (swapping `{0}`)")]
    NoReplacement(String),
    /// No step's root verb is a side of a verb pair.
    #[error("no step's root verb (with its particle) is listed in verbs.txt")]
    NoVerb,
    /// Every step has the same text.
    #[error("no two steps differ")]
    NoDistinctSteps,
    /// The plan has too few steps.
    #[error("the plan has fewer than {needed} steps")]
    TooShort {
        /// The fewest steps the kind needs.
        needed: usize,
    },
    /// No other task's plan has a step this plan lacks.
    #[error("no plan of another trial and goal has a step this plan lacks")]
    NoOtherStep,
    /// Every step only moves the agent (or no place for a copy is apart).
    #[error("no step does more than walk or turn, or none can be repeated apart from itself")]
    NoActionStep,
}

/// An item a kind could not corrupt.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Skipped {
    /// The item's id.
    pub item: String,
    /// The kind.
    pub kind: Kind,
    /// Why.
    pub reason: Unchanged,
}

impl fmt::Display for Skipped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} cannot corrupt it: {}",
            self.item, self.kind, self.reason
        )
    }
}

/// An edit that does not fit the plan it is applied to.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("edit of step {step} does not fit the plan: {message}")]
pub struct EditMismatch {
    /// The edit's step.
    pub step: usize,
    /// What does not fit.
    pub message: String,
}

/// Applies a corruption's edits to its source plan, giving the corrupted
/// plan: an edit with `from` replaces (`to`) or removes (no `to`) source step
/// `step`, which must read `from`; an edit without `from` adds `to` before
/// source step `step` (after the last when `step` is the plan's length).
pub fn apply_edits(source: &[String], edits: &[Edit]) -> Result<Vec<String>, EditMismatch> {
    let mut out = Vec::with_capacity(source.len() + edits.len());
    for e in edits {
        let fits = match &e.from {
            Some(from) => source.get(e.step) == Some(from),
            None => e.step <= source.len() && e.to.is_some(),
        };
        if !fits {
            return Err(EditMismatch {
                step: e.step,
                message: format!(
                    "the source has {} steps: {:?}",
                    source.len(),
                    source.get(e.step)
                ),
            });
        }
    }
    for k in 0..=source.len() {
        for e in edits.iter().filter(|e| e.step == k && e.from.is_none()) {
            out.extend(e.to.clone());
        }
        let Some(step) = source.get(k) else {
            break;
        };
        match edits.iter().find(|e| e.step == k && e.from.is_some()) {
            Some(e) => out.extend(e.to.clone()),
            None => out.push(step.clone()),
        }
    }
    Ok(out)
}

/// What the kinds of one item draw on besides its plan.
struct Inputs<'a> {
    /// The plan's parse, when a swap needs one.
    parsed: &'a [swap::ParsedStep],
    /// The words of the item's task, lowercase.
    task: &'a HashSet<String>,
    /// Whether each step only moves the agent (empty without a parse).
    navigation: &'a [bool],
    /// Every step of every item, with the index of its item.
    pool: &'a [(usize, &'a str)],
    /// Whether the item of that index is of another task.
    other: &'a dyn Fn(usize) -> bool,
}

/// Corrupts items: the models and vocabularies of the swaps and the seed of
/// every draw.
pub struct Corrupter<'a> {
    /// The English pipeline and the word vectors.
    pub language: Language<'a>,
    /// What the swaps draw from.
    pub vocabulary: &'a Vocabulary,
    /// The seed; with the item id and the kind it fixes every draw.
    pub seed: u64,
}

impl Corrupter<'_> {
    /// Every item followed by one corrupted item per requested kind that
    /// applies to it (id `SOURCE~KIND`, with the source's ground truth, task
    /// and image), and the (item, kind) pairs that did not apply. `trials`
    /// names the trial (scene) of each item, when known (empty: none known).
    /// Steps for `insert` come from the items of another trial and another
    /// `task` text (without a task text: another family).
    pub fn corrupt_items(
        &self,
        items: &[Pair],
        trials: &[Option<String>],
        kinds: &[Kind],
    ) -> (Vec<Pair>, Vec<Skipped>) {
        let mut out = Vec::with_capacity(items.len() * (kinds.len() + 1));
        let mut skipped = Vec::new();
        let needs_parse = kinds.iter().any(|k| {
            matches!(
                k,
                Kind::ObjectSwap
                    | Kind::PlaceSwap
                    | Kind::VerbSwap
                    | Kind::Reorder
                    | Kind::Duplicate
            )
        });
        let pool: Vec<(usize, &str)> = items
            .iter()
            .enumerate()
            .flat_map(|(j, other)| other.pred.iter().map(move |s| (j, s.as_str())))
            .collect();
        for (index, item) in items.iter().enumerate() {
            out.push(item.clone());
            let parsed = if needs_parse {
                swap::parse_plan(self.language.parser, &item.pred)
            } else {
                Vec::new()
            };
            let navigation: Vec<bool> = parsed.iter().map(swap::navigation_only).collect();
            let task = match (&item.task, needs_parse) {
                (Some(text), true) => swap::words_of(self.language.parser, text),
                _ => HashSet::new(),
            };
            let trial = |j: usize| trials.get(j).and_then(Option::as_deref);
            let other = |j: usize| {
                let apart = match (&items[j].task, &item.task) {
                    (Some(a), Some(b)) => a.trim() != b.trim(),
                    _ => items[j].family() != item.family(),
                };
                let elsewhere = match (trial(j), trial(index)) {
                    (Some(a), Some(b)) => a != b,
                    _ => true,
                };
                j != index && apart && elsewhere
            };
            let inputs = Inputs {
                parsed: &parsed,
                task: &task,
                navigation: &navigation,
                pool: &pool,
                other: &other,
            };
            for &kind in kinds {
                match self.corrupt(item, &inputs, kind) {
                    Ok(changed) => out.push(self.item(item, kind, changed)),
                    Err(reason) => skipped.push(Skipped {
                        item: item.id.clone(),
                        kind,
                        reason,
                    }),
                }
            }
        }
        (out, skipped)
    }

    /// One kind applied to one item's plan.
    fn corrupt(&self, item: &Pair, inputs: &Inputs, kind: Kind) -> Result<Changed, Unchanged> {
        let parsed = inputs.parsed;
        let draws = &mut draw::Draws::new(self.seed, &item.id, kind.name());
        let plan = &item.pred;
        let (language, vocabulary) = (self.language, self.vocabulary);
        let changed = match kind {
            Kind::ObjectSwap => swap::noun_swap(
                parsed,
                inputs.task,
                NounClass::Object,
                &vocabulary.objects,
                vocabulary,
                language,
                draws,
            ),
            Kind::PlaceSwap => swap::noun_swap(
                parsed,
                inputs.task,
                NounClass::Place,
                &vocabulary.places,
                vocabulary,
                language,
                draws,
            ),
            Kind::VerbSwap => swap::verb_swap(parsed, &vocabulary.verbs, language, draws),
            Kind::Reorder => structure::reorder(plan, inputs.navigation, draws),
            Kind::Drop => structure::drop(plan, draws),
            Kind::Duplicate => structure::duplicate(plan, inputs.navigation, draws),
            Kind::Insert => structure::insert(plan, inputs.pool, inputs.other, draws),
            Kind::Truncate => structure::truncate(plan),
        }?;
        if changed.steps == *plan {
            return Err(Unchanged::NoDistinctSteps);
        }
        Ok(changed)
    }

    /// The corrupted item of `source`.
    fn item(&self, source: &Pair, kind: Kind, changed: Changed) -> Pair {
        Pair {
            id: format!("{}~{}", source.id, kind.name()),
            gt: source.gt.clone(),
            pred: changed.steps,
            task: source.task.clone(),
            image: source.image.clone(),
            source: Some(source.id.clone()),
            group: None,
            corruption: Some(Corruption {
                kind: kind.name().to_string(),
                seed: self.seed,
                edits: changed.edits,
                similarity: changed.similarity,
                words: changed.words,
                touches_task: changed.touches_task,
                adjacent: changed.adjacent,
                version: Some(ALGORITHM),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(steps: &[&str]) -> Vec<String> {
        steps.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn kinds_are_named_as_on_the_command_line() {
        for kind in Kind::ALL {
            assert_eq!(kind.name().parse::<Kind>(), Ok(kind));
        }
        assert_eq!("Object_Swap".parse::<Kind>(), Ok(Kind::ObjectSwap));
        let err = "swap".parse::<Kind>().unwrap_err();
        assert!(err.contains("object-swap, place-swap"), "{err}");
    }

    #[test]
    fn edits_apply_in_source_order_and_must_fit() {
        let source = plan(&["A.", "B.", "C."]);
        let edit = |step, from: Option<&str>, to: Option<&str>| Edit {
            step,
            from: from.map(String::from),
            to: to.map(String::from),
        };
        let edits = [
            edit(0, None, Some("Z.")),
            edit(1, Some("B."), None),
            edit(2, Some("C."), Some("D.")),
            edit(3, None, Some("E.")),
        ];
        assert_eq!(
            apply_edits(&source, &edits),
            Ok(plan(&["Z.", "A.", "D.", "E."]))
        );
        assert!(apply_edits(&source, &[edit(1, Some("X."), None)]).is_err());
        assert!(apply_edits(&source, &[edit(4, None, Some("X."))]).is_err());
    }
}
