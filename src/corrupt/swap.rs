//! The swaps: an object, a place or an action of a plan replaced by another
//! one from the vocabularies. The words are found with the English pipeline
//! (dependency labels and parts of speech), never by matching strings, and a
//! noun is only swapped for a word that has a vector, so the similarity of
//! the two is always known.

use std::collections::HashSet;
use std::ops::Range;

use super::draw::Draws;
use super::vocab::Action;
use super::{Changed, Unchanged};
use crate::dataset::{Edit, SwappedWords};
use crate::nlp::en::EnPipeline;
use crate::nlp::wordvec::{numpy_cosine, WordVectorTable};
use crate::nlp::Token;

/// The models the swaps need.
#[derive(Clone, Copy)]
pub struct Language<'a> {
    /// Finds nouns (dobj, pobj), root verbs and their particles.
    pub parser: &'a EnPipeline,
    /// Says which words can be swapped and how similar two words are.
    pub vectors: &'a WordVectorTable,
}

/// A step with its tokens and where each token is in the step's text.
pub struct ParsedStep {
    text: String,
    tokens: Vec<Token>,
    spans: Vec<Option<Range<usize>>>,
}

/// Which vocabulary a noun swap draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NounClass {
    /// Household objects.
    Object,
    /// Places and receptacles.
    Place,
}

impl ParsedStep {
    /// The lowercase text of token `i`.
    fn word(&self, i: usize) -> String {
        self.tokens[i].text.to_lowercase()
    }

    /// The step with the byte ranges of `changes` replaced, in order.
    fn rewritten(&self, mut changes: Vec<(Range<usize>, String)>) -> String {
        changes.sort_by_key(|(r, _)| r.start);
        let mut out = String::with_capacity(self.text.len());
        let mut at = 0;
        for (range, new) in changes {
            out.push_str(&self.text[at..range.start]);
            out.push_str(&new);
            at = range.end;
        }
        out.push_str(&self.text[at..]);
        out
    }
}

/// Parses every step of a plan once, for all the swaps of an item.
pub fn parse_plan(parser: &EnPipeline, plan: &[String]) -> Vec<ParsedStep> {
    plan.iter()
        .map(|text| {
            let tokens = parser.analyse(text);
            let mut at = 0;
            let spans = tokens
                .iter()
                .map(|t| {
                    let start = at + text.get(at..)?.find(&t.text)?;
                    at = start + t.text.len();
                    Some(start..at)
                })
                .collect();
            ParsedStep {
                text: text.clone(),
                tokens,
                spans,
            }
        })
        .collect()
}

/// `word` written with the case of `like` (capitalised or not).
fn cased(word: &str, like: &str) -> String {
    let mut chars = word.chars();
    match (like.chars().next(), chars.next()) {
        (Some(l), Some(first)) if l.is_uppercase() => first.to_uppercase().chain(chars).collect(),
        _ => word.to_string(),
    }
}

/// The cosine of the vectors of two words, when both have one.
fn similarity(vectors: &WordVectorTable, a: &str, b: &str) -> Option<f64> {
    Some(f64::from(numpy_cosine(
        &vectors.vector(a)?,
        &vectors.vector(b)?,
    )))
}

fn is_noun(token: &Token) -> bool {
    token.pos == "NOUN" || token.pos == "PROPN"
}

/// One object (or place) noun of the plan, a singular direct object or
/// object of a preposition listed in `vocabulary`, is replaced in every step by a word
/// of `vocabulary` that the plan does not mention.
pub fn noun_swap(
    plan: &[ParsedStep],
    class: NounClass,
    vocabulary: &[String],
    language: Language,
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    let listed: HashSet<&str> = vocabulary.iter().map(String::as_str).collect();
    let mut candidates: Vec<String> = Vec::new();
    for step in plan {
        for (i, t) in step.tokens.iter().enumerate() {
            let word = step.word(i);
            if (t.dep == "dobj" || t.dep == "pobj")
                && (t.tag == "NN" || t.tag == "NNP")
                && listed.contains(word.as_str())
                && !candidates.contains(&word)
                && language.vectors.vector(&word).is_some()
            {
                candidates.push(word);
            }
        }
    }
    let from = draws
        .pick(&candidates)
        .cloned()
        .ok_or(Unchanged::NoNoun(class))?;
    let mentioned: HashSet<String> = plan
        .iter()
        .flat_map(|s| (0..s.tokens.len()).map(|i| s.word(i)))
        .collect();
    let replacements: Vec<&String> = vocabulary
        .iter()
        .filter(|w| !mentioned.contains(*w) && language.vectors.vector(w).is_some())
        .collect();
    let to = (*draws
        .pick(&replacements)
        .ok_or_else(|| Unchanged::NoReplacement(from.clone()))?)
    .clone();
    let mut edits = Vec::new();
    let mut steps = Vec::new();
    for (k, step) in plan.iter().enumerate() {
        let changes: Vec<(Range<usize>, String)> = (0..step.tokens.len())
            .filter(|&i| is_noun(&step.tokens[i]) && step.word(i) == from)
            .filter_map(|i| {
                let span = step.spans[i].clone()?;
                Some((span, cased(&to, &step.tokens[i].text)))
            })
            .collect();
        if changes.is_empty() {
            steps.push(step.text.clone());
            continue;
        }
        let text = step.rewritten(changes);
        edits.push(Edit {
            step: k,
            from: Some(step.text.clone()),
            to: Some(text.clone()),
        });
        steps.push(text);
    }
    let similarity = similarity(language.vectors, &from, &to);
    Ok(Changed {
        similarity,
        words: Some(SwappedWords { from, to }),
        ..Changed::new(steps, edits)
    })
}

/// The root verb of a step with its particle (token indices).
#[derive(Clone, Copy)]
struct RootAction {
    verb: usize,
    particle: Option<usize>,
}

/// The root verb of `step` (a `VERB` labelled `ROOT`) and its `prt` child.
fn root_action(step: &ParsedStep) -> Option<RootAction> {
    let verb = step
        .tokens
        .iter()
        .position(|t| t.dep == "ROOT" && t.pos == "VERB")?;
    let particle = step
        .tokens
        .iter()
        .enumerate()
        .position(|(i, t)| i != verb && t.head == verb && t.dep == "prt");
    Some(RootAction { verb, particle })
}

/// One step's root action that matches a side of a pair of `verbs` becomes
/// the other side.
pub fn verb_swap(
    plan: &[ParsedStep],
    verbs: &[(Action, Action)],
    language: Language,
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    let mut candidates: Vec<(usize, RootAction, Action, &Action)> = Vec::new();
    for (k, step) in plan.iter().enumerate() {
        let Some(root) = root_action(step) else {
            continue;
        };
        let found = Action {
            verb: step.word(root.verb),
            particle: root.particle.map(|p| step.word(p)),
        };
        let opposites: Vec<&Action> = verbs
            .iter()
            .filter_map(|(a, b)| {
                if *a == found {
                    Some(b)
                } else if *b == found {
                    Some(a)
                } else {
                    None
                }
            })
            .collect();
        for to in opposites {
            candidates.push((k, root, found.clone(), to));
        }
    }
    let (k, root, from, to) = draws.pick(&candidates).ok_or(Unchanged::NoVerb)?;
    let step = &plan[*k];
    let verb_span = step.spans[root.verb].clone().ok_or(Unchanged::NoVerb)?;
    let verb_text = &step.tokens[root.verb].text;
    let mut changes = Vec::new();
    match (root.particle, &to.particle) {
        (Some(p), Some(new)) => {
            changes.push((verb_span, cased(&to.verb, verb_text)));
            let span = step.spans[p].clone().ok_or(Unchanged::NoVerb)?;
            changes.push((span, cased(new, &step.tokens[p].text)));
        }
        (Some(p), None) => {
            changes.push((verb_span, cased(&to.verb, verb_text)));
            let span = step.spans[p].clone().ok_or(Unchanged::NoVerb)?;
            let start = step.text[..span.start].trim_end().len();
            changes.push((start..span.end, String::new()));
        }
        (None, _) => changes.push((verb_span, cased(&to.phrase(), verb_text))),
    }
    let text = step.rewritten(changes);
    let mut steps: Vec<String> = plan.iter().map(|s| s.text.clone()).collect();
    steps[*k] = text.clone();
    let edits = vec![Edit {
        step: *k,
        from: Some(step.text.clone()),
        to: Some(text),
    }];
    Ok(Changed {
        similarity: similarity(language.vectors, &from.verb, &to.verb),
        words: Some(SwappedWords {
            from: from.phrase(),
            to: to.phrase(),
        }),
        ..Changed::new(steps, edits)
    })
}

#[cfg(test)]
mod tests {
    use super::cased;

    #[test]
    fn a_replacement_keeps_the_capital_of_the_word_it_replaces() {
        assert_eq!(cased("put", "Pick"), "Put");
        assert_eq!(cased("bread", "laptop"), "bread");
        assert_eq!(cased("", "X"), "");
    }
}
