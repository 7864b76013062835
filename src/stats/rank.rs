//! Ranks of a column: dense ranks (for counting ties and discordances) and
//! the average ranks of `scipy.stats.rankdata`.

use std::cmp::Ordering;

/// The dense ranks of `values`: equal values (by `==`, so `-0.0 == 0.0`)
/// share a rank, ranks run from 0 upwards in ascending order of value.
/// Returns the ranks and how many distinct values there are. NaN is not
/// expected (values come from JSON numbers) and sorts last in its own group.
pub fn dense_ranks(values: &[f64]) -> (Vec<u32>, usize) {
    let mut order: Vec<u32> = (0..values.len() as u32).collect();
    order.sort_unstable_by(|&a, &b| cmp(values[a as usize], values[b as usize]));
    let mut ranks = vec![0u32; values.len()];
    let mut rank = 0u32;
    for (k, &i) in order.iter().enumerate() {
        if k > 0 && values[order[k - 1] as usize] != values[i as usize] {
            rank += 1;
        }
        ranks[i as usize] = rank;
    }
    let distinct = if values.is_empty() {
        0
    } else {
        rank as usize + 1
    };
    (ranks, distinct)
}

/// The dense ranks of whole-number keys below `bound`, found by counting
/// (O(n + bound)) instead of sorting.
pub fn dense_ranks_of_keys(keys: &[u32], bound: usize) -> (Vec<u32>, usize) {
    let mut rank_of = vec![0u32; bound];
    for &k in keys {
        rank_of[k as usize] = 1;
    }
    let mut distinct = 0u32;
    for slot in &mut rank_of {
        let present = *slot;
        *slot = distinct;
        distinct += present;
    }
    (
        keys.iter().map(|&k| rank_of[k as usize]).collect(),
        distinct as usize,
    )
}

/// The average ranks (1-based, ties sharing the mean of their positions),
/// as `scipy.stats.rankdata(values, method="average")`.
pub fn average_ranks(values: &[f64]) -> Vec<f64> {
    let (dense, distinct) = dense_ranks(values);
    let mut counts = vec![0u64; distinct];
    for &r in &dense {
        counts[r as usize] += 1;
    }
    let mut start = 0u64;
    let rank_of: Vec<f64> = counts
        .iter()
        .map(|&c| {
            let rank = start as f64 + (c as f64 + 1.0) / 2.0;
            start += c;
            rank
        })
        .collect();
    dense.iter().map(|&r| rank_of[r as usize]).collect()
}

/// Ascending order of two values, with `-0.0` and `0.0` side by side and
/// NaN last.
fn cmp(a: f64, b: f64) -> Ordering {
    a.partial_cmp(&b)
        .unwrap_or_else(|| a.is_nan().cmp(&b.is_nan()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_share_a_dense_rank_and_the_mean_position() {
        let values = [3.0, 1.0, 3.0, -0.0, 0.0, 7.5];
        let (dense, distinct) = dense_ranks(&values);
        assert_eq!(dense, [2, 1, 2, 0, 0, 3]);
        assert_eq!(distinct, 4);
        assert_eq!(average_ranks(&values), [4.5, 3.0, 4.5, 1.5, 1.5, 6.0]);
        assert_eq!(dense_ranks(&[]), (vec![], 0));
        assert_eq!(
            dense_ranks_of_keys(&[9, 3, 9, 0], 10),
            (vec![2, 1, 2, 0], 3)
        );
    }
}
