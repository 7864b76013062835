//! Taking back edits one at a time: a bounded stack of the states before
//! each edit, newest last. A leaf module: the step lists keep their states
//! in it ([`crate::workbench::panes::steps::StepsBefore`]), so that `u`
//! puts a list back on the source it was edited on.

use std::collections::VecDeque;

/// How many edits `u` can take back on one source; the oldest goes when
/// one more is made.
pub const UNDO_LEVELS: usize = 200;

/// The states before the edits that can be taken back, newest last, at
/// most [`UNDO_LEVELS`].
#[derive(Debug, Clone, PartialEq)]
pub struct Undo<T> {
    done: VecDeque<T>,
}

impl<T> Default for Undo<T> {
    fn default() -> Self {
        Undo {
            done: VecDeque::new(),
        }
    }
}

impl<T> Undo<T> {
    /// Keeps `before` as the state the newest edit changed, forgetting the
    /// oldest beyond [`UNDO_LEVELS`].
    pub fn push(&mut self, before: T) {
        if self.done.len() == UNDO_LEVELS {
            self.done.pop_front();
        }
        self.done.push_back(before);
    }

    /// The state before the newest edit, taken off the stack.
    pub fn pop(&mut self) -> Option<T> {
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

    #[test]
    fn the_newest_comes_back_first_and_the_oldest_goes_past_the_limit() {
        let mut undo = Undo::default();
        for n in 0..UNDO_LEVELS + 5 {
            undo.push(n);
        }
        assert_eq!(undo.len(), UNDO_LEVELS);
        assert_eq!(undo.pop(), Some(UNDO_LEVELS + 4));
        let mut last = None;
        while let Some(b) = undo.pop() {
            last = Some(b);
        }
        assert_eq!(last, Some(5), "the five oldest were forgotten");
        assert!(undo.is_empty());
    }
}
