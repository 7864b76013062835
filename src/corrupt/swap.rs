//! The swaps: an object, a place or an action of a plan replaced by another
//! one from the vocabularies. The words are found with the English pipeline
//! (dependency labels and parts of speech), never by matching strings, and a
//! noun is only swapped for a word that has a vector, so the similarity of
//! the two is always known.

use std::collections::HashSet;
use std::ops::Range;

use super::draw::Draws;
use super::vocab::{Action, Vocabulary};
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

/// `word` written with the case of `like`, the word it replaces: a word of
/// one or two letters is an initialism (`cd` → `CD`); all capitals when
/// `like` is a capitalised word of four or more letters (`SINK`), as given
/// when `like` is a short initialism (`CD` → `book`), capitalised when
/// `like` is (`Sink`, `CounterTop` → `Sink`), else as given.
fn cased(word: &str, like: &str) -> String {
    if word.chars().count() <= 2 {
        return word.to_uppercase();
    }
    let letters: Vec<char> = like.chars().filter(|c| c.is_alphabetic()).collect();
    if letters.len() >= 2 && letters.iter().all(|c| c.is_uppercase()) {
        return if letters.len() >= 4 {
            word.to_uppercase()
        } else {
            word.to_string()
        };
    }
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

/// The mean of the vectors of a phrase's words (as spaCy's `Doc.vector`),
/// when every word has one.
fn phrase_vector(vectors: &WordVectorTable, words: &[&str]) -> Option<Vec<f32>> {
    let mut sum = vec![0f32; vectors.dim()];
    for w in words {
        for (s, x) in sum.iter_mut().zip(vectors.vector(w)?) {
            *s += x;
        }
    }
    let n = words.len().max(1) as f32;
    Some(sum.into_iter().map(|s| s / n).collect())
}

/// The cosine of two actions' phrase vectors (`turn off` against `turn on`),
/// when every word of both has a vector.
fn phrase_similarity(vectors: &WordVectorTable, a: &Action, b: &Action) -> Option<f64> {
    let words = |x: &Action| -> Vec<String> { x.phrase().split(' ').map(String::from).collect() };
    let (wa, wb) = (words(a), words(b));
    let va = phrase_vector(vectors, &wa.iter().map(String::as_str).collect::<Vec<_>>())?;
    let vb = phrase_vector(vectors, &wb.iter().map(String::as_str).collect::<Vec<_>>())?;
    Some(f64::from(numpy_cosine(&va, &vb)))
}

fn is_noun(token: &Token) -> bool {
    token.pos == "NOUN" || token.pos == "PROPN"
}

/// The lowercase words of a text (the task), as the plan's parser splits them.
pub fn words_of(parser: &EnPipeline, text: &str) -> HashSet<String> {
    parser
        .analyse(text)
        .iter()
        .map(|t| t.text.to_lowercase())
        .collect()
}

/// Whether token `i` of `step` is the head of a partitive phrase (`the loaf
/// of bread`, `a bottle of wine`), where swapping the head gives nonsense
/// (`the newspaper of bread`).
fn is_partitive(step: &ParsedStep, i: usize) -> bool {
    step.tokens
        .iter()
        .enumerate()
        .any(|(j, t)| j != i && t.head == i && t.dep == "prep" && t.text.eq_ignore_ascii_case("of"))
}

/// The byte range that a swap of noun `i` replaces: the noun with the
/// compound nouns right before it that modify it (`wine bottle`, `credit
/// card`), so the replacement does not keep a modifier of the old thing
/// (`wine disc`).
fn noun_span(step: &ParsedStep, i: usize) -> Option<Range<usize>> {
    let end = step.spans[i].clone()?;
    let mut first = i;
    while first > 0 {
        let t = &step.tokens[first - 1];
        if t.dep == "compound" && t.head == i && is_noun(t) {
            first -= 1;
        } else {
            break;
        }
    }
    let start = step.spans[first].clone()?;
    Some(start.start..end.end)
}

/// One object (or place) noun of the plan, a singular direct object or
/// object of a preposition listed in `words`, is replaced in every step by a
/// word of `words` that the plan does not mention and that names another
/// thing than it (and than every noun of the plan). When the plan mentions a
/// listed thing the task names (`task`: the task's words; a word of the
/// same thing counts), that thing is the one replaced, wherever it stands
/// (`touches_task`); other nouns are only replaced where they head no
/// partitive phrase (`loaf of bread`).
pub fn noun_swap(
    plan: &[ParsedStep],
    task: &HashSet<String>,
    class: NounClass,
    words: &[String],
    vocabulary: &Vocabulary,
    language: Language,
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    let listed: HashSet<&str> = words.iter().map(String::as_str).collect();
    let mut candidates: Vec<String> = Vec::new();
    let mut partitive: HashSet<String> = HashSet::new();
    for step in plan {
        for (i, t) in step.tokens.iter().enumerate() {
            let word = step.word(i);
            if is_noun(t) && is_partitive(step, i) {
                partitive.insert(word.clone());
            }
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
    let named = |w: &str| task.iter().any(|t| vocabulary.same_thing(w, t));
    let mut of_task: Vec<String> = candidates.iter().filter(|w| named(w)).cloned().collect();
    if of_task.is_empty() {
        // The task's thing in another role (a subject, a compound, a plural
        // the tagger misread): still the one to swap.
        for step in plan {
            for i in 0..step.tokens.len() {
                let word = step.word(i);
                if listed.contains(word.as_str())
                    && named(&word)
                    && !of_task.contains(&word)
                    && language.vectors.vector(&word).is_some()
                {
                    of_task.push(word);
                }
            }
        }
    }
    let touches_task = !of_task.is_empty();
    let pool: Vec<String> = if touches_task {
        of_task
    } else {
        candidates
            .into_iter()
            .filter(|w| !partitive.contains(w))
            .collect()
    };
    let from = draws.pick(&pool).cloned().ok_or(Unchanged::NoNoun(class))?;
    let mentioned: HashSet<String> = plan
        .iter()
        .flat_map(|s| (0..s.tokens.len()).map(|i| s.word(i)))
        .collect();
    let nouns: HashSet<String> = plan
        .iter()
        .flat_map(|s| {
            (0..s.tokens.len())
                .filter(|&i| is_noun(&s.tokens[i]))
                .map(|i| s.word(i))
        })
        .collect();
    let replacements: Vec<&String> = words
        .iter()
        .filter(|w| {
            !mentioned.contains(*w)
                && !vocabulary.same_thing(w, &from)
                && !nouns.iter().any(|n| vocabulary.same_thing(w, n))
                && language.vectors.vector(w).is_some()
        })
        .collect();
    let to = (*draws
        .pick(&replacements)
        .ok_or_else(|| Unchanged::NoReplacement(from.clone()))?)
    .clone();
    let mut edits = Vec::new();
    let mut steps = Vec::new();
    for (k, step) in plan.iter().enumerate() {
        let changes: Vec<(Range<usize>, String)> = (0..step.tokens.len())
            .filter(|&i| (touches_task || is_noun(&step.tokens[i])) && step.word(i) == from)
            .filter_map(|i| {
                let span = if step.tokens[i].dep == "compound" {
                    step.spans[i].clone()?
                } else {
                    noun_span(step, i)?
                };
                let like = &step.text[span.clone()];
                Some((span.clone(), cased(&to, like)))
            })
            .collect();
        let changes = without_overlaps(changes);
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
        touches_task: Some(touches_task),
        ..Changed::new(steps, edits)
    })
}

/// The changes sorted by start, each one that overlaps an earlier one left
/// out (a compound of the swapped word inside another's span).
fn without_overlaps(mut changes: Vec<(Range<usize>, String)>) -> Vec<(Range<usize>, String)> {
    changes.sort_by_key(|(r, _)| (r.start, std::cmp::Reverse(r.end)));
    let mut out: Vec<(Range<usize>, String)> = Vec::new();
    for (range, text) in changes {
        if out.last().is_some_and(|(last, _)| range.start < last.end) {
            continue;
        }
        out.push((range, text));
    }
    out
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

/// Whether a step only moves the agent: its root verb is one of
/// [`super::NAVIGATION_VERBS`] and every other verb of the step is too
/// (`Turn around and walk to the sink.`), but those that describe a thing
/// (`the desk located by the bed`), so repeating or reordering it changes
/// no action.
pub fn navigation_only(step: &ParsedStep) -> bool {
    let navigating = |i: usize| super::NAVIGATION_VERBS.contains(&step.word(i).as_str());
    let Some(root) = step.tokens.iter().position(|t| t.dep == "ROOT") else {
        return false;
    };
    // A verb that only describes a thing (`the desk located next to the
    // bed`, `where the mug is placed`) is no action of the step.
    let describes = |i: usize| matches!(step.tokens[i].dep.as_str(), "acl" | "relcl" | "amod");
    navigating(root)
        && (0..step.tokens.len())
            .filter(|&i| i != root && step.tokens[i].pos == "VERB" && !describes(i))
            .all(navigating)
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
        similarity: phrase_similarity(language.vectors, from, to),
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
        assert_eq!(cased("sink", "TOWEL"), "SINK");
        assert_eq!(cased("book", "CD"), "book");
        assert_eq!(cased("cd", "book"), "CD");
        assert_eq!(cased("sink", "CounterTop"), "Sink");
        assert_eq!(cased("sink", "A"), "Sink");
        assert_eq!(cased("bread", "laptop"), "bread");
        assert_eq!(cased("", "X"), "");
    }
}
