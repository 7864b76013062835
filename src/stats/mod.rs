//! Agreement statistics, written once for the whole product: rank
//! correlations as scipy computes them, pairwise accuracy, percentile
//! bootstrap intervals, permutation tests (paired tau-b, two-sample means),
//! Williams' test of dependent correlations with Holm's correction,
//! Krippendorff's alpha, and the mean and sd of samples.
//!
//! Every statistic that can be undefined (too few items, a constant column)
//! returns [`Undefined`] with the reason instead of NaN, so a report can
//! print `null` and say why.

pub mod bootstrap;
pub mod correlation;
pub mod holm;
pub mod krippendorff;
pub mod pairs;
pub mod permutation;
pub mod pvalue;
pub mod rank;
pub mod rng;
pub mod summary;
pub mod williams;

/// Why a statistic has no value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Undefined {
    /// Fewer than two observations.
    #[error("fewer than two items")]
    TooFewItems,
    /// One of the two columns has a single value, so nothing can be ranked.
    #[error("the {0} column is constant")]
    Constant(Column),
    /// Every pair of items ties on the human score.
    #[error("no two items have different human scores")]
    NoDifferingPairs,
    /// No unit was judged by two or more coders.
    #[error("no item was rated by two or more annotators")]
    NoSharedUnits,
    /// No step was labelled by two or more annotators.
    #[error("no step was labelled by two or more annotators")]
    NoSharedSteps,
    /// Every pairable value is the same, so there is no disagreement to expect.
    #[error("every rating is the same")]
    NoVariation,
    /// No resample or permutation gave a defined value.
    #[error("undefined on every resample")]
    NoResample,
    /// A pairwise comparison had nothing to compare.
    #[error("no preference between two scored items")]
    NoPreferences,
    /// Williams' test has n − 3 degrees of freedom.
    #[error("fewer than four items")]
    FewerThanFourItems,
    /// A correlation of exactly ±1 leaves nothing to test.
    #[error("a correlation is exactly 1 or -1")]
    PerfectCorrelation,
    /// The three columns of Williams' test are linearly dependent.
    #[error("the human score and the two metrics are linearly dependent")]
    Collinear,
}

/// Which column of a paired statistic a reason is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// The first column (a metric's values).
    First,
    /// The second column (the human scores).
    Second,
}

impl std::fmt::Display for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Column::First => "metric",
            Column::Second => "human",
        })
    }
}

/// A statistic's value, or why it has none.
pub type Estimate = Result<f64, Undefined>;
