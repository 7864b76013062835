//! Taking back step edits: each edit, insertion, deletion or move of a
//! plan or ground-truth step keeps the list as it was before, so `u` puts
//! it back, one edit at a time, on the source it was made on.

use std::collections::VecDeque;

use crate::workbench::panes::steps::{StepList, Steps};
use crate::workbench::session::{GroundTruthSource, PlanSource};

/// How many step edits `u` can take back on one source; the oldest goes
/// when one more is made.
pub const UNDO_LEVELS: usize = 200;

/// A step list as it was before an edit, with where its steps came from.
#[derive(Debug, Clone, PartialEq)]
pub struct StepsBefore {
    /// Which list was edited.
    pub list: StepList,
    /// Its steps and selection.
    pub steps: Steps,
    /// The plan's origin then (an edit of the plan keeps it; a restored
    /// one must say where its steps came from).
    pub plan_source: PlanSource,
    /// The ground truth's origin then (an edit makes it `typed`).
    pub ground_truth_source: GroundTruthSource,
}

/// The edits of one source that can be taken back, newest last.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepUndo {
    done: VecDeque<StepsBefore>,
}

impl StepUndo {
    /// Keeps `before` as the state the newest edit changed, forgetting the
    /// oldest beyond [`UNDO_LEVELS`].
    pub fn push(&mut self, before: StepsBefore) {
        if self.done.len() == UNDO_LEVELS {
            self.done.pop_front();
        }
        self.done.push_back(before);
    }

    /// The state before the newest edit, taken off the stack.
    pub fn pop(&mut self) -> Option<StepsBefore> {
        self.done.pop_back()
    }

    /// How many edits can be taken back.
    pub fn len(&self) -> usize {
        self.done.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.done.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn before(n: usize) -> StepsBefore {
        StepsBefore {
            list: StepList::Plan,
            steps: Steps::new(vec![format!("step {n}")]),
            plan_source: PlanSource::None,
            ground_truth_source: GroundTruthSource::Typed,
        }
    }

    #[test]
    fn the_newest_comes_back_first_and_the_oldest_goes_past_the_limit() {
        let mut undo = StepUndo::default();
        for n in 0..UNDO_LEVELS + 5 {
            undo.push(before(n));
        }
        assert_eq!(undo.len(), UNDO_LEVELS);
        assert_eq!(undo.pop(), Some(before(UNDO_LEVELS + 4)));
        let mut last = None;
        while let Some(b) = undo.pop() {
            last = Some(b);
        }
        assert_eq!(last, Some(before(5)), "the five oldest were forgotten");
        assert!(undo.is_empty());
    }
}
