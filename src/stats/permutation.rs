//! Permutation tests. The paired one: is the difference between two
//! metrics' Kendall's tau-b with the human scores more than chance? The
//! two-sample one ([`mean_difference`]): is the difference between the means
//! of two groups (two runs' samples) more than their spread?
//!
//! Over the items that have both metrics, each metric's values are replaced
//! by their average ranks (the two metrics have different scales; tau-b only
//! sees the order). Under the null hypothesis the two metrics are
//! exchangeable item by item, so each permutation swaps the two ranks of
//! every item with probability ½ (one bit of stream `PERMUTATION + p`) and
//! recomputes the difference. The p-value is two-sided,
//! `(1 + #{|d*| ≥ |d|}) / (1 + permutations)`.

use rand_chacha::rand_core::RngCore;
use rayon::prelude::*;

use super::correlation::{Paired, Ranked};
use super::rank::{average_ranks, dense_ranks, dense_ranks_of_keys};
use super::rng::{below, stream, PERMUTATION};
use super::summary::mean;
use super::Undefined;

/// The outcome of the test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PermutationTest {
    /// tau-b of the first metric minus tau-b of the second, on the shared items.
    pub difference: f64,
    /// The two-sided p-value.
    pub p_value: f64,
    /// The items both metrics score.
    pub n: usize,
    /// Permutations whose difference was defined (a swap can make a column
    /// constant on very small inputs; those are left out).
    pub permutations: usize,
}

/// Tests tau-b(`a`, `human`) against tau-b(`b`, `human`) with `permutations`
/// random swaps drawn from `seed`. The three columns are paired item by item.
pub fn tau_b_difference(
    a: &[f64],
    b: &[f64],
    human: &[f64],
    permutations: usize,
    seed: u64,
) -> Result<PermutationTest, Undefined> {
    let n = a.len().min(b.len()).min(human.len());
    let (a, b, human) = (&a[..n], &b[..n], &human[..n]);
    let all = vec![1u32; n];
    let observed =
        Paired::new(a, human).kendall_tau_b(&all)? - Paired::new(b, human).kendall_tau_b(&all)?;
    // Average ranks are halves: twice a rank is a whole number up to 2n, so
    // each permuted column is ranked by counting, without a sort.
    let twice =
        |v: &[f64]| -> Vec<u32> { average_ranks(v).iter().map(|r| (2.0 * r) as u32).collect() };
    let (ka, kb) = (twice(a), twice(b));
    let (h_rank, h_distinct) = dense_ranks(human);
    let tau = |keys: Vec<u32>| {
        let (ranks, distinct) = dense_ranks_of_keys(&keys, 2 * n + 1);
        let x = Ranked {
            values: keys.iter().map(|&k| f64::from(k)).collect(),
            ranks,
            distinct,
        };
        let y = Ranked {
            values: human.to_vec(),
            ranks: h_rank.clone(),
            distinct: h_distinct,
        };
        Paired::from_ranks(x, y).kendall_tau_b(&all).ok()
    };
    let tolerance = 1e-12;
    let extreme: Vec<bool> = (0..permutations)
        .into_par_iter()
        .filter_map(|p| {
            let mut rng = stream(seed, PERMUTATION + p as u64);
            let mut x = Vec::with_capacity(n);
            let mut y = Vec::with_capacity(n);
            let mut bits = 0u64;
            for i in 0..n {
                if i % 64 == 0 {
                    bits = rng.next_u64();
                }
                let swap = bits & 1 == 1;
                bits >>= 1;
                let (first, second) = if swap { (kb[i], ka[i]) } else { (ka[i], kb[i]) };
                x.push(first);
                y.push(second);
            }
            let d = tau(x)? - tau(y)?;
            Some(d.abs() >= observed.abs() - tolerance)
        })
        .collect();
    if extreme.is_empty() {
        return Err(Undefined::NoResample);
    }
    let hits = extreme.iter().filter(|&&e| e).count();
    Ok(PermutationTest {
        difference: observed,
        p_value: (1 + hits) as f64 / (1 + extreme.len()) as f64,
        n,
        permutations: extreme.len(),
    })
}

/// Tests the mean of `b` minus the mean of `a` against chance: under the
/// null hypothesis the values are exchangeable between the groups, so each
/// of `permutations` shuffles (Fisher–Yates, stream `PERMUTATION + p` of
/// `seed`) deals the pooled values out again and recomputes the difference.
/// Two-sided p-value as [`tau_b_difference`]; `n` is the pooled count.
/// Undefined unless each group has two values or more.
pub fn mean_difference(
    a: &[f64],
    b: &[f64],
    permutations: usize,
    seed: u64,
) -> Result<PermutationTest, Undefined> {
    if a.len() < 2 || b.len() < 2 {
        return Err(Undefined::TooFewItems);
    }
    if permutations == 0 {
        return Err(Undefined::NoResample);
    }
    let observed = mean(b)? - mean(a)?;
    let pooled: Vec<f64> = a.iter().chain(b).copied().collect();
    let tolerance = 1e-12 * (1.0 + observed.abs());
    let hits = (0..permutations)
        .into_par_iter()
        .filter(|&p| {
            let mut rng = stream(seed, PERMUTATION + p as u64);
            let mut dealt = pooled.clone();
            for i in (1..dealt.len()).rev() {
                dealt.swap(i, below(&mut rng, i as u64 + 1) as usize);
            }
            let (x, y) = dealt.split_at(a.len());
            let d = mean(y).unwrap_or(0.0) - mean(x).unwrap_or(0.0);
            d.abs() >= observed.abs() - tolerance
        })
        .count();
    Ok(PermutationTest {
        difference: observed,
        p_value: (1 + hits) as f64 / (1 + permutations) as f64,
        n: pooled.len(),
        permutations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_sample_means_apart_beyond_their_spread_are_significant_and_within_it_are_not() {
        let low = [0.40, 0.41, 0.39, 0.40, 0.42];
        let high = [0.60, 0.61, 0.59, 0.62, 0.60];
        let apart = mean_difference(&low, &high, 2000, 0).unwrap_or_else(|e| panic!("{e}"));
        assert!((apart.difference - 0.2).abs() < 1e-9, "{apart:?}");
        // 5 + 5 values fully apart: only 2 of the 252 deals are as extreme.
        assert!(apart.p_value < 0.02, "{apart:?}");
        assert_eq!(apart.n, 10);
        let noisy = [0.30, 0.70, 0.45, 0.55, 0.50];
        let close = mean_difference(&noisy, &[0.52, 0.48, 0.60, 0.40, 0.51], 2000, 0)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(close.p_value > 0.5, "{close:?}");
        assert_eq!(
            close,
            mean_difference(&noisy, &[0.52, 0.48, 0.60, 0.40, 0.51], 2000, 0)
                .unwrap_or_else(|e| panic!("{e}"))
        );
        assert_eq!(
            mean_difference(&[0.5], &high, 100, 0),
            Err(Undefined::TooFewItems)
        );
    }

    #[test]
    fn identical_metrics_are_never_significant_and_opposite_ones_are() {
        let human: Vec<f64> = (0..60).map(|i| f64::from(i % 5)).collect();
        let good: Vec<f64> = (0..60)
            .map(|i| f64::from(i % 5) + f64::from(i) * 1e-3)
            .collect();
        let same = tau_b_difference(&good, &good, &human, 200, 3).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(same.difference, 0.0);
        assert_eq!(same.p_value, 1.0);
        let bad: Vec<f64> = good.iter().map(|v| -v).collect();
        let apart = tau_b_difference(&good, &bad, &human, 200, 3).unwrap_or_else(|e| panic!("{e}"));
        assert!(apart.difference > 1.5);
        assert!(apart.p_value < 0.01, "{apart:?}");
        assert_eq!(
            apart,
            tau_b_difference(&good, &bad, &human, 200, 3).unwrap_or_else(|e| panic!("{e}"))
        );
        assert_eq!(
            tau_b_difference(&[1.0], &[2.0], &[3.0], 10, 0),
            Err(Undefined::TooFewItems)
        );
    }
}
