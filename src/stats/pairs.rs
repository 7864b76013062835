//! The pair counts of two paired columns (Knight's algorithm counts them in
//! O(n log n), [`super::correlation`]) and the sizes of their tie groups:
//! what Kendall's tau-b, pairwise accuracy and the p-value of tau-b
//! ([`super::pvalue`]) are computed from, kept apart from both so that
//! neither imports the other.

use super::{Column, Estimate, Undefined};

/// Pair counts of Knight's algorithm, over the items counted with their
/// multiplicity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairCounts {
    /// All pairs, `n (n - 1) / 2`.
    pub total: u64,
    /// Pairs ordered oppositely by the two columns.
    pub discordant: u64,
    /// Pairs tied on x.
    pub x_ties: u64,
    /// Pairs tied on y.
    pub y_ties: u64,
    /// Pairs tied on both.
    pub joint_ties: u64,
}

impl PairCounts {
    /// Pairs ordered the same way by both columns.
    pub fn concordant(&self) -> u64 {
        self.total + self.joint_ties - self.discordant - self.x_ties - self.y_ties
    }

    /// Kendall's tau-b, with the arithmetic of `scipy.stats.kendalltau`.
    pub fn tau_b(&self, n: u64) -> Estimate {
        if n < 2 {
            return Err(Undefined::TooFewItems);
        }
        if self.x_ties == self.total {
            return Err(Undefined::Constant(Column::First));
        }
        if self.y_ties == self.total {
            return Err(Undefined::Constant(Column::Second));
        }
        let con_minus_dis = self.concordant() as f64 - self.discordant as f64;
        let tau = con_minus_dis
            / ((self.total - self.x_ties) as f64).sqrt()
            / ((self.total - self.y_ties) as f64).sqrt();
        Ok(tau.clamp(-1.0, 1.0))
    }

    /// Pairwise accuracy: concordant pairs over the pairs whose y differ.
    pub fn pairwise_accuracy(&self, n: u64) -> Estimate {
        if n < 2 {
            return Err(Undefined::TooFewItems);
        }
        let differing = self.total - self.y_ties;
        if differing == 0 {
            return Err(Undefined::NoDifferingPairs);
        }
        Ok(self.concordant() as f64 / differing as f64)
    }
}

/// The sizes of the tie groups of one column (values shared by two or more
/// items), for the variance of tau-b.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TieSums {
    /// Σ t(t − 1)(t − 2) over the groups.
    pub cubic: u64,
    /// Σ t(t − 1)(2t + 5) over the groups.
    pub variance: u64,
}

impl TieSums {
    /// The sums over groups of these sizes.
    pub fn of(sizes: impl IntoIterator<Item = u64>) -> TieSums {
        let mut sums = TieSums::default();
        for t in sizes.into_iter().filter(|&t| t > 1) {
            sums.cubic += t * (t - 1) * (t - 2);
            sums.variance += t * (t - 1) * (2 * t + 5);
        }
        sums
    }
}

/// `n (n - 1) / 2`: the pairs among `n` items.
pub fn pairs(n: u64) -> u64 {
    n * n.saturating_sub(1) / 2
}
