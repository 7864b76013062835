//! The built-in example: a task, its ground truth and a plan, written for
//! this project, used when a command is given no input of its own.

/// The task of the built-in example.
pub const TASK: &str = include_str!("demo/task.txt");

/// The ground-truth plan of the built-in example, one step a line.
pub const GROUND_TRUTH: &str = include_str!("demo/ground_truth.txt");

/// A predicted plan for the built-in example, as a model might write it.
pub const PLAN: &str = include_str!("demo/plan.txt");

mod scene;

pub use scene::{scene_image, scene_png};

/// A second ground truth for the built-in example, as another annotator
/// wrote it, so a user can switch ground truths and watch the scores move.
pub const GROUND_TRUTH_B: &str = include_str!("demo/ground_truth_b.txt");

/// The recorded output of the semantic-knowledge miner: scene triples.
pub const SKM_OUTPUT: &str = include_str!("demo/skm.txt");

/// The recorded output of the grounded-knowledge miner.
pub const GKM_OUTPUT: &str = include_str!("demo/gkm.txt");

/// The recorded raw output of the planner, preamble and closing remark included.
pub const PLANNER_OUTPUT: &str = include_str!("demo/planner.txt");

/// The demo's recording (a [`crate::agents::replay::Recording`] as JSON):
/// the answers above, hand-written, keyed by the requests the built-in
/// `prompts/` templates make for the demo task and scene.
pub const RECORDING: &str = include_str!("demo/recording.json");
