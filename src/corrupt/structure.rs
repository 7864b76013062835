//! The corruptions of a plan's structure, which need no language model:
//! reorder, drop, duplicate, insert and truncate.

use super::draw::Draws;
use super::{Changed, Unchanged};
use crate::dataset::Edit;

/// Two steps whose texts differ trade places.
pub fn reorder(plan: &[String], draws: &mut Draws) -> Result<Changed, Unchanged> {
    let pairs: Vec<(usize, usize)> = (0..plan.len())
        .flat_map(|i| (i + 1..plan.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| plan[i] != plan[j])
        .collect();
    let &(i, j) = draws.pick(&pairs).ok_or(Unchanged::NoDistinctSteps)?;
    let mut steps = plan.to_vec();
    steps.swap(i, j);
    let edits = vec![replace(i, plan, &plan[j]), replace(j, plan, &plan[i])];
    Ok(Changed::new(steps, edits))
}

/// One step is removed.
pub fn drop(plan: &[String], draws: &mut Draws) -> Result<Changed, Unchanged> {
    if plan.len() < 2 {
        return Err(Unchanged::TooShort { needed: 2 });
    }
    let k = draws.below(plan.len());
    let mut steps = plan.to_vec();
    steps.remove(k);
    Ok(Changed::new(steps, vec![remove(k, plan)]))
}

/// One step is repeated right after itself.
pub fn duplicate(plan: &[String], draws: &mut Draws) -> Result<Changed, Unchanged> {
    if plan.is_empty() {
        return Err(Unchanged::TooShort { needed: 1 });
    }
    let k = draws.below(plan.len());
    let mut steps = plan.to_vec();
    steps.insert(k + 1, plan[k].clone());
    Ok(Changed::new(steps, vec![add(k + 1, &plan[k])]))
}

/// A step of another task's plan is put at a random place. The step is
/// drawn from `pool`, every step of every plan with the index of its owner,
/// again (a bounded number of times) while it belongs to an owner that
/// `other` refuses or to this plan.
pub fn insert(
    plan: &[String],
    pool: &[(usize, &str)],
    other: impl Fn(usize) -> bool,
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    const TRIES: usize = 64;
    let step = (0..TRIES)
        .filter_map(|_| draws.pick(pool))
        .find(|(owner, s)| other(*owner) && !plan.iter().any(|p| p == s))
        .map(|(_, s)| *s)
        .ok_or(Unchanged::NoOtherStep)?;
    let at = draws.below(plan.len() + 1);
    let mut steps = plan.to_vec();
    steps.insert(at, step.to_string());
    Ok(Changed::new(steps, vec![add(at, step)]))
}

/// The plan stops after half its steps (rounded down): the rest are removed.
pub fn truncate(plan: &[String]) -> Result<Changed, Unchanged> {
    if plan.len() < 2 {
        return Err(Unchanged::TooShort { needed: 2 });
    }
    let keep = plan.len() / 2;
    let edits = (keep..plan.len()).map(|k| remove(k, plan)).collect();
    Ok(Changed::new(plan[..keep].to_vec(), edits))
}

/// Step `k` of `plan` becomes `to`.
pub fn replace(k: usize, plan: &[String], to: &str) -> Edit {
    Edit {
        step: k,
        from: Some(plan[k].clone()),
        to: Some(to.to_string()),
    }
}

fn remove(k: usize, plan: &[String]) -> Edit {
    Edit {
        step: k,
        from: Some(plan[k].clone()),
        to: None,
    }
}

fn add(k: usize, step: &str) -> Edit {
    Edit {
        step: k,
        from: None,
        to: Some(step.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::corrupt::apply_edits;

    fn plan(steps: &[&str]) -> Vec<String> {
        steps.iter().map(|s| s.to_string()).collect()
    }

    /// The edits of `changed` turn `plan` into its steps.
    fn consistent(plan: &[String], changed: &Changed) {
        assert_eq!(
            apply_edits(plan, &changed.edits).as_deref(),
            Ok(changed.steps.as_slice())
        );
    }

    #[test]
    fn reorder_swaps_two_different_steps_only() {
        let p = plan(&["A.", "A.", "B."]);
        for seed in 0..20 {
            let c = reorder(&p, &mut Draws::new(seed, "i", "reorder"))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_ne!(c.steps, p);
            consistent(&p, &c);
            assert_eq!(c.edits.len(), 2);
        }
        let same = plan(&["A.", "A."]);
        assert_eq!(
            reorder(&same, &mut Draws::new(0, "i", "reorder")).map(|_| ()),
            Err(Unchanged::NoDistinctSteps)
        );
    }

    #[test]
    fn drop_duplicate_insert_and_truncate_record_their_edits() {
        let p = plan(&["A.", "B.", "C.", "D.", "E."]);
        let mut d = Draws::new(5, "i", "k");
        let dropped = drop(&p, &mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(dropped.steps.len(), 4);
        consistent(&p, &dropped);
        let doubled = duplicate(&p, &mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(doubled.steps.len(), 6);
        let k = doubled.edits[0].step;
        assert_eq!(doubled.steps[k], doubled.steps[k - 1]);
        consistent(&p, &doubled);
        let pool = [(1, "A."), (1, "Z."), (0, "Y.")];
        let inserted =
            insert(&p, &pool, |owner| owner == 1, &mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(inserted.edits[0].to.as_deref(), Some("Z."));
        consistent(&p, &inserted);
        let cut = truncate(&p).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cut.steps, plan(&["A.", "B."]));
        assert_eq!(
            cut.edits.iter().map(|e| e.step).collect::<Vec<_>>(),
            [2, 3, 4]
        );
        consistent(&p, &cut);
    }

    #[test]
    fn plans_too_short_or_without_another_step_are_not_changed() {
        let one = plan(&["A."]);
        let mut d = Draws::new(0, "i", "k");
        assert_eq!(
            drop(&one, &mut d).map(|_| ()),
            Err(Unchanged::TooShort { needed: 2 })
        );
        assert_eq!(
            truncate(&one).map(|_| ()),
            Err(Unchanged::TooShort { needed: 2 })
        );
        assert_eq!(
            duplicate(&[], &mut d).map(|_| ()),
            Err(Unchanged::TooShort { needed: 1 })
        );
        let pool = [(1, "A."), (0, "B.")];
        let from_1 = |owner| owner == 1;
        assert_eq!(
            insert(&one, &pool, from_1, &mut d).map(|_| ()),
            Err(Unchanged::NoOtherStep)
        );
        assert_eq!(
            insert(&one, &[], from_1, &mut d).map(|_| ()),
            Err(Unchanged::NoOtherStep)
        );
    }
}
