//! The one key table: every binding of the workbench declared once, with the
//! context it applies in, the action it triggers and its help text. The key
//! handlers look actions up here, and the help overlay and the status-bar
//! hints are drawn from it, so a key cannot be handled without being shown,
//! or shown without being handled (the `key_table` tests hold both ways).

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

use super::graph_view::Direction;
use crate::annotate::{Preference, StepLabelKind};

/// Where a binding applies: the mode or pane that has the keyboard.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Context {
    /// Everywhere, editors and overlays included.
    Always,
    /// Any pane, when no editor or overlay has the keyboard.
    Panes,
    /// The Plan pane (beside the keys of the step lists).
    Plan,
    /// The Plan and Ground Truth panes (step lists).
    Steps,
    /// The Knowledge Graph pane showing one node's neighbourhood.
    Graph,
    /// The Knowledge Graph pane showing the whole graph.
    WholeGraph,
    /// The Prompt pane.
    Prompt,
    /// Editing a step.
    StepEditor,
    /// Editing a prompt.
    PromptEditor,
    /// Typing a search.
    Search,
    /// A list to choose from: the ground-truth picker.
    Picker,
    /// The run history.
    History,
    /// A one-line path prompt (the step file).
    PathPrompt,
    /// The model form.
    ModelForm,
    /// Typing the name of a prompt set to save.
    SetName,
    /// A view to read, scroll and close: the framed actions, the message
    /// log.
    Viewer,
    /// The diff of two runs, scrolled.
    RunDiff,
    /// The workbench's key help, open.
    Help,
    /// The annotation screen, rating single plans or choosing between two.
    Annotate,
    /// The annotation screen rating single plans.
    AnnotateRating,
    /// The annotation screen choosing between two plans.
    AnnotatePairwise,
    /// Writing a note on the annotation screen.
    AnnotateNote,
    /// The annotation screen showing the reference plan.
    AnnotateReference,
    /// The annotation screen's help, open.
    AnnotateHelp,
}

impl Context {
    /// Whether this is an overlay's context, whose keys the status bar
    /// shows in full (every binding of it has a hint) instead of the help.
    pub fn is_overlay(self) -> bool {
        matches!(
            self,
            Context::Picker
                | Context::History
                | Context::PathPrompt
                | Context::ModelForm
                | Context::SetName
                | Context::Viewer
                | Context::RunDiff
                | Context::Help
        )
    }

    /// Whether this context belongs to the annotation screen, whose keys
    /// its own help lists (the workbench's help leaves them out).
    pub fn is_annotate(self) -> bool {
        matches!(
            self,
            Context::Annotate
                | Context::AnnotateRating
                | Context::AnnotatePairwise
                | Context::AnnotateNote
                | Context::AnnotateReference
                | Context::AnnotateHelp
        )
    }

    /// The word the status bar starts with in this context, if it is a mode.
    pub fn mode(self) -> Option<&'static str> {
        match self {
            Context::StepEditor => Some("EDIT step"),
            Context::PromptEditor => Some("EDIT prompt"),
            Context::Search => Some("SEARCH"),
            Context::Picker => Some("CHOOSE"),
            Context::History => Some("RUNS"),
            Context::PathPrompt => Some("PATH"),
            Context::ModelForm => Some("MODEL"),
            Context::SetName => Some("SAVE prompts"),
            Context::Viewer => Some("VIEW"),
            Context::RunDiff => Some("DIFF"),
            Context::Help => Some("HELP"),
            _ => None,
        }
    }
}

/// What a key does. Handlers match on this, never on key codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Quit (the session is saved).
    Quit,
    /// Focus the next pane.
    NextPane,
    /// Focus the previous pane.
    PreviousPane,
    /// Show the key help.
    Help,
    /// Zoom the focused pane, or leave the zoom.
    Zoom,
    /// Leave zoom, clear the search, or clear the status line.
    Escape,
    /// Start typing a search.
    Search,
    /// Jump to the next search hit.
    NextHit,
    /// Move the selection or scroll by this many lines.
    Move(isize),
    /// Edit the selected step.
    EditStep,
    /// Insert a step after the selected one.
    InsertAfter,
    /// Insert a step before the selected one.
    InsertBefore,
    /// Delete the selected step.
    DeleteStep,
    /// Move the selected step down.
    StepDown,
    /// Move the selected step up.
    StepUp,
    /// Open the ground-truth picker.
    ChooseGroundTruth,
    /// Load the task's published plan.
    PublishedPlan,
    /// Switch to the next approach.
    NextApproach,
    /// Ask each agent for the next number of samples per run
    /// ([`SAMPLE_STEPS`](crate::workbench::runs::SAMPLE_STEPS)).
    NextSamples,
    /// Run the agents whose inputs changed.
    Run,
    /// Run every agent again.
    RunAll,
    /// Cancel the run in flight.
    CancelRun,
    /// Open the model form of an agent.
    ModelForm,
    /// Save every prompt as a named prompt set.
    SavePromptSet,
    /// Choose a saved prompt set and load its prompts.
    LoadPromptSet,
    /// In the model form: save for every agent, or for the form's agent
    /// alone (a toggle).
    EveryAgent,
    /// Show the framed actions and their matches.
    Actions,
    /// Open the run history.
    History,
    /// Open the message log.
    Messages,
    /// Turn the scene image on or off.
    ToggleImage,
    /// Switch to the next theme.
    NextTheme,
    /// Go to the selected neighbour in the graph.
    GraphEnter,
    /// Go back to the previous node in the graph.
    GraphBack,
    /// Select the next (+1) or previous (-1) node of the graph.
    GraphNode(isize),
    /// Select the next (+1) or previous (-1) node of the whole graph.
    GraphSelect(isize),
    /// Select the nearest node in a direction in the whole graph.
    GraphStep(Direction),
    /// Zoom the whole graph in (+1) or out (-1).
    GraphZoom(isize),
    /// Switch between the whole graph and one node's neighbourhood.
    GraphMode,
    /// Show the knowledge graph's triples as a list (focusing its pane),
    /// or the drawing again.
    GraphList,
    /// Edit the shown prompt.
    EditPrompt,
    /// Show the prompt of the next (+1) or previous (-1) agent.
    PromptStep(isize),
    /// Show the prompt of the agent at this position.
    PromptOf(usize),
    /// Keep the edit (step editor) or jump to the hit (search).
    Accept,
    /// Cancel the edit, finish the prompt, or clear the search.
    Leave,
    /// Run the agents from the prompt editor.
    RunFromEditor,
    /// Focus the next field of a form.
    NextField,
    /// Focus the previous field of a form.
    PreviousField,
    /// Mark the highlighted run for comparison, or unmark it.
    MarkRun,
    /// Open the diff of the marked run (or the one before) and the highlighted one.
    CompareRuns,
    /// Choose how to corrupt the plan into a new run.
    Corrupt,
    /// Rate the plan on screen 1–5, save, and move on (annotation).
    Rate(u8),
    /// Prefer one plan of the pair, save, and move on (annotation).
    Prefer(Preference),
    /// Put a label on the selected step; the same label again takes it off.
    Label(StepLabelKind),
    /// Take the label off the selected step.
    ClearLabel,
    /// Write or change the note of the judgement.
    WriteNote,
    /// Show the next item.
    NextItem,
    /// Show the previous item.
    PreviousItem,
    /// Show the next item not judged yet.
    NextUnjudged,
    /// Leave this item for later and show the next one not judged.
    SkipItem,
    /// Take back the newest change: a judgement on the annotation screen
    /// (its item shown again), a step edit in the workbench's step lists,
    /// the last change to the text in an editor.
    Undo,
}

/// A key as the table names it: a code, and whether Ctrl is held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Key {
    /// The key.
    pub code: KeyCode,
    /// Ctrl must be held (Shift is part of the character).
    pub ctrl: bool,
}

impl Key {
    /// Whether `event` is this key: Ctrl held exactly when the table says,
    /// and no Alt. Ctrl-D is never `d` (delete) nor Ctrl-Z `z` (zoom), so a
    /// chord meant for another program or a slip of the finger does nothing;
    /// Shift is part of the character.
    pub fn matches(self, event: &KeyEvent) -> bool {
        event.code == self.code
            && self.ctrl == event.modifiers.contains(KeyModifiers::CONTROL)
            && !event.modifiers.contains(KeyModifiers::ALT)
    }
}

/// One line of the key help: keys, each with its action, in one context.
#[derive(Debug, Clone, Copy)]
pub struct Binding {
    /// Where the keys apply.
    pub context: Context,
    /// Each key and what it does.
    pub keys: &'static [(Key, Action)],
    /// The keys as the help shows them.
    pub label: &'static str,
    /// What they do, as the help says it.
    pub help: &'static str,
    /// The status-bar hint: the key and a word or two.
    pub hint: Option<(&'static str, &'static str)>,
}

mod annotate;
mod row;
mod table;

/// Every binding, the workbench's and the annotation screen's, in the order
/// their helps list them: the one table every key is looked up in.
pub const BINDINGS: &[Binding] = &joined::<{ table::WORKBENCH.len() + annotate::ANNOTATE.len() }>(
    table::WORKBENCH,
    annotate::ANNOTATE,
);

/// The rows of `first` then those of `second`, as one array of `N` rows
/// (their lengths summed).
const fn joined<const N: usize>(first: &[Binding], second: &[Binding]) -> [Binding; N] {
    let mut out = [first[0]; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < first.len() {
            first[i]
        } else {
            second[i - first.len()]
        };
        i += 1;
    }
    out
}

/// Every key a person can press: the printable characters, Ctrl with each
/// letter, and the named keys (F1 to F12 among them). The tests that press
/// every key against the key table (workbench and annotation screen) use
/// this one list, so that a key missing from one of them cannot hide.
pub fn pressable_keys() -> Vec<KeyEvent> {
    let named = [
        KeyCode::Enter,
        KeyCode::Esc,
        KeyCode::Tab,
        KeyCode::BackTab,
        KeyCode::Backspace,
        KeyCode::Delete,
        KeyCode::Insert,
        KeyCode::Up,
        KeyCode::Down,
        KeyCode::Left,
        KeyCode::Right,
        KeyCode::Home,
        KeyCode::End,
        KeyCode::PageUp,
        KeyCode::PageDown,
    ];
    (' '..='~')
        .map(|c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
        .chain(('a'..='z').map(|c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL)))
        .chain(
            named
                .into_iter()
                .chain((1..=12).map(KeyCode::F))
                .map(|code| KeyEvent::new(code, KeyModifiers::NONE)),
        )
        .collect()
}

/// The action `event` triggers in the first of `contexts` that binds it.
pub fn action(contexts: &[Context], event: &KeyEvent) -> Option<Action> {
    contexts.iter().find_map(|&context| {
        BINDINGS
            .iter()
            .filter(|b| b.context == context)
            .flat_map(|b| b.keys)
            .find(|(key, _)| key.matches(event))
            .map(|&(_, action)| action)
    })
}

/// The status-bar hints of `context`: "key hint" pairs joined by dots.
pub fn hints(context: Context) -> String {
    hints_of(&[context]).join(" · ")
}

/// The status-bar hints of every context of `contexts`, each "key hint",
/// in table order.
pub fn hints_of(contexts: &[Context]) -> Vec<String> {
    BINDINGS
        .iter()
        .filter(|b| contexts.contains(&b.context))
        .filter_map(|b| b.hint.map(|(key, hint)| format!("{key} {hint}")))
        .collect()
}

/// The workbench help's lines: the keys as shown and what they do, in table
/// order. An overlay's keys are not among them (its status bar shows them
/// all), nor the annotation screen's (its own help lists them).
pub fn help_lines() -> impl Iterator<Item = (&'static str, &'static str)> {
    BINDINGS
        .iter()
        .filter(|b| !b.context.is_overlay() && !b.context.is_annotate())
        .map(|b| (b.label, b.help))
}

/// The help lines of the bindings of `contexts`, in table order: what a
/// screen with exactly these contexts lists in its help.
pub fn help_lines_of(
    contexts: &[Context],
) -> impl Iterator<Item = (&'static str, &'static str)> + '_ {
    BINDINGS
        .iter()
        .filter(|b| contexts.contains(&b.context))
        .map(|b| (b.label, b.help))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_is_bound_twice_in_one_context() {
        for (i, a) in BINDINGS.iter().enumerate() {
            for b in &BINDINGS[i..] {
                for (n, (ka, _)) in a.keys.iter().enumerate() {
                    let skip = if std::ptr::eq(a, b) { n + 1 } else { 0 };
                    for (kb, _) in b.keys.iter().skip(skip) {
                        assert!(
                            !(a.context == b.context && ka == kb),
                            "{ka:?} is bound twice in {:?}",
                            a.context
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn every_overlay_binding_has_a_status_bar_hint() {
        for b in BINDINGS.iter().filter(|b| b.context.is_overlay()) {
            assert!(b.hint.is_some(), "{} has no hint", b.label);
        }
    }

    #[test]
    fn the_first_context_that_binds_a_key_wins() {
        let right = KeyEvent::new(KeyCode::Right, KeyModifiers::NONE);
        assert_eq!(
            action(&[Context::Graph, Context::Panes], &right),
            Some(Action::GraphEnter)
        );
        assert_eq!(action(&[Context::Panes], &right), Some(Action::NextPane));
        let f5 = KeyEvent::new(KeyCode::F(5), KeyModifiers::NONE);
        assert_eq!(
            action(&[Context::PromptEditor], &f5),
            Some(Action::RunFromEditor)
        );
        let plain_r = KeyEvent::new(KeyCode::Char('r'), KeyModifiers::NONE);
        assert_eq!(action(&[Context::PromptEditor], &plain_r), None);
    }

    #[test]
    fn ctrl_or_alt_with_a_letter_is_never_the_plain_letter() {
        let with = |c, modifiers| KeyEvent::new(KeyCode::Char(c), modifiers);
        let steps = [Context::Steps, Context::Panes];
        assert_eq!(
            action(&steps, &with('d', KeyModifiers::NONE)),
            Some(Action::DeleteStep)
        );
        assert_eq!(
            action(&steps, &with('z', KeyModifiers::NONE)),
            Some(Action::Zoom)
        );
        for modifiers in [KeyModifiers::CONTROL, KeyModifiers::ALT] {
            assert_eq!(action(&steps, &with('d', modifiers)), None, "{modifiers:?}");
            assert_eq!(action(&steps, &with('z', modifiers)), None, "{modifiers:?}");
        }
        let capital = with('O', KeyModifiers::SHIFT);
        assert_eq!(action(&steps, &capital), Some(Action::InsertBefore));
    }
}
