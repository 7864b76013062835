//! KAS, the KeyActionScore in the rule-based form the PG2S paper's evaluation
//! used (`kas.md`), quirks included, so its numbers can be set beside the
//! paper's. It needs no model.

use std::collections::HashSet;
use std::sync::LazyLock;

use regex::Regex;
use serde::Serialize;

/// The NLTK English stopword list (179 words) that KAS drops.
const NLTK_STOPWORDS: &str = "i me my myself we our ours ourselves you you're you've you'll you'd \
your yours yourself yourselves he him his himself she she's her hers herself it it's its itself \
they them their theirs themselves what which who whom this that that'll these those am is are was \
were be been being have has had having do does did doing a an the and but if or because as until \
while of at by for with about against between into through during before after above below to from \
up down in out on off over under again further then once here there when where why how all any \
both each few more most other some such no nor not only own same so than too very s t can will \
just don don't should should've now d ll m o re ve y ain aren aren't couldn couldn't didn didn't \
doesn doesn't hadn hadn't hasn hasn't haven haven't isn isn't ma mightn mightn't mustn mustn't \
needn needn't shan shan't shouldn shouldn't wasn wasn't weren weren't won won't wouldn wouldn't";

/// Words the published evaluation drops on top of the NLTK list.
const EXTRA_STOPWORDS: [&str; 10] = [
    ",", "green", "red", "black", "white", "wooden", "wood", "walk", "back", "towards",
];

/// Directions that combine with a pending move.
const DIRECTIONS: [&str; 3] = ["left", "right", "around"];

static STOPWORDS: LazyLock<HashSet<&'static str>> = LazyLock::new(|| {
    NLTK_STOPWORDS
        .split_whitespace()
        .chain(EXTRA_STOPWORDS)
        .collect()
});

static STEP_NUMBER: LazyLock<Regex> = LazyLock::new(|| {
    Regex::new(r"step\s[0-9]+[:]\s").unwrap_or_else(|e| unreachable!("constant regex: {e}"))
});

/// The key actions of one step, as the published evaluation extracts them.
pub fn chunks(sentence: &str) -> Vec<String> {
    let lowered = sentence.to_lowercase();
    let text = STEP_NUMBER
        .replace_all(&lowered, "")
        .replace(',', " , ")
        .replace("  ", " ")
        .replace("walk", "go")
        .replace('.', "");
    let kept: Vec<&str> = text.split(' ').filter(|t| !STOPWORDS.contains(t)).collect();
    let joined = kept.join(" ");
    let mut out = Vec::new();
    let mut pending: Option<&str> = None;
    for token in joined.split(' ') {
        if token == "turn" || token == "go" {
            pending = Some(token);
            continue;
        }
        if let Some(motion) = pending.take() {
            if DIRECTIONS.contains(&token) {
                out.push(format!("{motion} {token}"));
            } else {
                out.push(motion.to_string());
                out.push(token.to_string());
            }
            continue;
        }
        if token == "," || DIRECTIONS.contains(&token) {
            continue;
        }
        out.push(token.to_string());
    }
    out
}

/// Removes `turn…` items the way the published code does: walking the list by
/// index, a removed item lets the next one slide into its place, and that one
/// is skipped.
fn drop_turns_like_published_code(items: &mut Vec<String>) {
    let mut i = 0;
    while i < items.len() {
        if items[i].starts_with("turn") {
            items.remove(i);
        }
        i += 1;
    }
}

/// The score of one predicted step against one ground-truth step.
pub fn step_score(gt_step: &str, pred_step: &str) -> f64 {
    let mut g = chunks(gt_step);
    let mut p = chunks(pred_step);
    if g.iter().filter(|c| c.starts_with("turn")).count() > 1 {
        drop_turns_like_published_code(&mut g);
        drop_turns_like_published_code(&mut p);
    }
    let g: HashSet<&String> = g.iter().collect();
    let p: HashSet<&String> = p.iter().collect();
    let common = g.intersection(&p).count();
    (common as f64 + 1e-15) / (p.len() as f64 + 1e-8)
}

/// KAS of a plan, with the key actions of every step and, when KAS is not
/// applicable, the reason.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KasReport {
    /// The mean per-step score, or `None` when KAS is not applicable.
    pub kas: Option<f64>,
    /// Why KAS is not applicable, when it is not.
    pub reason: Option<String>,
    /// The score of each ground-truth step against the predicted step of the
    /// same index (empty when not applicable).
    pub step_scores: Vec<f64>,
    /// The key actions of every step of both plans.
    pub chunks: KasChunks,
}

/// The key actions of every step of the two plans.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KasChunks {
    /// One list per ground-truth step.
    pub gt: Vec<Vec<String>>,
    /// One list per predicted step.
    pub pred: Vec<Vec<String>>,
}

/// Scores a predicted plan against a ground truth with KAS. Steps are paired
/// by index; extra predicted steps are ignored.
pub fn kas<S: AsRef<str>>(gt: &[S], pred: &[S]) -> KasReport {
    let chunks = KasChunks {
        gt: gt.iter().map(|s| chunks(s.as_ref())).collect(),
        pred: pred.iter().map(|s| chunks(s.as_ref())).collect(),
    };
    let not_applicable = |reason: String| KasReport {
        kas: None,
        reason: Some(reason),
        step_scores: Vec::new(),
        chunks: chunks.clone(),
    };
    if gt.is_empty() {
        return not_applicable("the ground truth has no steps".to_string());
    }
    if pred.len() < gt.len() {
        return not_applicable(format!(
            "the prediction has {} steps, fewer than the ground truth's {}; KAS pairs steps by index",
            pred.len(),
            gt.len()
        ));
    }
    let step_scores: Vec<f64> = gt
        .iter()
        .zip(pred)
        .map(|(g, p)| step_score(g.as_ref(), p.as_ref()))
        .collect();
    let sum = step_scores.iter().fold(0.0, |acc, s| acc + s);
    KasReport {
        kas: Some(sum / step_scores.len() as f64),
        reason: None,
        step_scores,
        chunks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(items: &[&str]) -> Vec<String> {
        items.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn the_stop_set_has_the_nltk_list_and_the_extras() {
        assert_eq!(NLTK_STOPWORDS.split_whitespace().count(), 179);
        assert_eq!(STOPWORDS.len(), 189);
    }

    #[test]
    fn moves_join_directions() {
        assert_eq!(
            chunks("Turn around and walk over to the sink."),
            strings(&["turn around", "go", "sink"])
        );
        assert_eq!(
            chunks("Turn left, walk to the fridge."),
            strings(&["turn left", "go", "fridge"])
        );
    }

    #[test]
    fn walk_is_replaced_inside_words_and_step_numbers_removed() {
        assert_eq!(
            chunks("STEP 2: Cross the walkway."),
            strings(&["cross", "goway"])
        );
    }

    #[test]
    fn a_pending_move_at_the_end_is_dropped() {
        assert_eq!(chunks("Open the door and turn"), strings(&["open", "door"]));
    }

    #[test]
    fn three_spaces_become_two_and_leave_an_empty_token() {
        assert_eq!(chunks("pick   cup"), strings(&["pick", "", "cup"]));
    }

    #[test]
    fn turn_removal_skips_the_item_after_a_removed_one() {
        let mut items = strings(&["turn left", "turn right", "go", "turn around"]);
        drop_turns_like_published_code(&mut items);
        assert_eq!(items, strings(&["turn right", "go"]));
    }

    #[test]
    fn shorter_prediction_is_not_applicable_with_a_reason() {
        let report = kas(&["Walk to the sink.", "Stop."], &["Walk to the sink."]);
        assert_eq!(report.kas, None);
        assert!(report.reason.is_some_and(|r| r.contains("fewer")));
    }

    #[test]
    fn identical_plans_score_one() {
        let plan = ["Walk to the sink.", "Pick up the cup."];
        let report = kas(&plan, &plan);
        let value = report.kas.unwrap_or_default();
        assert!((value - 1.0).abs() < 1e-7, "{value}");
    }
}
