//! The built-in example: a task, its ground truth and a plan, written for
//! this project, used when a command is given no input of its own.

/// The task of the built-in example.
pub const TASK: &str = include_str!("demo/task.txt");

/// The ground-truth plan of the built-in example, one step a line.
pub const GROUND_TRUTH: &str = include_str!("demo/ground_truth.txt");

/// A predicted plan for the built-in example, as a model might write it.
pub const PLAN: &str = include_str!("demo/plan.txt");
