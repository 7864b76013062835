//! The verdict per metric of a run diff: the change in the mean over the
//! runs' samples, and whether it exceeds their spread (a permutation test
//! from the one statistics module).

use crate::stats::permutation::mean_difference;
use crate::stats::summary::mean;
use crate::workbench::session::ScoreRecord;

/// Permutations of the verdicts' test (enough for a p-value near 0.05 to
/// be read to about ±0.005).
const PERMUTATIONS: usize = 2_000;

/// The seed of the verdicts' permutations, fixed so a diff always reads the same.
const SEED: u64 = 0;

/// A change in mean with a permutation p-value below this exceeds the spread.
pub const SIGNIFICANCE: f64 = 0.05;

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

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
