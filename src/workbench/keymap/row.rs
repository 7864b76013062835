//! How a row of the key table is written: `row(context, keys, action,
//! help)` on one line, with `.hint(word)` for a status-bar hint and
//! `.overrides()` where a pane's key wins over the same key of the panes
//! behind it. Shared by the workbench's rows and the annotation screen's.

use super::notation::Keys;
use super::{Action, Binding, Context};

/// A row: `keys` in the table's notation ([`super::notation`]) do
/// `action` in `context`, as `help` says.
pub(super) const fn row(
    context: Context,
    keys: &str,
    action: Action,
    help: &'static str,
) -> Binding {
    Binding {
        context,
        keys: Keys::parse(keys),
        action,
        help,
        hint: None,
        overrides: false,
    }
}

impl Binding {
    /// This row with the status-bar hint `word`, shown after the row's
    /// first key (rows of one context with the same word share a hint).
    pub(super) const fn hint(self, word: &'static str) -> Binding {
        Binding {
            hint: Some(word),
            ..self
        }
    }

    /// This row marked as meant to win over the same key bound in a
    /// context active behind it (the Prompt pane's ← →, the graph's
    /// arrows): without the mark the key table's tests refuse the clash.
    pub(super) const fn overrides(self) -> Binding {
        Binding {
            overrides: true,
            ..self
        }
    }
}
