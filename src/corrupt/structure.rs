//! The corruptions of a plan's structure, which need no language model:
//! reorder, drop, duplicate, insert and truncate.

use std::collections::HashSet;

use super::draw::Draws;
use super::{Changed, Unchanged};
use crate::dataset::Edit;

/// Two steps whose texts differ, not both navigation-only (`navigation[k]`:
/// step `k` only moves the agent), trade places; the record says whether
/// they were neighbours.
pub fn reorder(
    plan: &[String],
    navigation: &[bool],
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    let moving = |k: usize| navigation.get(k).copied().unwrap_or(false);
    let pairs: Vec<(usize, usize)> = (0..plan.len())
        .flat_map(|i| (i + 1..plan.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| plan[i] != plan[j] && !(moving(i) && moving(j)))
        .collect();
    let &(i, j) = draws.pick(&pairs).ok_or(Unchanged::NoDistinctSteps)?;
    let mut steps = plan.to_vec();
    steps.swap(i, j);
    let edits = vec![replace(i, plan, &plan[j]), replace(j, plan, &plan[i])];
    Ok(Changed {
        adjacent: Some(j == i + 1),
        ..Changed::new(steps, edits)
    })
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

/// A step that does more than move the agent (`navigation[k]` false) is
/// repeated elsewhere in the plan: never right before or after itself nor
/// beside another copy of its text, where a reader would take it for a typo.
pub fn duplicate(
    plan: &[String],
    navigation: &[bool],
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    if plan.len() < 2 {
        return Err(Unchanged::TooShort { needed: 2 });
    }
    let places: Vec<(usize, usize)> = (0..plan.len())
        .filter(|&k| !navigation.get(k).copied().unwrap_or(false))
        .flat_map(|k| (0..=plan.len()).map(move |at| (k, at)))
        .filter(|&(k, at)| {
            let beside = |j: Option<usize>| j.and_then(|j| plan.get(j)) == Some(&plan[k]);
            !beside(at.checked_sub(1)) && !beside(Some(at))
        })
        .collect();
    let &(k, at) = draws.pick(&places).ok_or(Unchanged::NoActionStep)?;
    let mut steps = plan.to_vec();
    steps.insert(at, plan[k].clone());
    Ok(Changed::new(steps, vec![add(at, &plan[k])]))
}

/// A step of another task's plan, written in this plan's style, is put at a
/// random place. The step is drawn from `pool`, every step of every plan
/// with the index of its owner, again (a bounded number of times) while its
/// owner is one that `other` refuses, or it reads as a step of such an
/// owner or of this plan.
pub fn insert(
    plan: &[String],
    pool: &[(usize, &str)],
    other: impl Fn(usize) -> bool,
    draws: &mut Draws,
) -> Result<Changed, Unchanged> {
    const TRIES: usize = 64;
    let style = Style::of(plan);
    // The steps of this plan's own trial or goal, as this plan would write
    // them: a step of another plan that reads the same is no foreign step.
    let near: HashSet<String> = pool
        .iter()
        .filter(|(owner, _)| !other(*owner))
        .map(|(_, s)| style.apply(s))
        .chain(plan.iter().map(|s| style.apply(s)))
        .collect();
    let step = (0..TRIES)
        .filter_map(|_| draws.pick(pool))
        .filter(|(owner, _)| other(*owner))
        .map(|(_, s)| style.apply(s))
        .find(|s| !s.is_empty() && !near.contains(s) && !plan.iter().any(|p| p == s))
        .ok_or(Unchanged::NoOtherStep)?;
    let at = draws.below(plan.len() + 1);
    let mut steps = plan.to_vec();
    steps.insert(at, step.clone());
    Ok(Changed::new(steps, vec![add(at, &step)]))
}

/// How a plan writes its steps, so that a step taken from another plan
/// can be written the same way: bold headings (`**Pick up the mug**: …`),
/// and a full stop at the end. Each holds when most steps have it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Style {
    headings: bool,
    full_stop: bool,
}

impl Style {
    fn of(plan: &[String]) -> Style {
        let most = |f: &dyn Fn(&str) -> bool| 2 * plan.iter().filter(|s| f(s)).count() > plan.len();
        Style {
            headings: most(&|s| heading(s).is_some()),
            full_stop: most(&|s| s.trim_end().ends_with('.')),
        }
    }

    /// `step` written in this style: its list marker or number removed, its
    /// bold heading kept alone (a plain plan) or made (a plan of headings),
    /// the full stop added or removed.
    fn apply(self, step: &str) -> String {
        let bare = unlisted(step.trim());
        let sentence = match heading(bare) {
            Some(h) => h.to_string(),
            None => bare.replace("**", "").replace("__", ""),
        };
        let sentence = sentence.trim().trim_end_matches(['.', ':']).trim_end();
        if sentence.is_empty() {
            return String::new();
        }
        match (self.headings, self.full_stop) {
            (true, _) => format!("**{sentence}**"),
            (false, true) => format!("{sentence}."),
            (false, false) => sentence.to_string(),
        }
    }
}

/// The bold heading a step opens with (`**Pick up the mug**: …` →
/// `Pick up the mug`).
fn heading(step: &str) -> Option<&str> {
    let rest = unlisted(step.trim()).strip_prefix("**")?;
    let (inside, _) = rest.split_once("**")?;
    (!inside.trim().is_empty()).then_some(inside.trim())
}

/// `step` without a leading list marker or number (`- `, `* `, `3. `,
/// `3) `, `Step 3: `).
fn unlisted(step: &str) -> &str {
    let s = step.trim_start();
    if let Some(rest) = s.strip_prefix("- ").or_else(|| s.strip_prefix("* ")) {
        return rest.trim_start();
    }
    let worded = s
        .get(..5)
        .filter(|w| w.eq_ignore_ascii_case("step "))
        .map(|_| &s[5..]);
    let body = worded.unwrap_or(s);
    let digits = body.len() - body.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    if digits == 0 {
        return s;
    }
    let after = &body[digits..];
    match after.chars().next() {
        Some('.' | ')' | ':') => after[1..].trim_start(),
        _ => s,
    }
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
            let c = reorder(&p, &[], &mut Draws::new(seed, "i", "reorder"))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_ne!(c.steps, p);
            consistent(&p, &c);
            assert_eq!(c.edits.len(), 2);
        }
        let same = plan(&["A.", "A."]);
        assert_eq!(
            reorder(&same, &[], &mut Draws::new(0, "i", "reorder")).map(|_| ()),
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
        let doubled = duplicate(&p, &[], &mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(doubled.steps.len(), 6);
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
    fn duplicate_repeats_an_action_step_away_from_itself() {
        let p = plan(&[
            "Walk to the sink.",
            "Pick up the mug.",
            "Turn left.",
            "Wash the mug.",
        ]);
        let navigation = [true, false, true, false];
        for seed in 0..40 {
            let c = duplicate(&p, &navigation, &mut Draws::new(seed, "i", "duplicate"))
                .unwrap_or_else(|e| panic!("{e}"));
            consistent(&p, &c);
            let e = &c.edits[0];
            let copy = e.to.as_deref().unwrap_or_default();
            let k = p.iter().position(|s| s == copy).unwrap_or(usize::MAX);
            assert!(!navigation[k], "seed {seed}: {copy}");
            assert!(e.step != k && e.step != k + 1, "seed {seed}: {e:?}");
        }
        assert_eq!(
            duplicate(&p[..1], &[true], &mut Draws::new(0, "i", "d")).map(|_| ()),
            Err(Unchanged::TooShort { needed: 2 })
        );
        let walking = plan(&["Walk to the sink.", "Turn left."]);
        assert_eq!(
            duplicate(&walking, &[true, true], &mut Draws::new(0, "i", "d")).map(|_| ()),
            Err(Unchanged::NoActionStep)
        );
    }

    #[test]
    fn reorder_never_swaps_two_navigation_steps_and_says_if_they_were_neighbours() {
        let p = plan(&[
            "Walk to the sink.",
            "Turn left.",
            "Pick up the mug.",
            "Go to the bed.",
        ]);
        let navigation = [true, true, false, true];
        let mut adjacent = [0, 0];
        for seed in 0..60 {
            let c = reorder(&p, &navigation, &mut Draws::new(seed, "i", "reorder"))
                .unwrap_or_else(|e| panic!("{e}"));
            let (i, j) = (c.edits[0].step, c.edits[1].step);
            assert!(i == 2 || j == 2, "seed {seed}: {i} {j}");
            assert_eq!(c.adjacent, Some(j == i + 1));
            adjacent[usize::from(j == i + 1)] += 1;
        }
        assert!(adjacent[0] > 0 && adjacent[1] > 0, "{adjacent:?}");
    }

    #[test]
    fn an_inserted_step_is_written_in_the_plan_style() {
        let plain = Style::of(&plan(&["Walk to the sink.", "Wash the mug."]));
        let headed = Style::of(&plan(&[
            "**Walk to the sink**: go there.",
            "**Wash it**: well.",
        ]));
        let bare = Style::of(&plan(&["walk to the sink", "wash the mug"]));
        let md = "**Identify the wine bottle's position**: The wine bottle is on the counter.";
        assert_eq!(plain.apply(md), "Identify the wine bottle's position.");
        assert_eq!(plain.apply("3. Open the fridge"), "Open the fridge.");
        assert_eq!(plain.apply("- Open the fridge."), "Open the fridge.");
        assert_eq!(plain.apply("Step 2: Open the fridge."), "Open the fridge.");
        assert_eq!(headed.apply("Open the fridge."), "**Open the fridge**");
        assert_eq!(bare.apply("Open the fridge."), "Open the fridge");
        assert_eq!(plain.apply("**  **"), "");
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
            duplicate(&one, &[], &mut d).map(|_| ()),
            Err(Unchanged::TooShort { needed: 2 })
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
