//! PG2S, the Planning Goal Semantic Score (`pg2s.md`): a sentence-wise score
//! from sentence embeddings and a goal-wise score from framed actions, each
//! with the explanation a user needs to see why a point was lost.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use super::{FramingParser, ModelError, SentenceEncoder, WordVectors};
use crate::nlp::Token;

/// The thresholds and weight of PG2S. Settings from outside (flags, files)
/// are made with [`Pg2sSettings::new`], which refuses values out of range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pg2sSettings {
    /// A sentence match needs a cosine strictly above this.
    pub sentence_threshold: f64,
    /// A verb match needs a similarity strictly above this; nouns agree at or
    /// above it.
    pub word_threshold: f64,
    /// The weight of S_goal: `PG2S = (1 - alpha) * S_plan + alpha * S_goal`.
    pub alpha: f64,
}

impl Default for Pg2sSettings {
    fn default() -> Self {
        Self {
            sentence_threshold: 0.675,
            word_threshold: 0.708,
            alpha: 0.5,
        }
    }
}

impl std::fmt::Display for Pg2sSettings {
    /// The settings in words, for messages that compare two of them.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "settings (sentence threshold {}, word threshold {}, alpha {})",
            self.sentence_threshold, self.word_threshold, self.alpha
        )
    }
}

/// One of the three numbers of [`Pg2sSettings`], to say which was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pg2sSetting {
    /// [`Pg2sSettings::sentence_threshold`].
    SentenceThreshold,
    /// [`Pg2sSettings::word_threshold`].
    WordThreshold,
    /// [`Pg2sSettings::alpha`].
    Alpha,
}

impl Pg2sSetting {
    /// The range the setting must lie in (bounds included), and what the
    /// number is, for the message that refuses it.
    pub fn range(self) -> (f64, f64, &'static str) {
        match self {
            Self::SentenceThreshold | Self::WordThreshold => (-1.0, 1.0, "a cosine similarity"),
            Self::Alpha => (0.0, 1.0, "the weight of S_goal"),
        }
    }
}

impl std::fmt::Display for Pg2sSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::SentenceThreshold => "sentence threshold",
            Self::WordThreshold => "word threshold",
            Self::Alpha => "alpha",
        })
    }
}

/// A PG2S setting outside its range (NaN included): which, and its value.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "the PG2S {setting} {value} is outside {}..={} ({}): give a value in that range",
    setting.range().0,
    setting.range().1,
    setting.range().2
)]
pub struct Pg2sSettingsError {
    /// The setting refused.
    pub setting: Pg2sSetting,
    /// Its value.
    pub value: f64,
}

impl Pg2sSettings {
    /// The settings, once each number is known to lie in its range
    /// ([`Pg2sSetting::range`]); the first that does not is refused.
    pub fn new(
        sentence_threshold: f64,
        word_threshold: f64,
        alpha: f64,
    ) -> Result<Self, Pg2sSettingsError> {
        let settings = Self {
            sentence_threshold,
            word_threshold,
            alpha,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Checks that every number lies in its range; settings built field by
    /// field, or read from a file, are checked with this before use.
    pub fn validate(&self) -> Result<(), Pg2sSettingsError> {
        for (setting, value) in [
            (Pg2sSetting::SentenceThreshold, self.sentence_threshold),
            (Pg2sSetting::WordThreshold, self.word_threshold),
            (Pg2sSetting::Alpha, self.alpha),
        ] {
            let (low, high, _) = setting.range();
            if !(low..=high).contains(&value) {
                return Err(Pg2sSettingsError { setting, value });
            }
        }
        Ok(())
    }
}

/// How one ground-truth step fared in the sentence-wise matching.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SentenceMatch {
    /// Index of the ground-truth step.
    pub gt: usize,
    /// Index of the predicted step it matched, if any.
    pub pred: Option<usize>,
    /// Cosine of the match, if any.
    pub cosine: Option<f64>,
    /// For an unmatched step: the closest predicted step still unmatched at
    /// its turn and its cosine, which was not above the threshold.
    pub closest: Option<(usize, f64)>,
}

/// An action framed from a step: a verb and its direct objects and subjects.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Action {
    /// Index of the step the action was framed from.
    pub step: usize,
    /// The verb's text followed by its `dobj`/`nsubj` children's texts.
    pub words: Vec<String>,
}

/// How one ground-truth action fared in the goal-wise matching.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ActionMatch {
    /// Index of the ground-truth action.
    pub gt: usize,
    /// Index of the predicted action it matched, if any.
    pub pred: Option<usize>,
    /// Verb similarity times noun agreement of the match, if any.
    pub score: Option<f64>,
}

/// The goal-wise half of a report, present when a framing parser and word
/// vectors are available.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GoalReport {
    /// S_goal: the share of ground-truth actions matched.
    pub s_goal: f64,
    /// Framed actions of the ground truth, in order.
    pub gt_actions: Vec<Action>,
    /// Framed actions of the prediction, in order.
    pub pred_actions: Vec<Action>,
    /// One entry per ground-truth action.
    pub action_matches: Vec<ActionMatch>,
}

/// PG2S of one plan pair with its full explanation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pg2sReport {
    /// S_plan: the share of ground-truth steps matched by a predicted step.
    pub s_plan: f64,
    /// One entry per ground-truth step.
    pub sentence_matches: Vec<SentenceMatch>,
    /// The goal-wise half, or why it could not be computed.
    pub goal: Result<GoalReport, NoGoalModels>,
    /// The settings the scores were computed with.
    pub settings: Pg2sSettings,
}

impl Pg2sReport {
    /// S_goal, when it could be computed.
    pub fn s_goal(&self) -> Option<f64> {
        self.goal.as_ref().ok().map(|g| g.s_goal)
    }

    /// The final PG2S, when S_goal could be computed.
    pub fn pg2s(&self) -> Option<f64> {
        let alpha = self.settings.alpha;
        self.s_goal()
            .map(|s_goal| (1.0 - alpha) * self.s_plan + alpha * s_goal)
    }
}

/// The cosine of two vectors as NumPy computes it for f32 embeddings: a
/// single-precision quotient of the dot product and the product of the norms.
pub fn cosine(a: &[f32], b: &[f32]) -> f64 {
    let dot: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| f64::from(*x) * f64::from(*y))
        .sum();
    let na: f64 = a
        .iter()
        .map(|x| f64::from(*x) * f64::from(*x))
        .sum::<f64>()
        .sqrt();
    let nb: f64 = b
        .iter()
        .map(|x| f64::from(*x) * f64::from(*x))
        .sum::<f64>()
        .sqrt();
    let denominator = (na as f32) * (nb as f32);
    if denominator == 0.0 {
        return 0.0;
    }
    f64::from((dot as f32) / denominator)
}

/// The sentence-wise matching over a matrix of cosines (`cos[i][j]`: ground
/// truth `i`, prediction `j`): each ground-truth step in order takes the
/// closest predicted step still free whose cosine is above the threshold.
pub fn match_sentences(cos: &[Vec<f64>], n_pred: usize, threshold: f64) -> Vec<SentenceMatch> {
    let mut left: Vec<usize> = (0..n_pred).collect();
    let mut matches = Vec::with_capacity(cos.len());
    for (i, row) in cos.iter().enumerate() {
        let mut best: Option<(usize, f64)> = None;
        let mut closest: Option<(usize, f64)> = None;
        for &j in &left {
            let c = row[j];
            if c > best.map_or(f64::NEG_INFINITY, |b| b.1) && c > threshold {
                best = Some((j, c));
            }
            if c > closest.map_or(f64::NEG_INFINITY, |b| b.1) {
                closest = Some((j, c));
            }
        }
        match best {
            Some((j, c)) => {
                left.retain(|&k| k != j);
                matches.push(SentenceMatch {
                    gt: i,
                    pred: Some(j),
                    cosine: Some(c),
                    closest: None,
                });
            }
            None => matches.push(SentenceMatch {
                gt: i,
                pred: None,
                cosine: None,
                closest,
            }),
        }
    }
    matches
}

/// The share of `1`s in a list of matches, 0 for an empty list.
fn share_matched<T>(matches: &[T], matched: impl Fn(&T) -> bool) -> f64 {
    if matches.is_empty() {
        return 0.0;
    }
    matches.iter().filter(|m| matched(m)).count() as f64 / matches.len() as f64
}

/// Frames one parsed step: for each `VERB` token in order, its `dobj` and
/// `nsubj` children in token order; a verb with none emits nothing.
pub fn frame_tokens(tokens: &[Token]) -> Vec<Vec<String>> {
    let mut actions = Vec::new();
    for (i, verb) in tokens.iter().enumerate() {
        if verb.pos != "VERB" {
            continue;
        }
        let kids: Vec<String> = tokens
            .iter()
            .enumerate()
            .filter(|(k, t)| *k != i && t.head == i && (t.dep == "dobj" || t.dep == "nsubj"))
            .map(|(_, t)| t.text.clone())
            .collect();
        if !kids.is_empty() {
            let mut words = Vec::with_capacity(kids.len() + 1);
            words.push(verb.text.clone());
            words.extend(kids);
            actions.push(words);
        }
    }
    actions
}

/// The goal-wise matching of framed actions with word similarities.
pub fn match_actions(
    gt: &[Action],
    pred: &[Action],
    vectors: &dyn WordVectors,
    threshold: f64,
) -> Vec<ActionMatch> {
    let sim = |a: &str, b: &str| f64::from(vectors.similarity(a, b));
    let mut left: Vec<usize> = (0..pred.len()).collect();
    let mut matches = Vec::with_capacity(gt.len());
    for (i, a) in gt.iter().enumerate() {
        let a = &a.words;
        let mut best: Option<(usize, f64)> = None;
        for &j in &left {
            let b = &pred[j].words;
            let verb_similarity = sim(&a[0], &b[0]);
            let k = a.len().min(b.len()) - 1;
            let noun_score = if a.len() != b.len() && k == 0 {
                0.0
            } else if k == 0 {
                1.0
            } else {
                let agree = (1..=k).filter(|&n| sim(&a[n], &b[n]) >= threshold).count();
                agree as f64 / k as f64
            };
            let score = verb_similarity * noun_score;
            if score > best.map_or(0.0, |b| b.1) && verb_similarity > threshold {
                best = Some((j, score));
            }
        }
        if let Some((j, _)) = best {
            left.retain(|&k| k != j);
        }
        matches.push(ActionMatch {
            gt: i,
            pred: best.map(|b| b.0),
            score: best.map(|b| b.1),
        });
    }
    matches
}

/// The models PG2S needs for its goal-wise half.
#[derive(Clone)]
pub struct GoalModels {
    /// Word vectors for verb and noun similarity.
    pub vectors: Arc<dyn WordVectors>,
    /// The parser that frames steps into actions.
    pub parser: Arc<dyn FramingParser>,
}

/// The framed steps a scorer keeps in memory; past this it starts afresh,
/// so memory stays bounded however many pairs one scorer scores.
const FRAMES_KEPT: usize = 16_384;

/// Why a report has no S_goal or PG2S: its scorer was made without the
/// goal-wise models ([`Pg2sScorer::new`] with `None`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("no framing parser or word vectors loaded")]
pub struct NoGoalModels;

/// Written as its message, as reports have always carried the reason.
impl Serialize for NoGoalModels {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

/// Scores plan pairs with PG2S, keeping the framed actions of the steps seen
/// lately (up to [`FRAMES_KEPT`]) so an unchanged step is not parsed twice.
pub struct Pg2sScorer {
    encoder: Arc<dyn SentenceEncoder>,
    goal: Option<GoalModels>,
    settings: Pg2sSettings,
    frames: Mutex<HashMap<String, Arc<Vec<Vec<String>>>>>,
}

impl Pg2sScorer {
    /// A scorer; `goal` is the goal-wise models, if any (without them S_goal
    /// and PG2S are reported as missing, saying why).
    pub fn new(
        encoder: Arc<dyn SentenceEncoder>,
        goal: Option<GoalModels>,
        settings: Pg2sSettings,
    ) -> Self {
        Self {
            encoder,
            goal,
            settings,
            frames: Mutex::new(HashMap::new()),
        }
    }

    /// The settings in use.
    pub fn settings(&self) -> Pg2sSettings {
        self.settings
    }

    /// Embeds and frames steps ahead of scoring, in one batch, so that the
    /// encoder can sort them by length and later scoring hits its caches.
    pub fn warm_up(&self, steps: &[&str]) -> Result<(), ModelError> {
        self.encoder.encode(steps)?;
        if let Some(models) = &self.goal {
            for step in steps {
                self.frame_step(models.parser.as_ref(), step)?;
            }
        }
        Ok(())
    }

    /// Scores `pred` against `gt`.
    pub fn score<S: AsRef<str>>(&self, gt: &[S], pred: &[S]) -> Result<Pg2sReport, ModelError> {
        let texts: Vec<&str> = gt.iter().chain(pred).map(AsRef::as_ref).collect();
        let embeddings = self.encoder.encode(&texts)?;
        let (eg, ep) = embeddings.split_at(gt.len());
        let cos: Vec<Vec<f64>> = eg
            .iter()
            .map(|g| ep.iter().map(|p| cosine(g, p)).collect())
            .collect();
        let sentence_matches = match_sentences(&cos, pred.len(), self.settings.sentence_threshold);
        let s_plan = share_matched(&sentence_matches, |m| m.pred.is_some());
        let goal = match &self.goal {
            Some(models) => Ok(self.goal_report(models, gt, pred)?),
            None => Err(NoGoalModels),
        };
        Ok(Pg2sReport {
            s_plan,
            sentence_matches,
            goal,
            settings: self.settings,
        })
    }

    fn goal_report<S: AsRef<str>>(
        &self,
        models: &GoalModels,
        gt: &[S],
        pred: &[S],
    ) -> Result<GoalReport, ModelError> {
        let gt_actions = self.frame_plan(models.parser.as_ref(), gt)?;
        let pred_actions = self.frame_plan(models.parser.as_ref(), pred)?;
        let action_matches = match_actions(
            &gt_actions,
            &pred_actions,
            models.vectors.as_ref(),
            self.settings.word_threshold,
        );
        Ok(GoalReport {
            s_goal: share_matched(&action_matches, |m| m.pred.is_some()),
            gt_actions,
            pred_actions,
            action_matches,
        })
    }

    /// The actions of a plan, in order: each step lowercased and framed.
    pub fn frame_plan<S: AsRef<str>>(
        &self,
        parser: &dyn FramingParser,
        steps: &[S],
    ) -> Result<Vec<Action>, ModelError> {
        let mut actions = Vec::new();
        for (step, text) in steps.iter().enumerate() {
            let framed = self.frame_step(parser, text.as_ref())?;
            actions.extend(framed.iter().map(|words| Action {
                step,
                words: words.clone(),
            }));
        }
        Ok(actions)
    }

    fn frame_step(
        &self,
        parser: &dyn FramingParser,
        text: &str,
    ) -> Result<Arc<Vec<Vec<String>>>, ModelError> {
        let cached = self
            .frames
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get(text)
            .cloned();
        if let Some(framed) = cached {
            return Ok(framed);
        }
        let framed = Arc::new(frame_tokens(&parser.parse(&text.to_lowercase())?));
        let mut frames = self.frames.lock().unwrap_or_else(PoisonError::into_inner);
        if frames.len() >= FRAMES_KEPT {
            frames.clear();
        }
        frames.insert(text.to_string(), Arc::clone(&framed));
        Ok(framed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_refused_naming_the_setting() {
        assert_eq!(
            Pg2sSettings::new(0.675, 0.708, 0.5),
            Ok(Pg2sSettings::default())
        );
        assert!(
            Pg2sSettings::new(-1.0, 1.0, 0.0).is_ok(),
            "bounds are allowed"
        );
        let refused = |s: f64, w: f64, a: f64| Pg2sSettings::new(s, w, a).unwrap_err().setting;
        assert_eq!(refused(f64::NAN, 0.7, 0.5), Pg2sSetting::SentenceThreshold);
        assert_eq!(refused(0.7, 7.0, 0.5), Pg2sSetting::WordThreshold);
        assert_eq!(refused(0.7, 0.7, -1.0), Pg2sSetting::Alpha);
        let message = Pg2sSettings::new(0.7, 0.7, 1.5).unwrap_err().to_string();
        assert_eq!(
            message,
            "the PG2S alpha 1.5 is outside 0..=1 (the weight of S_goal): give a value in that range"
        );
        let built = Pg2sSettings {
            word_threshold: -1.01,
            ..Pg2sSettings::default()
        };
        assert_eq!(
            built.validate().unwrap_err().setting,
            Pg2sSetting::WordThreshold
        );
    }

    struct Table(Vec<(&'static str, Vec<f32>)>);

    impl WordVectors for Table {
        fn similarity(&self, a: &str, b: &str) -> f32 {
            let get = |w: &str| self.0.iter().find(|(k, _)| *k == w).map(|(_, v)| v);
            match (get(a), get(b)) {
                (Some(x), Some(y)) => cosine(x, y) as f32,
                _ => 0.0,
            }
        }
    }

    fn action(step: usize, words: &[&str]) -> Action {
        Action {
            step,
            words: words.iter().map(|w| w.to_string()).collect(),
        }
    }

    #[test]
    fn first_of_equal_maxima_wins_and_threshold_is_strict() {
        let cos = vec![vec![0.9, 0.9, 0.1], vec![0.675, 0.675, 0.6751]];
        let m = match_sentences(&cos, 3, 0.675);
        assert_eq!(m[0].pred, Some(0));
        assert_eq!(m[1].pred, Some(2));
        let m = match_sentences(&[vec![0.675]], 1, 0.675);
        assert_eq!(m[0].pred, None);
        assert_eq!(m[0].closest, Some((0, 0.675)));
    }

    #[test]
    fn a_predicted_step_is_matched_once() {
        let cos = vec![vec![0.9], vec![0.95]];
        let m = match_sentences(&cos, 1, 0.675);
        assert_eq!((m[0].pred, m[1].pred), (Some(0), None));
        assert_eq!(share_matched(&m, |m| m.pred.is_some()), 0.5);
    }

    #[test]
    fn actions_need_a_similar_verb_and_agreeing_nouns() {
        let vectors = Table(vec![
            ("pick", vec![1.0, 0.0]),
            ("take", vec![0.9, 0.1]),
            ("cup", vec![0.0, 1.0]),
            ("mug", vec![0.1, 0.95]),
            ("sink", vec![1.0, 1.0]),
        ]);
        let gt = [action(0, &["pick", "cup"]), action(1, &["pick", "sink"])];
        let pred = [action(0, &["take", "mug"]), action(1, &["take"])];
        let m = match_actions(&gt, &pred, &vectors, 0.708);
        assert_eq!(m[0].pred, Some(0));
        assert_eq!(m[1].pred, None, "lengths differ with k == 0 gives ns = 0");
    }

    #[test]
    fn missing_words_have_similarity_zero() {
        let vectors = Table(vec![("pick", vec![1.0, 0.0])]);
        let gt = [action(0, &["pick"])];
        let pred = [action(0, &["grab"])];
        assert_eq!(match_actions(&gt, &pred, &vectors, 0.708)[0].pred, None);
    }

    #[test]
    fn framing_takes_dobj_and_nsubj_children_of_verbs() {
        let tok = |text: &str, pos: &str, dep: &str, head: usize| Token {
            text: text.into(),
            ws: " ".into(),
            tag: String::new(),
            pos: pos.into(),
            dep: dep.into(),
            head,
        };
        let tokens = [
            tok("put", "VERB", "ROOT", 0),
            tok("on", "ADP", "prt", 0),
            tok("the", "DET", "det", 3),
            tok("shoe", "NOUN", "dobj", 0),
            tok("walk", "VERB", "conj", 0),
        ];
        assert_eq!(
            frame_tokens(&tokens),
            vec![vec!["put".to_string(), "shoe".to_string()]]
        );
    }
}
