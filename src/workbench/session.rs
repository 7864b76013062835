//! The saved state of a workbench session: what the user chose and typed, and
//! every run with its prompts, outputs, scores, settings, timing and token use.
//! Saved with atomic writes (temporary file, then rename) so a crash never
//! leaves half a file; a file that cannot be read is set aside, not fatal.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::agents::config::AgentSettings;
use crate::agents::pipeline::AgentRecord;
use crate::agents::{AgentRole, Approach, Usage};
use crate::dataset::Corruption;

mod file;
mod migrate;
mod repair;

pub use file::{decode, default_path, restore, save, Restored, SessionError};

/// The format version written into every session file.
pub const SESSION_VERSION: u32 = 6;

/// Where the ground truth in use came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum GroundTruthSource {
    /// One of the built-in demo's ground truths, by index.
    Demo {
        /// Index into the demo's ground truths.
        index: usize,
    },
    /// The ground truth of a dataset task.
    Dataset {
        /// The task id.
        task: String,
    },
    /// A step file.
    File {
        /// The file it was read from.
        path: PathBuf,
    },
    /// Typed in the workbench.
    Typed,
}

/// Where the plan in the Plan pane came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum PlanSource {
    /// No plan yet.
    None,
    /// The planner of a run.
    Run {
        /// The run's id.
        run: u64,
    },
    /// A plan published with a dataset task.
    Published {
        /// The task id.
        task: String,
        /// The approach whose plan it is.
        approach: Approach,
    },
}

/// The scores of a plan against a ground truth.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ScoreRecord {
    /// KAS, when applicable.
    pub kas: Option<f64>,
    /// S_plan, when the sentence encoder was available.
    pub s_plan: Option<f64>,
    /// S_goal, when the goal models were available.
    pub s_goal: Option<f64>,
    /// PG2S, when S_goal was available.
    pub pg2s: Option<f64>,
}

/// One run of the agents, kept for the history and for comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The run's id, increasing within a session.
    pub id: u64,
    /// When it started, in seconds since the Unix epoch.
    pub started_unix: u64,
    /// The approach it used.
    pub approach: Approach,
    /// The task text.
    pub task: String,
    /// The agents it ran.
    pub agents: Vec<AgentRecord>,
    /// The prompt template text each agent ran with, as the compare and
    /// diff views show it (a record keeps the template's name and hash).
    pub prompts: BTreeMap<AgentRole, String>,
    /// The plan it produced.
    pub plan: Vec<String>,
    /// The ground truth it was scored against.
    pub ground_truth: Vec<String>,
    /// Its scores, once computed.
    pub scores: Option<ScoreRecord>,
    /// What became of it: only a finished run, and the complete samples of
    /// a partial one, count as scored plans.
    pub state: RunState,
    /// The first failure of its agents as they reported it (`Planner: …`),
    /// when one failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Why it is not simply finished, in words the history and the panes
    /// show (cancelled, quit during the run, a partial plan kept, samples
    /// that failed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Set when the run's plan was made by corrupting a plan (the Plan
    /// pane's `c`), not by agents: where that plan came from and the edits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corrupted: Option<CorruptedFrom>,
    /// Each plan step's part of the scores, as the Plan pane marked it when
    /// the run was scored, so two runs' steps can be compared without
    /// scoring again (absent in older sessions and before scoring).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub steps: Vec<StepScore>,
    /// The samples after the first, in order, when the run asked for more
    /// than one (the run's own `agents`, `plan` and `scores` are sample 0;
    /// a run of one sample, and every run saved before version 3, has none).
    #[serde(default)]
    pub samples: Vec<SampleRecord>,
}

/// What became of a run. A run that is not finished is never scored as a
/// plan: it stays out of the sparkline, the means and the diff's verdict;
/// a partial run counts over its complete samples only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunState {
    /// Its agents are still at work (a session saved during the run; it is
    /// restored as cancelled).
    Running,
    /// Every agent of every sample answered.
    Finished,
    /// An agent of its first sample failed: it has no plan to score (a plan
    /// broken off mid-stream is kept, marked, unscored).
    Failed,
    /// Cancelled by the user, or the workbench stopped during it.
    Cancelled,
    /// Some later samples failed: scored over its complete samples only.
    Partial,
}

impl RunState {
    /// The word the history, the panes and the diff show for it.
    pub fn word(self) -> &'static str {
        match self {
            RunState::Running => "running",
            RunState::Finished => "finished",
            RunState::Failed => "failed",
            RunState::Cancelled => "cancelled",
            RunState::Partial => "partial",
        }
    }

    /// Whether the run's (complete) samples count as scored plans.
    pub fn is_scored(self) -> bool {
        matches!(self, RunState::Finished | RunState::Partial)
    }
}

/// A later sample of a run (see [`RunRecord::samples`]): the same agents,
/// prompts and settings asked again, with what they answered and how the
/// plan scored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleRecord {
    /// Which sample (1 for the second; the run itself is sample 0).
    pub sample: u32,
    /// Each agent's call of this sample, in the order they started: its
    /// answer, failure, tokens, time and whether it came from the cache
    /// (a sample saved before version 5 has its answers only).
    pub agents: Vec<AgentRecord>,
    /// The plan it produced.
    pub plan: Vec<String>,
    /// Token use over its agents.
    pub usage: Usage,
    /// The first agent's failure, when one failed.
    pub error: Option<String>,
    /// Its scores, once computed.
    pub scores: Option<ScoreRecord>,
}

/// One plan step's part of a run's scores: its KAS step score and the
/// ground-truth step PG2S matched it to, the breakdown the Plan pane shows
/// under each step (the reason for every point lost).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct StepScore {
    /// KAS of this step against the ground-truth step at the same position.
    pub kas: Option<f64>,
    /// The ground-truth step (0-based) PG2S matched this step to, and the
    /// cosine of the match; `None` when unmatched or PG2S was not computed.
    pub matched: Option<(usize, f64)>,
}

/// A plan corrupted on purpose: the plan it was made from and what was
/// changed, so the change can be checked and undone by hand.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorruptedFrom {
    /// Where the source plan came from.
    pub source: PlanSource,
    /// The kind, the seed and the edits.
    pub corruption: Corruption,
}

impl RunRecord {
    /// Every sample's scores of the run, in sample order: the one place the run
    /// diff's verdicts and the Scores pane read a run's samples from. The run's
    /// own scores are sample 0; each later sample follows once scored (a
    /// sample not scored yet is left out).
    ///
    /// Only complete samples of a run that counts as scored ([`RunState::is_scored`])
    /// are given: a failed or cancelled run has none, a partial run its
    /// complete samples only.
    pub fn sample_scores(&self) -> Vec<ScoreRecord> {
        if !self.state.is_scored() {
            return Vec::new();
        }
        self.scores
            .into_iter()
            .chain(
                self.samples
                    .iter()
                    .filter(|s| s.error.is_none())
                    .filter_map(|s| s.scores),
            )
            .collect()
    }

    /// What became of it in one line, as every view says it: `finished`, or
    /// the state's word with the failure and the reason (`failed: Planner:
    /// HTTP 500 … (no plan, not scored)`).
    pub fn state_text(&self) -> String {
        let word = self.state.word();
        match (&self.error, &self.reason) {
            (Some(error), Some(reason)) => format!("{word}: {error} ({reason})"),
            (Some(error), None) => format!("{word}: {error}"),
            (None, Some(reason)) if reason.starts_with(word) => reason.clone(),
            (None, Some(reason)) => format!("{word}: {reason}"),
            (None, None) => word.to_string(),
        }
    }

    /// Every agent call it made, sample by sample: its own agents (sample
    /// 0), then each later sample's.
    pub fn calls(&self) -> impl Iterator<Item = &AgentRecord> {
        self.agents
            .iter()
            .chain(self.samples.iter().flat_map(|s| &s.agents))
    }

    /// The time of every call it made, summed, in milliseconds.
    pub fn total_ms(&self) -> u64 {
        self.calls().map(|a| a.elapsed_ms).sum()
    }

    /// The tokens every call it made sent and wrote, summed (a later
    /// sample counts its own total, which sessions before version 5 kept
    /// without the split by agent).
    pub fn total_tokens(&self) -> u64 {
        let tokens = |u: &Usage| u.input_tokens + u.output_tokens;
        self.agents.iter().map(|a| tokens(&a.usage)).sum::<u64>()
            + self.samples.iter().map(|s| tokens(&s.usage)).sum::<u64>()
    }
}

/// Text being edited when the session was saved, so a kill loses nothing typed.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Draft {
    /// What is being edited: `plan`, `ground_truth`.
    pub target: String,
    /// The step index being edited.
    pub index: usize,
    /// The text typed so far.
    pub text: String,
}

/// What one source of plans keeps of its own: the built-in demo, or one
/// dataset task. Each source has its own plan, ground truth, agents' answers
/// and run history, so opening one never shows or scores anything of
/// another.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourceState {
    /// The dataset task, or `None` for the built-in demo.
    pub task_id: Option<String>,
    /// The approach.
    pub approach: Approach,
    /// The ground truth's origin.
    pub ground_truth_source: GroundTruthSource,
    /// The ground-truth steps, as edited.
    pub ground_truth: Vec<String>,
    /// The plan's origin.
    pub plan_source: PlanSource,
    /// The plan steps, as edited.
    pub plan: Vec<String>,
    /// The settings of each agent.
    pub settings: BTreeMap<AgentRole, AgentSettings>,
    /// The latest output of each agent.
    pub outputs: BTreeMap<AgentRole, String>,
    /// The prompt and settings each output was made with.
    pub ran_with: BTreeMap<AgentRole, (String, AgentSettings)>,
    /// Every run on this source.
    pub runs: Vec<RunRecord>,
}

/// Everything a session restores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Session {
    /// The format version ([`SESSION_VERSION`]).
    pub version: u32,
    /// The source in use when the session was saved (its fields sit at the
    /// top of the file, where version 5 kept them).
    #[serde(flatten)]
    pub current: SourceState,
    /// The other sources opened in this session, each as it was left.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parked: Vec<SourceState>,
    /// The prompt templates edited in the workbench, by template name (e.g.
    /// `multi-image-planner`); the others are the built-in or user ones.
    pub prompts: BTreeMap<String, String>,
    /// The theme's name.
    pub theme: String,
    /// Whether the scene image is shown.
    pub image: bool,
    /// How many samples `r` asks each agent for (1 to
    /// [`MAX_SAMPLES`](crate::agents::pipeline::MAX_SAMPLES)).
    pub samples: u32,
    /// Text being edited at the time of saving.
    pub draft: Option<Draft>,
}

/// Why the bytes of a file are not a session this version can read; the
/// file is then set aside, not fatal.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The bytes are not JSON of a session (the parser's words).
    #[error("not a session file ({0})")]
    NotSession(String),
    /// The JSON has no version field.
    #[error("not a session file (no version)")]
    NoVersion,
    /// A newer mapvlm wrote the file.
    #[error("version {0} was written by a newer mapvlm than this one (version {SESSION_VERSION})")]
    Newer(u64),
    /// A version older than any migration knows.
    #[error("version {0} is too old to read")]
    TooOld(u64),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Session {
        let mut session = Session {
            version: SESSION_VERSION,
            current: SourceState {
                task_id: None,
                approach: Approach::MultiImage,
                ground_truth_source: GroundTruthSource::Demo { index: 1 },
                ground_truth: vec!["Walk to the sink.".into()],
                plan_source: PlanSource::Run { run: 3 },
                plan: vec!["Go to the sink.".into()],
                settings: BTreeMap::new(),
                outputs: BTreeMap::new(),
                ran_with: BTreeMap::new(),
                runs: Vec::new(),
            },
            parked: Vec::new(),
            prompts: BTreeMap::from([("multi-image-skm".into(), "[user]\nList triples.".into())]),
            theme: "dark".into(),
            image: true,
            samples: 3,
            draft: Some(Draft {
                target: "plan".into(),
                index: 0,
                text: "Go to".into(),
            }),
        };
        session.parked.push(SourceState {
            task_id: Some("pick-1".into()),
            ground_truth_source: GroundTruthSource::Dataset {
                task: "pick-1".into(),
            },
            ..session.current.clone()
        });
        session
    }

    #[test]
    fn saves_and_restores_the_same_session() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nested/session.json");
        save(&path, &sample()).unwrap();
        match restore(&path).unwrap() {
            Restored::Loaded { session, repaired } => {
                assert_eq!(*session, sample());
                assert!(repaired.is_empty(), "{repaired:?}");
            }
            other => panic!("{other:?}"),
        }
        let left: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(left.len(), 1, "no temporary file is left behind");
    }

    #[test]
    fn the_session_file_is_the_owners_only_even_when_it_was_not() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.json");
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        save(&path, &sample()).unwrap();
        assert_eq!(mode(&path), 0o600);
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        save(&path, &sample()).unwrap();
        assert_eq!(mode(&path), 0o600);
    }

    #[test]
    fn a_session_from_a_newer_version_is_set_aside_with_the_reason() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.json");
        let mut newer = serde_json::to_value(sample()).unwrap();
        newer["version"] = (SESSION_VERSION + 1).into();
        std::fs::write(&path, newer.to_string()).unwrap();
        match restore(&path).unwrap() {
            Restored::SetAside { moved_to, reason } => {
                assert!(moved_to.exists());
                assert!(reason.to_string().contains("newer mapvlm"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_bad_number_falls_back_with_a_notice_and_the_history_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.json");
        let settings = AgentSettings::new(crate::agents::ProviderKind::Openai, "gpt-4o", 0.5, 300);
        let mut saved = sample();
        saved
            .current
            .settings
            .insert(AgentRole::Planner, settings.clone());
        saved.current.runs.push(RunRecord {
            id: 1,
            started_unix: 1_700_000_000,
            approach: Approach::MultiImage,
            task: "Wash the mug.".into(),
            agents: vec![AgentRecord {
                output: Some("1. Wash the mug.".into()),
                elapsed_ms: 1200,
                ..AgentRecord::blank(AgentRole::Planner, &settings, "multi-image-planner", "0123")
            }],
            prompts: BTreeMap::from([(AgentRole::Planner, "Plan.".to_string())]),
            plan: vec!["Wash the mug.".into()],
            ground_truth: vec!["Wash the mug.".into()],
            scores: None,
            state: RunState::Finished,
            error: None,
            reason: None,
            corrupted: None,
            steps: Vec::new(),
            samples: Vec::new(),
        });
        save(&path, &saved).unwrap();
        let mut json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        // What an older mapvlm saved for a temperature of 1e300 (an f32
        // infinity is written as null), and a hand-edited token limit.
        json["settings"]["planner"]["temperature"] = serde_json::Value::Null;
        json["runs"][0]["agents"][0]["max_tokens"] = (-5).into();
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        let Restored::Loaded { session, repaired } = restore(&path).unwrap() else {
            panic!("the session was set aside");
        };
        assert_eq!(session.current.runs, {
            let mut runs = saved.current.runs.clone();
            runs[0].agents[0].settings.max_tokens = crate::agents::config::DEFAULT_MAX_TOKENS;
            runs
        });
        assert_eq!(
            session.current.settings[&AgentRole::Planner].temperature,
            0.0
        );
        assert_eq!(repaired.len(), 2, "{repaired:?}");
        assert!(
            repaired[0].contains("settings.planner.temperature = null"),
            "{repaired:?}"
        );
        assert!(repaired[1].contains("runs[0].agents[0].max_tokens = -5"));
    }

    #[test]
    fn a_missing_file_is_a_fresh_session() {
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(
            restore(&dir.path().join("none.json")).unwrap(),
            Restored::Fresh
        ));
    }

    #[test]
    fn a_corrupted_file_is_set_aside() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.json");
        std::fs::write(&path, b"{\"version\": 1, \"plan\": [").unwrap();
        match restore(&path).unwrap() {
            Restored::SetAside { moved_to, reason } => {
                assert!(!path.exists());
                assert!(moved_to.exists());
                assert!(
                    reason.to_string().contains("not a session file"),
                    "{reason}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    mod properties {
        use super::*;
        use proptest::prelude::*;

        fn settings() -> impl Strategy<Value = AgentSettings> {
            (
                prop::sample::select(vec![
                    crate::agents::ProviderKind::Openai,
                    crate::agents::ProviderKind::Anthropic,
                    crate::agents::ProviderKind::Replay,
                ]),
                "[a-z0-9.-]{1,12}",
                0.0f32..=2.0,
                crate::agents::config::MAX_TOKENS_RANGE,
                any::<(bool, bool)>(),
            )
                .prop_map(
                    |(provider, model, temperature, max_tokens, (stream, json_output))| {
                        AgentSettings {
                            stream,
                            json_output,
                            ..AgentSettings::new(provider, &model, temperature, max_tokens)
                        }
                    },
                )
        }

        fn session() -> impl Strategy<Value = Session> {
            let text = || "[ -~é水\n\t\"\\\\]{0,20}";
            let steps = || prop::collection::vec("[ -~é]{0,16}", 0..5);
            let role = || prop::sample::select(AgentRole::ALL.to_vec());
            (
                (
                    prop::option::of("[a-z0-9-]{1,10}"),
                    prop::sample::select(Approach::ALL.to_vec()),
                ),
                (
                    steps(),
                    steps(),
                    prop::collection::btree_map("[a-z-]{1,12}", text(), 0..3),
                ),
                (
                    prop::collection::btree_map(role(), settings(), 0..3),
                    prop::collection::btree_map(role(), text(), 0..3),
                    prop::collection::btree_map(role(), (text(), settings()), 0..2),
                ),
                (any::<bool>(), prop::option::of((text(), any::<usize>()))),
                (any::<u64>(), prop::option::of(-1.0e300f64..1.0e300)),
            )
                .prop_map(|(head, plans, agents, (image, draft), (run, kas))| {
                    Session {
                        version: SESSION_VERSION,
                        current: SourceState {
                            task_id: head.0,
                            approach: head.1,
                            ground_truth_source: GroundTruthSource::Typed,
                            ground_truth: plans.0.clone(),
                            plan_source: PlanSource::Run { run },
                            plan: plans.1.clone(),
                            settings: agents.0.clone(),
                            outputs: agents.1.clone(),
                            ran_with: agents.2,
                            runs: vec![RunRecord {
                                id: run,
                                started_unix: run / 2,
                                approach: head.1,
                                task: "Do it.".into(),
                                agents: agents
                                    .0
                                    .iter()
                                    .map(|(&role, settings)| AgentRecord {
                                        output: Some("1. Go.".into()),
                                        ..AgentRecord::blank(
                                            role,
                                            settings,
                                            "multi-image-planner",
                                            "0123",
                                        )
                                    })
                                    .collect(),
                                prompts: agents.1,
                                plan: plans.1,
                                ground_truth: plans.0,
                                scores: Some(ScoreRecord {
                                    kas,
                                    ..ScoreRecord::default()
                                }),
                                state: if image {
                                    RunState::Cancelled
                                } else {
                                    RunState::Finished
                                },
                                error: None,
                                reason: image.then(|| "cancelled".to_string()),
                                corrupted: None,
                                steps: Vec::new(),
                                samples: Vec::new(),
                            }],
                        },
                        parked: Vec::new(),
                        image,
                        prompts: plans.2,
                        theme: "dark".into(),
                        samples: 1 + (run % 100) as u32,
                        draft: draft.map(|(text, index)| Draft {
                            target: "plan".into(),
                            index,
                            text,
                        }),
                    }
                })
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(64))]

            /// A saved session is restored unchanged.
            #[test]
            fn a_saved_session_restores_unchanged(session in session()) {
                let dir = tempfile::tempdir().map_err(|e| TestCaseError::fail(e.to_string()))?;
                let path = dir.path().join("session.json");
                save(&path, &session).map_err(|e| TestCaseError::fail(e.to_string()))?;
                match restore(&path) {
                    Ok(Restored::Loaded { session: back, repaired }) => {
                        prop_assert_eq!(*back, session);
                        prop_assert!(repaired.is_empty(), "{:?}", repaired);
                    }
                    other => prop_assert!(false, "{other:?}"),
                }
            }

            /// Any bytes: no panic; what decodes is a session of this
            /// version that decodes again after saving.
            #[test]
            fn any_bytes_decode_without_panic_and_round_trip(
                bytes in prop::collection::vec(any::<u8>(), 0..200),
            ) {
                if let Ok((session, _)) = decode(&bytes) {
                    prop_assert_eq!(session.version, SESSION_VERSION);
                    let saved = serde_json::to_vec(&session).unwrap_or_default();
                    prop_assert_eq!(decode(&saved), Ok((session, Vec::new())));
                }
            }
        }
    }
}
