//! Holm's step-down correction of a family of p-values (Holm 1979): it
//! controls the family-wise error rate without assuming the tests are
//! independent, which the tests of one set of metrics against the same
//! human scores are not.

use super::Estimate;

/// The Holm-adjusted p-values, in the order of `p`, over the family of the
/// defined ones (an undefined p-value stays undefined, for its reason, and
/// does not count in the family): with p_(1) ≤ … ≤ p_(m) the sorted values,
/// the adjusted p_(i) is the running maximum of (m − j + 1) · p_(j) over
/// j ≤ i, capped at 1. A hypothesis is rejected at a level α < 1 by Holm's
/// procedure exactly when its adjusted value is ≤ α.
pub fn holm(p: &[Estimate]) -> Vec<Estimate> {
    let mut order: Vec<(usize, f64)> = p
        .iter()
        .enumerate()
        .filter_map(|(i, e)| Some((i, *e.as_ref().ok()?)))
        .collect();
    order.sort_by(|a, b| a.1.total_cmp(&b.1));
    let m = order.len();
    let mut adjusted = p.to_vec();
    let mut running = 0.0f64;
    for (rank, &(i, value)) in order.iter().enumerate() {
        running = running.max(((m - rank) as f64 * value).min(1.0));
        adjusted[i] = Ok(running);
    }
    adjusted
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Undefined;
    use proptest::prelude::*;

    /// [`holm`] of defined values only.
    fn adjust(p: &[f64]) -> Vec<f64> {
        let defined: Vec<Estimate> = p.iter().map(|&v| Ok(v)).collect();
        holm(&defined)
            .into_iter()
            .map(|e| e.unwrap_or(f64::NAN))
            .collect()
    }

    /// Holm's procedure as he defined it: sort, and reject while
    /// p_(k) ≤ α / (m − k + 1) (multiplied out, so that the comparison at
    /// α equal to an adjusted value is exact); stop at the first that is not.
    fn rejected(p: &[f64], alpha: f64) -> Vec<bool> {
        let m = p.len();
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
        let mut out = vec![false; m];
        for (k, &i) in order.iter().enumerate() {
            if (m - k) as f64 * p[i] > alpha {
                break;
            }
            out[i] = true;
        }
        out
    }

    #[test]
    fn a_worked_family() {
        // Holm (1979)-style example, checked by hand: sorted 0.01, 0.02,
        // 0.03, 0.2 → 4·0.01, max(0.04, 3·0.02), max(0.06, 2·0.03), 0.2.
        let p = [0.03, 0.2, 0.01, 0.02];
        let adjusted = adjust(&p);
        let want = [0.06, 0.2, 0.04, 0.06];
        for (a, w) in adjusted.iter().zip(want) {
            assert!((a - w).abs() < 1e-15, "{adjusted:?}");
        }
        // Capped at 1, and a family of one is left alone.
        assert_eq!(adjust(&[0.6, 0.7]), vec![1.0, 1.0]);
        assert_eq!(adjust(&[0.3]), vec![0.3]);
        assert!(holm(&[]).is_empty());
        // An undefined p-value keeps its reason and is not in the family.
        let mixed = [Ok(0.01), Err(Undefined::FewerThanFourItems), Ok(0.04)];
        assert_eq!(
            holm(&mixed),
            vec![Ok(0.02), Err(Undefined::FewerThanFourItems), Ok(0.04)]
        );
    }

    proptest! {
        #[test]
        fn adjusted_values_reject_exactly_what_the_procedure_rejects(
            p in prop::collection::vec(0.0f64..=1.0, 1..12),
            levels in prop::collection::vec(0.0f64..1.0, 1..8),
        ) {
            let adjusted = adjust(&p);
            for (&a, &raw) in adjusted.iter().zip(&p) {
                prop_assert!(a >= raw && a <= 1.0);
            }
            // At every level below 1 (at 1 the cap rejects everything),
            // including the adjusted values themselves (where the decision
            // flips), the two agree.
            for alpha in levels.iter().chain(&adjusted).copied().filter(|&a| a < 1.0) {
                let want = rejected(&p, alpha);
                for i in 0..p.len() {
                    prop_assert_eq!(adjusted[i] <= alpha, want[i], "p {:?} alpha {}", p, alpha);
                }
            }
        }
    }
}
