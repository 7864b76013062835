//! What changed between two runs, as a value the run diff view draws: per
//! agent the settings that changed, its prompt and output diffed word by
//! word, its tokens and cost in both runs; the plans diffed step by step with
//! each step's score in both runs; and a verdict per metric on whether the
//! change in its mean exceeds the spread of the runs' samples.
//!
//! Built once when the diff opens, from the two run records and the price
//! table: it reads the scores the runs were given (per sample through
//! [`sample_scores`], per step from [`RunRecord::steps`]) and never scores.

use similar::{capture_diff_slices, Algorithm, ChangeTag, DiffOp, TextDiff};

use crate::agents::config::AgentSettings;
use crate::agents::cost::{dollars, Billing, PriceTable};
use crate::agents::pipeline::AgentRecord;
use crate::agents::{AgentRole, Usage};
use crate::stats::permutation::mean_difference;
use crate::stats::summary::mean;
use crate::workbench::runs::sample_scores;
use crate::workbench::session::{RunRecord, ScoreRecord, StepScore};

/// Permutations of the verdicts' test (enough for a p-value near 0.05 to
/// be read to about ±0.005).
const PERMUTATIONS: usize = 2_000;

/// The seed of the verdicts' permutations, fixed so a diff always reads the same.
const SEED: u64 = 0;

/// A change in mean with a permutation p-value below this exceeds the spread.
pub const SIGNIFICANCE: f64 = 0.05;

/// A stretch of text in a word diff: in both, only in the first, or only in
/// the second.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// Text both sides have.
    Same(String),
    /// Text only the first (older) side has.
    Removed(String),
    /// Text only the second (newer) side has.
    Added(String),
}

impl Piece {
    /// The text of the piece.
    pub fn text(&self) -> &str {
        match self {
            Piece::Same(t) | Piece::Removed(t) | Piece::Added(t) => t,
        }
    }

    /// Whether the piece is a change.
    pub fn is_change(&self) -> bool {
        !matches!(self, Piece::Same(_))
    }

    /// The same kind of piece holding `text`.
    fn with(&self, text: &str) -> Piece {
        match self {
            Piece::Same(_) => Piece::Same(text.to_string()),
            Piece::Removed(_) => Piece::Removed(text.to_string()),
            Piece::Added(_) => Piece::Added(text.to_string()),
        }
    }
}

/// `old` against `new` word by word: runs of words (and the spaces between
/// them) kept, removed or added, adjacent ones of a kind merged.
pub fn word_diff(old: &str, new: &str) -> Vec<Piece> {
    let diff = TextDiff::from_words(old, new);
    let mut pieces: Vec<Piece> = Vec::new();
    for change in diff.iter_all_changes() {
        let text = change.value();
        let piece = match change.tag() {
            ChangeTag::Equal => Piece::Same(String::new()),
            ChangeTag::Delete => Piece::Removed(String::new()),
            ChangeTag::Insert => Piece::Added(String::new()),
        };
        match pieces.last_mut() {
            Some(last) if std::mem::discriminant(last) == std::mem::discriminant(&piece) => {
                *last = last.with(&format!("{}{text}", last.text()));
            }
            _ => pieces.push(piece.with(text)),
        }
    }
    pieces
}

/// One line of a diff as shown: its pieces, or a count of unchanged lines
/// left out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DiffLine {
    /// A line, with its changes marked.
    Text(Vec<Piece>),
    /// This many unchanged lines left out.
    Unchanged(usize),
}

/// The lines of a word diff that hold a change, with `context` unchanged
/// lines around each; the unchanged stretches between are counted.
pub fn changed_lines(pieces: &[Piece], context: usize) -> Vec<DiffLine> {
    let mut lines: Vec<Vec<Piece>> = vec![Vec::new()];
    for piece in pieces {
        for (i, part) in piece.text().split('\n').enumerate() {
            if i > 0 {
                lines.push(Vec::new());
            }
            if !part.is_empty() {
                if let Some(line) = lines.last_mut() {
                    line.push(piece.with(part));
                }
            }
        }
    }
    let changed: Vec<bool> = lines
        .iter()
        .map(|l| l.iter().any(Piece::is_change))
        .collect();
    let last = lines.len() - 1;
    let near = |i: usize| {
        let (lo, hi) = (i.saturating_sub(context), (i + context).min(last));
        changed[lo..=hi].iter().any(|&c| c)
    };
    let mut out = Vec::new();
    let mut skipped = 0;
    for (i, line) in lines.into_iter().enumerate() {
        if near(i) {
            if skipped > 0 {
                out.push(DiffLine::Unchanged(skipped));
                skipped = 0;
            }
            out.push(DiffLine::Text(line));
        } else {
            skipped += 1;
        }
    }
    if skipped > 0 {
        out.push(DiffLine::Unchanged(skipped));
    }
    out
}

/// A setting whose value differs between the runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SettingChange {
    /// The setting's name as the model form calls it.
    pub name: &'static str,
    /// Its value in the first run.
    pub before: String,
    /// Its value in the second run.
    pub after: String,
}

/// The settings of two agents that differ, in the model form's order.
fn setting_changes(a: &AgentSettings, b: &AgentSettings) -> Vec<SettingChange> {
    let fields = [
        ("provider", a.provider.to_string(), b.provider.to_string()),
        ("model", a.model.clone(), b.model.clone()),
        ("base URL", a.base_url.clone(), b.base_url.clone()),
        (
            "temperature",
            a.temperature.to_string(),
            b.temperature.to_string(),
        ),
        (
            "max tokens",
            a.max_tokens.to_string(),
            b.max_tokens.to_string(),
        ),
    ];
    fields
        .into_iter()
        .filter(|(_, before, after)| before != after)
        .map(|(name, before, after)| SettingChange {
            name,
            before,
            after,
        })
        .collect()
}

/// What one agent used in one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentSide {
    /// Tokens sent and written.
    pub usage: Usage,
    /// What it cost, `None` without a price for its model.
    pub usd: Option<f64>,
    /// Whether its answer came from the cache or the recording.
    pub cached: bool,
}

/// One agent across the two runs.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentDiff {
    /// The agent.
    pub agent: AgentRole,
    /// Its tokens and cost in each run; `None` where it did not run (its
    /// earlier output was reused).
    pub sides: [Option<AgentSide>; 2],
    /// Its settings that changed (when it ran in both).
    pub settings: Vec<SettingChange>,
    /// Its prompt, word by word, when it ran in both and the prompt changed.
    pub prompt: Option<Vec<Piece>>,
    /// Its output, word by word, when it ran in both and the output changed.
    pub output: Option<Vec<Piece>>,
}

/// What one agent's answer cost in US dollars at `prices`: nothing when it
/// came from the response cache, `None` when its model has no price (the
/// demo's `replay` agents among them).
pub fn agent_cost(prices: &PriceTable, agent: &AgentRecord) -> Option<f64> {
    let billing = if agent.cached {
        Billing::Cached
    } else {
        Billing::Interactive
    };
    prices.cost(
        agent.settings.provider,
        &agent.settings.model,
        agent.usage,
        billing,
    )
}

/// What a whole run cost: the sum over its agents, `None` when any of them
/// has no price (a partial sum would read as the whole).
pub fn run_cost(prices: &PriceTable, run: &RunRecord) -> Option<f64> {
    run.agents.iter().map(|a| agent_cost(prices, a)).sum()
}

/// A cost as the run history and the diff show it: `$0.0123`, or `no price`.
pub fn cost_text(usd: Option<f64>) -> String {
    match usd {
        Some(_) => format!("${}", dollars(usd)),
        None => dollars(None),
    }
}

/// A word diff of `old` and `new`, `None` when they are equal.
fn changed_text(old: &str, new: &str) -> Option<Vec<Piece>> {
    (old != new).then(|| word_diff(old, new))
}

fn agent_diff(agent: AgentRole, runs: [&RunRecord; 2], prices: &PriceTable) -> AgentDiff {
    let records = runs.map(|r| r.agents.iter().find(|a| a.role == agent));
    let prompts = runs.map(|r| r.prompts.get(&agent).map_or("", String::as_str));
    let sides = records.map(|r| {
        r.map(|a| AgentSide {
            usage: a.usage,
            usd: agent_cost(prices, a),
            cached: a.cached,
        })
    });
    let (settings, prompt, output) = match records {
        [Some(a), Some(b)] => (
            setting_changes(&a.settings, &b.settings),
            changed_text(prompts[0], prompts[1]),
            changed_text(a.output_text(), b.output_text()),
        ),
        _ => (Vec::new(), None, None),
    };
    AgentDiff {
        agent,
        sides,
        settings,
        prompt,
        output,
    }
}

/// A plan step in one run: its position, text and score.
#[derive(Debug, Clone, PartialEq)]
pub struct StepSide {
    /// Its position in the plan (0-based).
    pub index: usize,
    /// Its text.
    pub text: String,
    /// Its part of the run's scores (default when the run was not scored).
    pub score: StepScore,
}

/// How a plan step changed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StepChange {
    /// The same text in both plans.
    Same,
    /// Only in the first plan.
    Removed,
    /// Only in the second plan.
    Added,
    /// Rewritten, word by word.
    Changed(Vec<Piece>),
}

/// One row of the plan diff: a step in either or both plans.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRow {
    /// How it changed.
    pub change: StepChange,
    /// The step in the first plan.
    pub before: Option<StepSide>,
    /// The step in the second plan.
    pub after: Option<StepSide>,
}

fn step_side(run: &RunRecord, index: usize) -> Option<StepSide> {
    Some(StepSide {
        index,
        text: run.plan.get(index)?.clone(),
        score: run.steps.get(index).copied().unwrap_or_default(),
    })
}

/// The plans of two runs step by step: kept, removed, added, or (a removed
/// step facing an added one) rewritten.
fn step_rows(a: &RunRecord, b: &RunRecord) -> Vec<StepRow> {
    let row = |change, i: Option<usize>, j: Option<usize>| StepRow {
        change,
        before: i.and_then(|i| step_side(a, i)),
        after: j.and_then(|j| step_side(b, j)),
    };
    let mut rows = Vec::new();
    for op in capture_diff_slices(Algorithm::Myers, &a.plan, &b.plan) {
        let (old, new) = (op.old_range(), op.new_range());
        match op {
            DiffOp::Equal { .. } => rows.extend(
                old.zip(new)
                    .map(|(i, j)| row(StepChange::Same, Some(i), Some(j))),
            ),
            DiffOp::Delete { .. } | DiffOp::Insert { .. } | DiffOp::Replace { .. } => {
                let paired = old.len().min(new.len());
                for k in 0..paired {
                    let (i, j) = (old.start + k, new.start + k);
                    let words = word_diff(&a.plan[i], &b.plan[j]);
                    rows.push(row(StepChange::Changed(words), Some(i), Some(j)));
                }
                rows.extend(
                    old.skip(paired)
                        .map(|i| row(StepChange::Removed, Some(i), None)),
                );
                rows.extend(
                    new.skip(paired)
                        .map(|j| row(StepChange::Added, None, Some(j))),
                );
            }
        }
    }
    rows
}

/// How to read one metric from a score.
pub type ReadMetric = fn(&ScoreRecord) -> Option<f64>;

/// The metrics a verdict is given for, with how to read each from a score.
pub const METRICS: [(&str, ReadMetric); 4] = [
    ("PG2S", |s| s.pg2s),
    ("S_plan", |s| s.s_plan),
    ("S_goal", |s| s.s_goal),
    ("KAS", |s| s.kas),
];

/// Whether a metric's change is more than the spread of its samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Judgement {
    /// The change exceeds the spread (permutation p-value below [`SIGNIFICANCE`]).
    Beyond {
        /// The p-value.
        p: f64,
    },
    /// The change is within the spread.
    Within {
        /// The p-value.
        p: f64,
    },
    /// A run has fewer than two samples: no spread to compare with.
    TooFewSamples,
    /// A run has no value of the metric.
    Missing,
}

/// The verdict on one metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// The metric's name.
    pub metric: &'static str,
    /// The mean over the first run's samples.
    pub before: Option<f64>,
    /// The mean over the second run's samples.
    pub after: Option<f64>,
    /// How many samples each run has of it.
    pub samples: [usize; 2],
    /// Whether the change exceeds the spread.
    pub judgement: Judgement,
}

impl Verdict {
    /// The change in mean, second run minus first.
    pub fn change(&self) -> Option<f64> {
        Some(self.after? - self.before?)
    }

    /// The verdict from the samples of the two runs.
    pub fn of(metric: &'static str, before: &[f64], after: &[f64]) -> Verdict {
        let judgement = if before.is_empty() || after.is_empty() {
            Judgement::Missing
        } else {
            match mean_difference(before, after, PERMUTATIONS, SEED) {
                Ok(test) if test.p_value < SIGNIFICANCE => Judgement::Beyond { p: test.p_value },
                Ok(test) => Judgement::Within { p: test.p_value },
                Err(_) => Judgement::TooFewSamples,
            }
        };
        Verdict {
            metric,
            before: mean(before).ok(),
            after: mean(after).ok(),
            samples: [before.len(), after.len()],
            judgement,
        }
    }
}

/// Everything the run diff view shows.
#[derive(Debug, Clone, PartialEq)]
pub struct RunDiff {
    /// The two runs' ids, first (older) then second.
    pub ids: [u64; 2],
    /// Changes to the whole run: approach, task, ground truth.
    pub run_changes: Vec<SettingChange>,
    /// One verdict per metric, in [`METRICS`] order.
    pub verdicts: Vec<Verdict>,
    /// Every agent that ran in either run, in pipeline order.
    pub agents: Vec<AgentDiff>,
    /// The two runs' whole cost.
    pub costs: [Option<f64>; 2],
    /// The plans step by step.
    pub steps: Vec<StepRow>,
}

impl RunDiff {
    /// The difference from `before` to `after`, with costs at `prices`.
    pub fn between(before: &RunRecord, after: &RunRecord, prices: &PriceTable) -> RunDiff {
        let runs = [before, after];
        let samples = runs.map(sample_scores);
        let verdicts = METRICS
            .iter()
            .map(|(name, read)| {
                let [a, b] = samples
                    .each_ref()
                    .map(|s| s.iter().filter_map(read).collect::<Vec<f64>>());
                Verdict::of(name, &a, &b)
            })
            .collect();
        let agents = AgentRole::ALL
            .into_iter()
            .filter(|role| {
                runs.iter()
                    .any(|r| r.agents.iter().any(|a| a.role == *role))
            })
            .map(|role| agent_diff(role, runs, prices))
            .collect();
        let run_changes = [
            (
                "approach",
                before.approach.name().to_string(),
                after.approach.name().to_string(),
            ),
            ("task", before.task.clone(), after.task.clone()),
            (
                "ground truth",
                before.ground_truth.join(" "),
                after.ground_truth.join(" "),
            ),
        ]
        .into_iter()
        .filter(|(_, a, b)| a != b)
        .map(|(name, before, after)| SettingChange {
            name,
            before,
            after,
        })
        .collect();
        RunDiff {
            ids: [before.id, after.id],
            run_changes,
            verdicts,
            agents,
            costs: runs.map(|r| run_cost(prices, r)),
            steps: step_rows(before, after),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::Approach;

    fn record(agent: AgentRole, output: &str) -> AgentRecord {
        AgentRecord {
            output: Some(output.into()),
            usage: Usage {
                input_tokens: 1_000,
                output_tokens: 200,
            },
            ..AgentRecord::blank(
                agent,
                &AgentSettings::new(crate::agents::ProviderKind::Openai, "gpt-4o", 0.0, 512),
                "multi-image-planner",
                "",
            )
        }
    }

    fn run(id: u64, agents: Vec<AgentRecord>, plan: &[&str], kas: Option<f64>) -> RunRecord {
        RunRecord {
            id,
            started_unix: 0,
            approach: Approach::MultiImage,
            task: "Wash the mug.".into(),
            agents,
            prompts: Default::default(),
            plan: plan.iter().map(|s| s.to_string()).collect(),
            ground_truth: vec!["Walk to the sink.".into()],
            scores: kas.map(|kas| ScoreRecord {
                kas: Some(kas),
                ..ScoreRecord::default()
            }),
            cancelled: false,
            corrupted: None,
            steps: plan
                .iter()
                .enumerate()
                .map(|(i, _)| StepScore {
                    kas,
                    matched: (i == 0).then_some((0, 0.9)),
                })
                .collect(),
            samples: Vec::new(),
        }
    }

    fn text(pieces: &[Piece]) -> String {
        pieces
            .iter()
            .map(|p| match p {
                Piece::Same(t) => t.clone(),
                Piece::Removed(t) => format!("[-{t}-]"),
                Piece::Added(t) => format!("{{+{t}+}}"),
            })
            .collect()
    }

    #[test]
    fn a_prompt_diff_marks_the_words_changed_and_keeps_the_rest() {
        let pieces = word_diff(
            "List every object in the scene.",
            "List every small object in the kitchen.",
        );
        assert_eq!(
            text(&pieces),
            "List every {+small +}object in the [-scene.-]{+kitchen.+}"
        );
        assert_eq!(
            word_diff("same words", "same words"),
            vec![Piece::Same("same words".into())]
        );
    }

    #[test]
    fn only_changed_lines_and_their_context_are_shown() {
        let old = "a\nb\nc\nd\ne\nf\ng";
        let new = "a\nb\nc\nD\ne\nf\ng";
        let lines = changed_lines(&word_diff(old, new), 1);
        let shown: Vec<String> = lines
            .iter()
            .map(|l| match l {
                DiffLine::Text(p) => text(p),
                DiffLine::Unchanged(n) => format!("({n})"),
            })
            .collect();
        assert_eq!(shown, ["(2)", "c", "[-d-]{+D+}", "e", "(2)"]);
    }

    #[test]
    fn the_plan_diff_pairs_rewritten_steps_and_keeps_each_steps_scores() {
        let a = run(
            1,
            vec![],
            &["Walk to the sink.", "Wash the mug.", "Dry it."],
            Some(0.5),
        );
        let b = run(
            2,
            vec![],
            &[
                "Walk to the sink.",
                "Rinse the mug.",
                "Dry it.",
                "Shelve it.",
            ],
            Some(0.75),
        );
        let rows = step_rows(&a, &b);
        let changes: Vec<String> = rows
            .iter()
            .map(|r| match &r.change {
                StepChange::Same => "=".to_string(),
                StepChange::Removed => "-".to_string(),
                StepChange::Added => "+".to_string(),
                StepChange::Changed(p) => text(p),
            })
            .collect();
        assert_eq!(changes, ["=", "[-Wash-]{+Rinse+} the mug.", "=", "+"]);
        let first = &rows[0];
        assert_eq!(first.before.as_ref().map(|s| s.score.kas), Some(Some(0.5)));
        assert_eq!(first.after.as_ref().map(|s| s.score.kas), Some(Some(0.75)));
        assert_eq!(
            first.after.as_ref().and_then(|s| s.score.matched),
            Some((0, 0.9))
        );
        assert_eq!(rows[3].before, None);
        assert_eq!(rows[3].after.as_ref().map(|s| s.index), Some(3));
    }

    #[test]
    fn agents_show_settings_prompt_and_output_changes_and_their_costs() {
        let mut planner = record(AgentRole::Planner, "1. Go.");
        let mut a = run(
            1,
            vec![record(AgentRole::Skm, "(a, on, b)"), planner.clone()],
            &[],
            None,
        );
        planner.settings.temperature = 0.7;
        planner.cached = true;
        let mut b = run(2, vec![planner], &[], None);
        a.prompts
            .insert(AgentRole::Planner, "Plan the task.".into());
        b.prompts
            .insert(AgentRole::Planner, "Plan the task in short steps.".into());
        let prices = PriceTable::from_config(
            &toml::from_str(
                "[openai.\"gpt-4o\"]\ninput_per_million = 2.5\noutput_per_million = 10.0\n",
            )
            .unwrap(),
        )
        .unwrap();
        let diff = RunDiff::between(&a, &b, &prices);
        assert_eq!(diff.agents.len(), 2);
        let skm = &diff.agents[0];
        assert_eq!(skm.agent, AgentRole::Skm);
        assert!(skm.sides[1].is_none() && skm.prompt.is_none());
        let planner = &diff.agents[1];
        assert_eq!(
            text(planner.prompt.as_deref().unwrap_or_default()),
            "Plan the [-task.-]{+task in short steps.+}"
        );
        assert_eq!(planner.output, None);
        assert_eq!(
            planner.settings,
            vec![SettingChange {
                name: "temperature",
                before: "0".into(),
                after: "0.7".into()
            }]
        );
        // 1,000 × $2.50 + 200 × $10 per million; the cached answer cost nothing.
        assert_eq!(
            planner.sides.map(|s| s.and_then(|s| s.usd)),
            [Some(0.0045), Some(0.0)]
        );
        assert_eq!(diff.costs, [Some(0.009), Some(0.0)]);
    }

    #[test]
    fn a_run_costs_the_sum_of_its_agents_and_no_figure_when_one_has_no_price() {
        let prices = PriceTable::from_config(
            &toml::from_str(
                "[openai.\"gpt-4o\"]\ninput_per_million = 2.5\noutput_per_million = 10.0\n",
            )
            .unwrap(),
        )
        .unwrap();
        let paid = || record(AgentRole::Skm, "");
        let mut cached = paid();
        cached.cached = true;
        let mut unpriced = paid();
        unpriced.settings.model = "gpt-4.1".into();
        let mut replay = paid();
        replay.settings.provider = crate::agents::ProviderKind::Replay;
        assert_eq!(cost_text(agent_cost(&prices, &paid())), "$0.0045");
        assert_eq!(cost_text(agent_cost(&prices, &cached)), "$0.0000");
        assert_eq!(cost_text(agent_cost(&prices, &unpriced)), "no price");
        assert_eq!(cost_text(agent_cost(&prices, &replay)), "no price");
        let both = run(1, vec![paid(), paid(), cached], &[], None);
        assert_eq!(cost_text(run_cost(&prices, &both)), "$0.0090");
        let partial = run(2, vec![paid(), unpriced], &[], None);
        assert_eq!(cost_text(run_cost(&prices, &partial)), "no price");
    }

    #[test]
    fn verdicts_come_from_the_samples_spread() {
        let apart = Verdict::of("KAS", &[0.40, 0.41, 0.39, 0.42], &[0.60, 0.61, 0.62, 0.59]);
        assert!(
            matches!(apart.judgement, Judgement::Beyond { p } if p < 0.05),
            "{apart:?}"
        );
        assert!((apart.change().unwrap_or_default() - 0.2).abs() < 1e-9);
        let noisy = Verdict::of("KAS", &[0.2, 0.8, 0.5], &[0.3, 0.7, 0.55]);
        assert!(
            matches!(noisy.judgement, Judgement::Within { p } if p > 0.5),
            "{noisy:?}"
        );
        let one = Verdict::of("PG2S", &[0.4], &[0.6]);
        assert_eq!(one.judgement, Judgement::TooFewSamples);
        assert_eq!(one.samples, [1, 1]);
        assert_eq!(
            Verdict::of("S_goal", &[], &[0.6]).judgement,
            Judgement::Missing
        );
        // Two runs of one sample each, as runs are today.
        let a = run(1, vec![], &["Go."], Some(0.5));
        let b = run(2, vec![], &["Go."], Some(0.75));
        let kas = RunDiff::between(&a, &b, &PriceTable::default()).verdicts[3];
        assert_eq!(
            (kas.metric, kas.before, kas.after),
            ("KAS", Some(0.5), Some(0.75))
        );
        assert_eq!(kas.judgement, Judgement::TooFewSamples);
    }
}
