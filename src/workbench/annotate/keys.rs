//! The keys of the annotation screen, in one table: the screen dispatches
//! from it and the help overlay lists it, so the two cannot disagree.

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use crate::annotate::{Preference, StepLabelKind};

/// What a key does on the annotation screen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Rate the item with the digit pressed, save, and move on.
    Rate,
    /// Prefer one plan of the pair, save, and move on.
    Prefer(Preference),
    /// Put a label on the selected step (the same label again takes it off).
    Label(StepLabelKind),
    /// Take the label off the selected step.
    ClearLabel,
    /// Select the next step.
    StepDown,
    /// Select the previous step.
    StepUp,
    /// Write or change the note.
    Note,
    /// The next item.
    Next,
    /// The previous item.
    Previous,
    /// The next item not judged yet.
    NextUnjudged,
    /// Leave this item for later and go to the next one not judged.
    Skip,
    /// Withdraw the last judgement and go back to it.
    Undo,
    /// List every key.
    Help,
    /// Leave; every judgement is already saved.
    Quit,
}

/// Which screens a key works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Applies {
    /// Rating single plans.
    Single,
    /// Choosing between two plans.
    Pairwise,
    /// Both.
    Both,
}

/// One row of the key table.
#[derive(Debug, Clone, Copy)]
pub struct Binding {
    /// The keys, as matched.
    pub codes: &'static [KeyCode],
    /// The keys, as shown in the help.
    pub shown: &'static str,
    /// What they do, as shown in the help.
    pub what: &'static str,
    /// What they do.
    pub action: Action,
    /// Where they work.
    pub applies: Applies,
}

const fn bind(
    codes: &'static [KeyCode],
    shown: &'static str,
    what: &'static str,
    action: Action,
    applies: Applies,
) -> Binding {
    Binding {
        codes,
        shown,
        what,
        action,
        applies,
    }
}

use Applies::{Both, Pairwise, Single};
use KeyCode::Char;

/// Every key of the annotation screen.
pub const KEYS: &[Binding] = &[
    bind(
        &[Char('1'), Char('2'), Char('3'), Char('4'), Char('5')],
        "1–5",
        "rate the plan (the scale is on screen), save, next",
        Action::Rate,
        Single,
    ),
    bind(
        &[Char('1')],
        "1",
        "the left plan is better; save, next",
        Action::Prefer(Preference::Left),
        Pairwise,
    ),
    bind(
        &[Char('2')],
        "2",
        "the right plan is better; save, next",
        Action::Prefer(Preference::Right),
        Pairwise,
    ),
    bind(
        &[Char('0')],
        "0",
        "neither is better; save, next",
        Action::Prefer(Preference::Neither),
        Pairwise,
    ),
    bind(
        &[KeyCode::Down, Char('j')],
        "↓ j",
        "select the next step",
        Action::StepDown,
        Single,
    ),
    bind(
        &[KeyCode::Up, Char('k')],
        "↑ k",
        "select the previous step",
        Action::StepUp,
        Single,
    ),
    bind(
        &[Char('o')],
        "o",
        "label the step: ok",
        Action::Label(StepLabelKind::Ok),
        Single,
    ),
    bind(
        &[Char('w')],
        "w",
        "label the step: wrong object",
        Action::Label(StepLabelKind::WrongObject),
        Single,
    ),
    bind(
        &[Char('a')],
        "a",
        "label the step: wrong action",
        Action::Label(StepLabelKind::WrongAction),
        Single,
    ),
    bind(
        &[Char('r')],
        "r",
        "label the step: wrong order",
        Action::Label(StepLabelKind::WrongOrder),
        Single,
    ),
    bind(
        &[Char('m')],
        "m",
        "label the step: missing step before",
        Action::Label(StepLabelKind::MissingStepBefore),
        Single,
    ),
    bind(
        &[Char('x')],
        "x",
        "label the step: unnecessary",
        Action::Label(StepLabelKind::Unnecessary),
        Single,
    ),
    bind(
        &[Char('!')],
        "!",
        "label the step: unsafe",
        Action::Label(StepLabelKind::Unsafe),
        Single,
    ),
    bind(
        &[KeyCode::Backspace, KeyCode::Delete],
        "Backspace",
        "take the label off the step",
        Action::ClearLabel,
        Single,
    ),
    bind(
        &[Char('e')],
        "e",
        "write a note (Enter keeps it, Esc drops the change)",
        Action::Note,
        Both,
    ),
    bind(
        &[KeyCode::Right, Char('n')],
        "→ n",
        "next item",
        Action::Next,
        Both,
    ),
    bind(
        &[KeyCode::Left, Char('p')],
        "← p",
        "previous item",
        Action::Previous,
        Both,
    ),
    bind(
        &[KeyCode::Tab],
        "Tab",
        "next item not judged yet",
        Action::NextUnjudged,
        Both,
    ),
    bind(
        &[Char('s')],
        "s",
        "skip: leave this one for later",
        Action::Skip,
        Both,
    ),
    bind(
        &[Char('u')],
        "u",
        "undo the last judgement (it is withdrawn)",
        Action::Undo,
        Both,
    ),
    bind(&[Char('?')], "?", "this help", Action::Help, Both),
    bind(
        &[Char('q'), KeyCode::Esc],
        "q Esc",
        "quit (every judgement is already saved)",
        Action::Quit,
        Both,
    ),
];

/// The bindings that work on the single or the pairwise screen.
pub fn bindings(pairwise: bool) -> impl Iterator<Item = &'static Binding> {
    KEYS.iter().filter(move |b| match b.applies {
        Both => true,
        Single => !pairwise,
        Pairwise => pairwise,
    })
}

/// What `key` does on the single or pairwise screen; Ctrl-C always quits.
pub fn action_of(key: KeyEvent, pairwise: bool) -> Option<Action> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    if key.modifiers.contains(KeyModifiers::CONTROL) {
        return (key.code == Char('c')).then_some(Action::Quit);
    }
    bindings(pairwise)
        .find(|b| b.codes.contains(&key.code))
        .map(|b| b.action)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_does_two_things_on_one_screen() {
        for pairwise in [false, true] {
            let mut seen: Vec<KeyCode> = Vec::new();
            for b in bindings(pairwise) {
                for code in b.codes {
                    assert!(
                        !seen.contains(code),
                        "{code:?} twice (pairwise: {pairwise})"
                    );
                    seen.push(*code);
                }
            }
        }
        let key = |c| KeyEvent::new(Char(c), KeyModifiers::NONE);
        assert_eq!(action_of(key('3'), false), Some(Action::Rate));
        assert_eq!(action_of(key('3'), true), None);
        assert_eq!(
            action_of(key('2'), true),
            Some(Action::Prefer(Preference::Right))
        );
        assert_eq!(
            action_of(KeyEvent::new(Char('c'), KeyModifiers::CONTROL), true),
            Some(Action::Quit)
        );
    }
}
