//! Correlation of a metric with the human scores: Kendall's tau-b,
//! Spearman's rho and Pearson's r as `scipy.stats` computes them, and
//! pairwise accuracy, all in O(n log n).
//!
//! The columns are prepared once ([`Paired::new`]: dense ranks and the order
//! by both columns); the statistics can then be computed for any
//! multiplicity of the items ([`Paired::correlations_weighted`]), which is
//! what a bootstrap resample is, without sorting again.

use super::pairs::{pairs, PairCounts, TieSums};
use super::pvalue::PValues;
use super::rank::dense_ranks;
use super::{Column, Estimate, Undefined};

/// Two paired columns (a metric's values and the human scores of the same
/// items), prepared for rank statistics.
#[derive(Debug, Clone)]
pub struct Paired {
    x: Vec<f64>,
    y: Vec<f64>,
    /// Dense rank of each x (0-based).
    x_rank: Vec<u32>,
    /// Dense rank of each y (1-based, for the Fenwick tree).
    y_rank: Vec<u32>,
    /// Distinct y values.
    y_distinct: usize,
    /// The items ordered by x rank, then y rank.
    order: Vec<u32>,
}

/// The four agreement statistics of a metric with the human scores.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correlations {
    /// Items compared (with a bootstrap resample: counted with multiplicity).
    pub n: u64,
    /// Kendall's tau-b (`scipy.stats.kendalltau`).
    pub kendall_tau_b: Estimate,
    /// Spearman's rho (`scipy.stats.spearmanr`).
    pub spearman: Estimate,
    /// Pearson's r (`scipy.stats.pearsonr`).
    pub pearson: Estimate,
    /// Among pairs whose human scores differ, the fraction the metric orders
    /// the same way (a metric tie is not agreement).
    pub pairwise_accuracy: Estimate,
}

/// A column with its dense ranks ([`dense_ranks`]: 0-based, equal values
/// sharing a rank).
#[derive(Debug, Clone, PartialEq)]
pub struct Ranked {
    /// The values.
    pub values: Vec<f64>,
    /// The dense rank of each value.
    pub ranks: Vec<u32>,
    /// How many distinct values (ranks run below this).
    pub distinct: usize,
}

impl Paired {
    /// Prepares two columns of equal length (`x` the metric, `y` the human
    /// score). Panics never; extra values of the longer column are ignored.
    pub fn new(x: &[f64], y: &[f64]) -> Paired {
        let len = x.len().min(y.len());
        let (x_rank, x_distinct) = dense_ranks(&x[..len]);
        let (y_rank, y_distinct) = dense_ranks(&y[..len]);
        Paired::from_ranks(
            Ranked {
                values: x[..len].to_vec(),
                ranks: x_rank,
                distinct: x_distinct,
            },
            Ranked {
                values: y[..len].to_vec(),
                ranks: y_rank,
                distinct: y_distinct,
            },
        )
    }

    /// Prepares two columns whose dense ranks are known already; the order
    /// by both is found by counting, in O(n + distinct values), so a column
    /// that changes on every permutation needs no sort.
    pub fn from_ranks(x: Ranked, y: Ranked) -> Paired {
        let by_y = counting_order(0..x.ranks.len() as u32, &y.ranks, y.distinct);
        let order = counting_order(by_y.into_iter(), &x.ranks, x.distinct);
        Paired {
            x: x.values,
            y: y.values,
            x_rank: x.ranks,
            y_rank: y.ranks.into_iter().map(|r| r + 1).collect(),
            y_distinct: y.distinct,
            order,
        }
    }

    /// How many items there are.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no items.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// The statistics over the items as they are.
    pub fn correlations(&self) -> Correlations {
        self.correlations_weighted(&vec![1; self.len()])
    }

    /// The statistics over the items repeated `weights[i]` times each (a
    /// bootstrap resample; weight 0 leaves an item out). The result equals
    /// scipy's on the expanded columns.
    pub fn correlations_weighted(&self, weights: &[u32]) -> Correlations {
        let (counts, ranks) = self.pair_counts(weights);
        let n = ranks.n;
        Correlations {
            n,
            kendall_tau_b: counts.tau_b(n),
            spearman: self.spearman(weights, &ranks),
            pearson: self.pearson(weights, &ranks),
            pairwise_accuracy: counts.pairwise_accuracy(n),
        }
    }

    /// The two-sided p-values of tau-b, rho and r over the items as they
    /// are, as scipy computes them ([`super::pvalue`]).
    pub fn p_values(&self) -> PValues {
        let ones = vec![1; self.len()];
        let (counts, ranks) = self.pair_counts(&ones);
        let n = ranks.n;
        let sizes = |ranks: &[u32], distinct: usize| {
            let mut size = vec![0u64; distinct + 1];
            for &r in ranks {
                size[r as usize] += 1;
            }
            TieSums::of(size)
        };
        let (x, y) = (
            sizes(&self.x_rank, self.len()),
            sizes(&self.y_rank, self.y_distinct),
        );
        PValues {
            kendall_tau_b: super::pvalue::kendall(n, &counts, x, y),
            spearman: super::pvalue::spearman(n, self.spearman(&ones, &ranks)),
            pearson: super::pvalue::pearson(n, self.pearson(&ones, &ranks)),
        }
    }

    /// Kendall's tau-b alone, over the items with these multiplicities.
    pub fn kendall_tau_b(&self, weights: &[u32]) -> Estimate {
        let (counts, ranks) = self.pair_counts(weights);
        counts.tau_b(ranks.n)
    }

    /// Knight's counts: the items in (x, y) order, discordances counted with
    /// a Fenwick tree over the y ranks (as scipy's `_kendall_dis`), and the
    /// average ranks of both columns on the way.
    fn pair_counts(&self, weights: &[u32]) -> (PairCounts, AverageRanks) {
        let mut tree = vec![0u64; self.y_distinct + 1];
        let mut y_weight = vec![0u64; self.y_distinct + 1];
        let mut x_avg = vec![0.0f64; self.len()];
        let mut counts = PairCounts::default();
        let mut inserted = 0u64;
        let mut x_groups = 0usize;
        let mut k = 0;
        while k < self.order.len() {
            let xr = self.x_rank[self.order[k] as usize];
            let mut end = k;
            while end < self.order.len() && self.x_rank[self.order[end] as usize] == xr {
                end += 1;
            }
            let group = &self.order[k..end];
            let mut group_weight = 0u64;
            let mut run_y = u32::MAX;
            let mut run_weight = 0u64;
            for &i in group {
                let (i, w) = (i as usize, u64::from(weights[i as usize]));
                if w == 0 {
                    continue;
                }
                let yr = self.y_rank[i];
                counts.discordant += w * (inserted - prefix(&tree, yr));
                if yr != run_y {
                    counts.joint_ties += pairs(run_weight);
                    run_y = yr;
                    run_weight = 0;
                }
                run_weight += w;
                group_weight += w;
            }
            counts.joint_ties += pairs(run_weight);
            counts.x_ties += pairs(group_weight);
            if group_weight > 0 {
                x_groups += 1;
                let rank = inserted as f64 + (group_weight as f64 + 1.0) / 2.0;
                for &i in group {
                    let (i, w) = (i as usize, u64::from(weights[i as usize]));
                    if w == 0 {
                        continue;
                    }
                    x_avg[i] = rank;
                    add(&mut tree, self.y_rank[i], w);
                    y_weight[self.y_rank[i] as usize] += w;
                }
            }
            inserted += group_weight;
            k = end;
        }
        counts.total = pairs(inserted);
        counts.y_ties = y_weight.iter().map(|&w| pairs(w)).sum();
        let mut y_avg = vec![0.0f64; self.y_distinct + 1];
        let mut start = 0u64;
        let mut y_groups = 0usize;
        for (r, &w) in y_weight.iter().enumerate() {
            if w > 0 {
                y_groups += 1;
                y_avg[r] = start as f64 + (w as f64 + 1.0) / 2.0;
                start += w;
            }
        }
        let ranks = AverageRanks {
            n: inserted,
            x: x_avg,
            y: y_avg,
            x_groups,
            y_groups,
        };
        (counts, ranks)
    }

    /// Spearman's rho: Pearson's r of the average ranks.
    fn spearman(&self, weights: &[u32], ranks: &AverageRanks) -> Estimate {
        ranks.defined()?;
        let y: Vec<f64> = self.y_rank.iter().map(|&r| ranks.y[r as usize]).collect();
        Ok(weighted_pearson(&ranks.x, &y, weights, ranks.n))
    }

    /// Pearson's r of the values.
    fn pearson(&self, weights: &[u32], ranks: &AverageRanks) -> Estimate {
        ranks.defined()?;
        Ok(weighted_pearson(&self.x, &self.y, weights, ranks.n))
    }
}

/// The average ranks of one weighting, and whether either column is constant.
struct AverageRanks {
    /// Items counted with their multiplicity.
    n: u64,
    /// Average rank of each item's x.
    x: Vec<f64>,
    /// Average rank of each y rank.
    y: Vec<f64>,
    /// Distinct x values among the weighted items.
    x_groups: usize,
    /// Distinct y values among the weighted items.
    y_groups: usize,
}

impl AverageRanks {
    /// Whether a correlation is defined: two items and two values on each side.
    fn defined(&self) -> Result<(), Undefined> {
        if self.n < 2 {
            Err(Undefined::TooFewItems)
        } else if self.x_groups < 2 {
            Err(Undefined::Constant(Column::First))
        } else if self.y_groups < 2 {
            Err(Undefined::Constant(Column::Second))
        } else {
            Ok(())
        }
    }
}

/// Pearson's r of two non-constant columns with multiplicities, with the
/// arithmetic of `scipy.stats.pearsonr`: centred, scaled by the largest
/// deviation, normalised, then the dot product; exactly ±1 for two items.
fn weighted_pearson(x: &[f64], y: &[f64], weights: &[u32], n: u64) -> f64 {
    let total = n as f64;
    let mean = |v: &[f64]| -> f64 {
        v.iter()
            .zip(weights)
            .map(|(&a, &w)| f64::from(w) * a)
            .sum::<f64>()
            / total
    };
    let (x_mean, y_mean) = (mean(x), mean(y));
    let scale = |v: &[f64], m: f64| -> f64 {
        v.iter()
            .zip(weights)
            .filter(|(_, &w)| w > 0)
            .map(|(&a, _)| (a - m).abs())
            .fold(0.0, f64::max)
    };
    let (x_max, y_max) = (scale(x, x_mean), scale(y, y_mean));
    let norm = |v: &[f64], m: f64, s: f64| -> f64 {
        s * v
            .iter()
            .zip(weights)
            .map(|(&a, &w)| f64::from(w) * ((a - m) / s).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (x_norm, y_norm) = (norm(x, x_mean, x_max), norm(y, y_mean, y_max));
    let r: f64 = x
        .iter()
        .zip(y)
        .zip(weights)
        .map(|((&a, &b), &w)| f64::from(w) * ((a - x_mean) / x_norm) * ((b - y_mean) / y_norm))
        .sum();
    let r = r.clamp(-1.0, 1.0);
    if n == 2 {
        r.round()
    } else {
        r
    }
}

/// The items of `input`, stably ordered by `key` (values below `distinct`).
fn counting_order(input: impl Iterator<Item = u32>, key: &[u32], distinct: usize) -> Vec<u32> {
    let mut start = vec![0usize; distinct + 1];
    for &k in key {
        start[k as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut order = vec![0u32; key.len()];
    for i in input {
        let slot = &mut start[key[i as usize] as usize];
        order[*slot] = i;
        *slot += 1;
    }
    order
}

/// The total weight at Fenwick positions `1..=i`.
fn prefix(tree: &[u64], mut i: u32) -> u64 {
    let mut sum = 0;
    while i != 0 {
        sum += tree[i as usize];
        i &= i - 1;
    }
    sum
}

/// Adds `w` at Fenwick position `i` (1-based).
fn add(tree: &mut [u64], mut i: u32, w: u64) {
    while (i as usize) < tree.len() {
        tree[i as usize] += w;
        i += i & i.wrapping_neg();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The O(n²) definitions, for comparison.
    fn naive(x: &[f64], y: &[f64]) -> (PairCounts, u64) {
        let mut c = PairCounts::default();
        let mut agree = 0;
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                c.total += 1;
                let (dx, dy) = (x[i] - x[j], y[i] - y[j]);
                c.x_ties += u64::from(dx == 0.0);
                c.y_ties += u64::from(dy == 0.0);
                c.joint_ties += u64::from(dx == 0.0 && dy == 0.0);
                c.discordant += u64::from(dx * dy < 0.0);
                agree += u64::from(dx * dy > 0.0);
            }
        }
        (c, agree)
    }

    fn naive_pearson(x: &[f64], y: &[f64]) -> f64 {
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
        let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
        let syy: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
        sxy / (sxx * syy).sqrt()
    }

    fn expand(v: &[f64], w: &[u32]) -> Vec<f64> {
        v.iter()
            .zip(w)
            .flat_map(|(&a, &k)| std::iter::repeat_n(a, k as usize))
            .collect()
    }

    #[test]
    fn scipy_values_on_a_small_case_with_ties() {
        // scipy 1.17: kendalltau, spearmanr, pearsonr of these columns.
        let x = [0.1, 0.4, 0.4, 0.9, 0.3, 0.0];
        let y = [1.0, 3.0, 2.0, 5.0, 3.0, 1.0];
        let c = Paired::new(&x, &y).correlations();
        assert_eq!(c.n, 6);
        let close = |a: Estimate, b: f64| {
            assert!((a.unwrap_or(f64::NAN) - b).abs() < 1e-12, "{a:?} vs {b}")
        };
        close(c.kendall_tau_b, 0.7412493166611012);
        close(c.spearman, 0.8508410434878082);
        close(c.pearson, 0.9430419201928971);
        close(c.pairwise_accuracy, 11.0 / 13.0);
    }

    #[test]
    fn undefined_statistics_say_why() {
        let c = Paired::new(&[0.5], &[3.0]).correlations();
        assert_eq!(c.kendall_tau_b, Err(Undefined::TooFewItems));
        assert_eq!(c.pearson, Err(Undefined::TooFewItems));
        let c = Paired::new(&[0.5, 0.5, 0.5], &[1.0, 2.0, 3.0]).correlations();
        assert_eq!(c.kendall_tau_b, Err(Undefined::Constant(Column::First)));
        assert_eq!(c.spearman, Err(Undefined::Constant(Column::First)));
        assert_eq!(c.pearson, Err(Undefined::Constant(Column::First)));
        assert_eq!(c.pairwise_accuracy, Ok(0.0));
        let c = Paired::new(&[0.1, 0.2], &[4.0, 4.0]).correlations();
        assert_eq!(c.kendall_tau_b, Err(Undefined::Constant(Column::Second)));
        assert_eq!(c.pairwise_accuracy, Err(Undefined::NoDifferingPairs));
        let c = Paired::new(&[0.1, 0.2], &[5.0, 4.0]).correlations();
        assert_eq!(
            (c.kendall_tau_b, c.spearman, c.pearson),
            (Ok(-1.0), Ok(-1.0), Ok(-1.0))
        );
        assert!(Paired::new(&[], &[]).is_empty());
    }

    /// Within 1e-9 relative (how the p-values must equal scipy's).
    fn close_rel(actual: f64, expected: f64) {
        let scale = expected.abs().max(f64::MIN_POSITIVE);
        assert!(
            (actual - expected).abs() <= 1e-9 * scale,
            "{actual:e} against {expected:e}"
        );
    }

    #[test]
    fn p_values_equal_scipy_on_hand_made_cases() {
        // scipy 1.17.1: kendalltau, spearmanr and pearsonr of these columns.
        let x = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        let y = [2.0, 1.0, 4.0, 3.0, 6.0, 5.0, 8.0, 7.0];
        let p = Paired::new(&x, &y).p_values();
        close_rel(p.kendall_tau_b.unwrap_or(f64::NAN), 0.014136904761904762);
        close_rel(p.spearman.unwrap_or(f64::NAN), 0.002008275505429469);
        close_rel(p.pearson.unwrap_or(f64::NAN), 0.0020082755054294755);
        let x = [0.1, 0.4, 0.4, 0.9, 0.3, 0.7, 0.2, 0.8, 0.5, 0.6];
        let y = [1.0, 2.0, 2.0, 5.0, 3.0, 4.0, 1.0, 4.0, 3.0, 2.0];
        let p = Paired::new(&x, &y).p_values();
        close_rel(p.kendall_tau_b.unwrap_or(f64::NAN), 0.004233038463727445);
        close_rel(p.spearman.unwrap_or(f64::NAN), 0.0015219301526655069);
        close_rel(p.pearson.unwrap_or(f64::NAN), 0.0006730121941773329);
    }

    #[test]
    fn two_items_and_constant_columns() {
        let p = Paired::new(&[0.1, 0.2], &[1.0, 2.0]).p_values();
        assert_eq!(p.kendall_tau_b, Ok(1.0));
        assert_eq!(p.pearson, Ok(1.0));
        assert_eq!(p.spearman, Err(Undefined::TooFewItems));
        let p = Paired::new(&[0.1, 0.1, 0.1], &[1.0, 2.0, 3.0]).p_values();
        assert!(p.kendall_tau_b.is_err() && p.spearman.is_err() && p.pearson.is_err());
    }

    proptest! {
        #[test]
        fn counts_and_correlations_match_the_definitions(
            cols in prop::collection::vec((0u8..6, 0u8..5, 0u32..3), 0..40)
        ) {
            let x: Vec<f64> = cols.iter().map(|c| f64::from(c.0) / 4.0).collect();
            let y: Vec<f64> = cols.iter().map(|c| f64::from(c.1)).collect();
            let w: Vec<u32> = cols.iter().map(|c| c.2).collect();
            let paired = Paired::new(&x, &y);
            let (ex, ey) = (expand(&x, &w), expand(&y, &w));
            let (counts, ranks) = paired.pair_counts(&w);
            let (want, agree) = naive(&ex, &ey);
            prop_assert_eq!(counts, want);
            prop_assert_eq!(counts.concordant(), agree);
            let weighted = paired.correlations_weighted(&w);
            let expanded = Paired::new(&ex, &ey).correlations();
            prop_assert_eq!(weighted.kendall_tau_b, expanded.kendall_tau_b);
            prop_assert_eq!(weighted.pairwise_accuracy, expanded.pairwise_accuracy);
            prop_assert_eq!(ranks.n, ex.len() as u64);
            for (a, b) in [(weighted.spearman, expanded.spearman), (weighted.pearson, expanded.pearson)] {
                match (a, b) {
                    (Ok(a), Ok(b)) => prop_assert!((a - b).abs() < 1e-12),
                    (a, b) => prop_assert_eq!(a, b),
                }
            }
            if let Ok(r) = expanded.pearson {
                if ex.len() > 2 {
                    prop_assert!((r - naive_pearson(&ex, &ey)).abs() < 1e-12);
                }
            }
        }
    }
}
