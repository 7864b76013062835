//! The order an annotator sees the items in: shuffled with a generator
//! seeded by the annotator's name, so each person has an order of their own
//! that is the same every time they open the file; items derived from one
//! source are kept apart, so that a plan and its altered copy are not judged
//! one after the other.

use std::collections::BTreeMap;

use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};

use crate::dataset::Pair;

/// What an annotator judges at one position: one item, or two side by side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unit {
    /// The item at this index of the items file.
    Single(usize),
    /// Two items of one task, as shown: (left, right).
    Pair(usize, usize),
}

/// The generator for `annotator` and `purpose`: ChaCha8, whose stream is
/// specified, seeded with the SHA-256 of both, so the order is the same on
/// every machine and version.
fn generator(annotator: &str, purpose: &str) -> ChaCha8Rng {
    let seed: [u8; 32] = Sha256::digest(format!("{purpose}\0{annotator}").as_bytes()).into();
    ChaCha8Rng::from_seed(seed)
}

/// A uniform index below `n` (`n > 0`), without modulo bias.
fn below(rng: &mut ChaCha8Rng, n: usize) -> usize {
    let n = n as u64;
    let zone = u64::MAX - u64::MAX % n;
    loop {
        let x = rng.next_u64();
        if x < zone {
            return (x % n) as usize;
        }
    }
}

/// Fisher–Yates, from the last element down.
fn shuffle<T>(rng: &mut ChaCha8Rng, items: &mut [T]) {
    for i in (1..items.len()).rev() {
        items.swap(i, below(rng, i + 1));
    }
}

/// The family of an item: its `group` (a blind copy), its `source`, or itself.
fn family(item: &Pair) -> &str {
    item.family()
}

/// Moves items so that no two neighbours share a family, where a place for
/// them exists: each clash at `i` is swapped with the first position `j`
/// where both land between neighbours of other families.
fn spread<T, K: PartialEq>(order: &mut [T], family: impl Fn(&T) -> K) {
    let clashes = |order: &[T], at: usize, f: K| {
        (at > 0 && family(&order[at - 1]) == f)
            || (at + 1 < order.len() && family(&order[at + 1]) == f)
    };
    for i in 1..order.len() {
        if family(&order[i]) != family(&order[i - 1]) {
            continue;
        }
        let found = (0..order.len()).find(|&j| {
            if j.abs_diff(i) <= 1 {
                return false;
            }
            order.swap(i, j);
            let fine =
                !clashes(order, i, family(&order[i])) && !clashes(order, j, family(&order[j]));
            order.swap(i, j);
            fine
        });
        if let Some(j) = found {
            order.swap(i, j);
        }
    }
}

/// The order of single items for `annotator`.
pub fn single_units(items: &[Pair], annotator: &str) -> Vec<Unit> {
    let mut rng = generator(annotator, "single");
    let mut order: Vec<usize> = (0..items.len()).collect();
    shuffle(&mut rng, &mut order);
    spread(&mut order, |&i| family(&items[i]));
    order.into_iter().map(Unit::Single).collect()
}

/// The pairs for `annotator`: the items of one task (same `task` text, else
/// the same family) in a shuffled chain, each compared with the next, the
/// sides drawn at random, and the pairs of all tasks shuffled.
pub fn pairwise_units(items: &[Pair], annotator: &str) -> Vec<Unit> {
    let mut rng = generator(annotator, "pairwise");
    let mut tasks: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, item) in items.iter().enumerate() {
        let key = item.task.as_deref().unwrap_or_else(|| family(item));
        tasks.entry(key).or_default().push(i);
    }
    let mut units = Vec::new();
    for members in tasks.values_mut() {
        shuffle(&mut rng, members);
        for two in members.windows(2) {
            let unit = if rng.next_u32() & 1 == 0 {
                Unit::Pair(two[0], two[1])
            } else {
                Unit::Pair(two[1], two[0])
            };
            units.push(unit);
        }
    }
    shuffle(&mut rng, &mut units);
    let task_of = |u: &Unit| {
        let (Unit::Pair(l, _) | Unit::Single(l)) = *u;
        items[l].task.as_deref().unwrap_or(family(&items[l]))
    };
    spread(&mut units, task_of);
    units
}

#[cfg(test)]
mod tests {
    use super::*;

    fn families(n: usize, size: usize) -> Vec<Pair> {
        let mut items = Vec::new();
        for f in 0..n {
            let mut original = Pair::new(format!("t{f}"), vec![], vec!["A.".into()]);
            original.task = Some(format!("task {f}"));
            for k in 0..size - 1 {
                let mut copy = original.clone();
                copy.id = format!("t{f}~{k}");
                copy.source = Some(original.id.clone());
                items.push(copy);
            }
            items.push(original);
        }
        items
    }

    #[test]
    fn each_annotator_has_a_stable_order_of_their_own_with_families_apart() {
        let items = families(8, 5);
        let ana = single_units(&items, "ana");
        assert_eq!(ana, single_units(&items, "ana"));
        assert_ne!(ana, single_units(&items, "bo"));
        for name in ["ana", "bo", "chen", "d", "eve"] {
            let order = single_units(&items, name);
            let mut seen: Vec<usize> = order
                .iter()
                .map(|u| match *u {
                    Unit::Single(i) | Unit::Pair(i, _) => i,
                })
                .collect();
            let idx = seen.clone();
            for w in idx.windows(2) {
                assert_ne!(family(&items[w[0]]), family(&items[w[1]]), "{name}: {w:?}");
            }
            seen.sort_unstable();
            assert_eq!(seen, (0..items.len()).collect::<Vec<_>>());
        }
    }

    #[test]
    fn the_first_draws_of_the_stream_are_fixed() {
        // The stream is ChaCha8's: the same on every machine and version.
        let mut rng = generator("ana", "single");
        let draws: Vec<usize> = (0..6).map(|_| below(&mut rng, 100)).collect();
        let mut again = generator("ana", "single");
        assert_eq!(
            draws,
            (0..6).map(|_| below(&mut again, 100)).collect::<Vec<_>>()
        );
        let items = families(3, 2);
        let order: Vec<String> = single_units(&items, "ana")
            .into_iter()
            .map(|u| match u {
                Unit::Single(i) | Unit::Pair(i, _) => items[i].id.clone(),
            })
            .collect();
        insta::assert_debug_snapshot!(order);
    }

    #[test]
    fn pairs_join_plans_of_one_task_with_both_sides_used() {
        let items = families(6, 4);
        let units = pairwise_units(&items, "ana");
        assert_eq!(units.len(), 6 * 3);
        let mut lefts_original = 0;
        for u in &units {
            let Unit::Pair(l, r) = *u else {
                panic!("single")
            };
            assert_eq!(items[l].task, items[r].task);
            assert_ne!(l, r);
            lefts_original += usize::from(items[l].source.is_none());
        }
        assert!(lefts_original > 0 && lefts_original < 6, "{lefts_original}");
    }
}
