//! The editors that take the keyboard: a step, the prompt, the search.

use ratatui_textarea::TextArea;

use crate::workbench::keymap::Context;
use crate::workbench::layout::StepList;

/// An editor in use.
#[derive(Debug, Clone)]
pub enum Editing {
    /// No editor: keys are commands.
    None,
    /// Editing one step.
    Step {
        /// The list.
        list: StepList,
        /// The step's index.
        index: usize,
        /// The editor.
        editor: TextArea<'static>,
        /// Whether the step was inserted for this edit (Esc removes it).
        inserted: bool,
    },
    /// Editing the selected agent's prompt.
    Prompt,
    /// Typing a search.
    Search(TextArea<'static>),
}

impl Editing {
    /// The key context of this editor ([`Context::Panes`] when none is open).
    pub fn context(&self) -> Context {
        match self {
            Editing::None => Context::Panes,
            Editing::Step { .. } => Context::StepEditor,
            Editing::Prompt => Context::PromptEditor,
            Editing::Search(_) => Context::Search,
        }
    }
}
