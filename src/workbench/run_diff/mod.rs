//! What changed between two runs, as a value the run diff view draws: per
//! agent the settings that changed, its prompt and output diffed word by
//! word, its tokens and cost in both runs; the plans diffed step by step with
//! each step's score in both runs; and a verdict per metric on whether the
//! change in its mean exceeds the spread of the runs' samples.
//!
//! Built once when the diff opens, from the two run records and the price
//! table: it reads the scores the runs were given (per sample through
//! [`RunRecord::sample_scores`], per step from [`RunRecord::steps`]) and never scores.

mod verdict;
mod words;

pub use verdict::{Judgement, ReadMetric, Verdict, METRICS, SIGNIFICANCE};
pub use words::{changed_lines, word_diff, DiffLine, Piece};

use similar::{capture_diff_slices, Algorithm, DiffOp};

use crate::agents::config::AgentSettings;
use crate::agents::cost::{dollars, Billing, PriceTable};
use crate::agents::pipeline::AgentRecord;
use crate::agents::{AgentRole, Usage};
use crate::workbench::session::{RunRecord, RunState, StepScore};

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

/// What one agent used in one run, over every sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentSide {
    /// Tokens sent and written, summed over its calls.
    pub usage: Usage,
    /// What its calls cost, `None` when one has no price for its model.
    pub usd: Option<f64>,
    /// Whether every answer came from the cache or the recording.
    pub cached: bool,
    /// How many calls it made (one a sample).
    pub calls: usize,
    /// The time of its calls, summed, in milliseconds.
    pub elapsed_ms: u64,
}

/// What `role` used in `run` over every sample's call of it (see
/// [`RunRecord::calls`]), costed at `prices`; `None` when it made no call
/// in the run (its earlier output was reused). The history and the diff
/// both show this.
pub fn agent_side(prices: &PriceTable, run: &RunRecord, role: AgentRole) -> Option<AgentSide> {
    let calls: Vec<&AgentRecord> = run.calls().filter(|a| a.role == role).collect();
    (!calls.is_empty()).then(|| AgentSide {
        usage: calls.iter().map(|a| &a.usage).sum(),
        usd: calls.iter().map(|a| agent_cost(prices, a)).sum(),
        cached: calls.iter().all(|a| a.cached),
        calls: calls.len(),
        elapsed_ms: calls.iter().map(|a| a.elapsed_ms).sum(),
    })
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

/// What a whole run cost: the sum over every call of every sample, `None` when any of them
/// has no price (a partial sum would read as the whole).
pub fn run_cost(prices: &PriceTable, run: &RunRecord) -> Option<f64> {
    run.calls().map(|a| agent_cost(prices, a)).sum()
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
    let sides = runs.map(|r| agent_side(prices, r, agent));
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
    /// What became of each run ([`RunRecord::state_text`]) when it did not
    /// finish, and what of it the verdicts count (nothing, or its complete
    /// samples).
    pub unfinished: [Option<String>; 2],
}

impl RunDiff {
    /// The difference from `before` to `after`, with costs at `prices`.
    pub fn between(before: &RunRecord, after: &RunRecord, prices: &PriceTable) -> RunDiff {
        let runs = [before, after];
        let samples = runs.map(RunRecord::sample_scores);
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
            unfinished: runs.map(|r| {
                let counted = match r.state {
                    RunState::Finished => return None,
                    RunState::Partial => "only its complete samples are in the verdict",
                    _ => "not in the verdict",
                };
                Some(format!("{} — {counted}", r.state_text()))
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::words::marked as text;
    use super::*;
    use crate::agents::Approach;
    use crate::workbench::session::ScoreRecord;

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
            state: RunState::Finished,
            error: None,
            reason: None,
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
    fn a_diff_of_one_sample_runs_gives_means_and_says_too_few_samples() {
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
