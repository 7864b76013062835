//! The small constructors that keep each row of the key table on a line
//! or two, shared by the workbench's rows and the annotation screen's.

use crossterm::event::KeyCode;

use super::{Action, Binding, Context, Key};

/// A key without modifiers.
pub(super) const fn key(code: KeyCode) -> Key {
    Key { code, ctrl: false }
}

/// A character key.
pub(super) const fn ch(c: char) -> Key {
    key(KeyCode::Char(c))
}

/// Ctrl with a character.
pub(super) const fn ctrl(c: char) -> Key {
    Key {
        code: KeyCode::Char(c),
        ctrl: true,
    }
}

/// A row without a status-bar hint.
pub(super) const fn bind(
    context: Context,
    keys: &'static [(Key, Action)],
    label: &'static str,
    help: &'static str,
) -> Binding {
    Binding {
        context,
        keys,
        label,
        help,
        hint: None,
    }
}

/// `binding` with the status-bar hint `key` and `hint`.
pub(super) const fn hinted(binding: Binding, key: &'static str, hint: &'static str) -> Binding {
    Binding {
        hint: Some((key, hint)),
        ..binding
    }
}

/// Up and down by one, arrows and vi keys: how every list and page moves.
pub(super) const MOVE_KEYS: &[(Key, Action)] = &[
    (key(KeyCode::Up), Action::Move(-1)),
    (key(KeyCode::Down), Action::Move(1)),
    (ch('k'), Action::Move(-1)),
    (ch('j'), Action::Move(1)),
];

/// The keys that move through a list or scroll a text: a line with ↑↓ j k,
/// a page with PgUp PgDn, the ends with Home End (read by
/// [`crate::workbench::scroll::Motion::of_move`]).
pub(super) const SCROLL_KEYS: &[(Key, Action)] = &[
    (key(KeyCode::Up), Action::Move(-1)),
    (key(KeyCode::Down), Action::Move(1)),
    (ch('k'), Action::Move(-1)),
    (ch('j'), Action::Move(1)),
    (key(KeyCode::PageUp), Action::Move(-10)),
    (key(KeyCode::PageDown), Action::Move(10)),
    (key(KeyCode::Home), Action::Move(isize::MIN)),
    (key(KeyCode::End), Action::Move(isize::MAX)),
];

/// How the help shows [`SCROLL_KEYS`].
pub(super) const SCROLL_LABEL: &str = "↑↓ j k, PgUp PgDn, Home End";
