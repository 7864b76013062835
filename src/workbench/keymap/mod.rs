//! The one key table: every binding of the workbench and of the annotation
//! screen declared once, a row a line (context, keys, action, help text,
//! status-bar hint), its keys written in a small notation read at compile
//! time. The key handlers look actions up here, and the helps and the
//! status-bar hints are drawn from it, key labels included, so a key cannot
//! be handled without being shown, or shown other than it is bound (the
//! `key_table` tests hold both ways).

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
    /// Typing the words the workbench's key help is filtered by.
    HelpFilter,
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
                | Context::HelpFilter
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
            Context::HelpFilter => Some("FILTER keys"),
            _ => None,
        }
    }

    /// The heading of this context's section in a help: where its keys
    /// work, in the words the screen uses for it.
    pub fn title(self) -> &'static str {
        match self {
            Context::Always => "Everywhere",
            Context::Panes => "Any pane",
            Context::Plan => "Plan pane",
            Context::Steps => "Plan and Ground Truth panes",
            Context::Graph => "Knowledge Graph, one node's neighbourhood",
            Context::WholeGraph => "Knowledge Graph, the whole graph",
            Context::Prompt => "Prompt pane",
            Context::StepEditor => "Editing a step",
            Context::PromptEditor => "Editing a prompt",
            Context::Search => "Typing a search",
            Context::Picker => "Choosing from a list (ground truth, corruption, prompt set)",
            Context::History => "Run history",
            Context::PathPrompt => "Step file path",
            Context::ModelForm => "Model form",
            Context::SetName => "Naming a prompt set",
            Context::Viewer => "Framed actions and message log",
            Context::RunDiff => "Diff of two runs",
            Context::Help | Context::AnnotateHelp => "This help",
            Context::HelpFilter => "Filtering this help",
            Context::Annotate => "Any item",
            Context::AnnotateRating => "Rating a plan",
            Context::AnnotatePairwise => "Choosing between two plans",
            Context::AnnotateNote => "Writing a note",
            Context::AnnotateReference => "With the reference plan shown",
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
    /// Move the selection or scroll by half the view, down (+1) or up
    /// (-1): Ctrl-D and Ctrl-U where they do not edit.
    HalfPage(isize),
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

/// A key as the table names it: a code, and whether Ctrl is held. Shown
/// by its `Display` (`Tab`, `Shift-Tab`, `→`, `Ctrl-R`, `PgUp`, `space`),
/// the one place a key's label is made.
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

    /// The event of pressing this key (no modifiers but Ctrl where the
    /// table says): what the tests press for a row.
    pub fn event(self) -> KeyEvent {
        let modifiers = if self.ctrl {
            KeyModifiers::CONTROL
        } else {
            KeyModifiers::NONE
        };
        KeyEvent::new(self.code, modifiers)
    }
}

/// One row of the key table: keys doing one action in one context, what
/// the help says of it and the status bar's word for it.
#[derive(Debug, Clone, Copy)]
pub struct Binding {
    /// Where the keys apply.
    pub context: Context,
    /// The keys, parsed from the table's notation.
    keys: Keys,
    /// What the keys do.
    pub action: Action,
    /// What they do, as the help says it (never naming a key: the help
    /// shows the row's keys beside it).
    pub help: &'static str,
    /// The status bar's word for the row, shown after its first key.
    pub hint: Option<&'static str>,
    /// Meant to win over the same key of a context active behind this one.
    pub overrides: bool,
}

impl Binding {
    /// The row's keys, in the order the table writes them.
    pub fn keys(&self) -> &[Key] {
        self.keys.as_slice()
    }

    /// The row's keys as the help shows them, made from the keys.
    pub fn label(&self) -> String {
        notation::label(self.keys())
    }
}

mod annotate;
mod notation;
mod row;
mod table;

use notation::Keys;

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

/// The row `event` triggers in the first of `contexts` that binds it.
fn binding_of(contexts: &[Context], event: &KeyEvent) -> Option<&'static Binding> {
    contexts.iter().find_map(|&context| {
        BINDINGS
            .iter()
            .filter(|b| b.context == context)
            .find(|b| b.keys().iter().any(|key| key.matches(event)))
    })
}

/// The action `event` triggers in the first of `contexts` that binds it.
pub fn action(contexts: &[Context], event: &KeyEvent) -> Option<Action> {
    binding_of(contexts, event).map(|b| b.action)
}

/// The first key bound to `action` in `context`, as the help shows it: for
/// a sentence that names the key to press (`Enter edits`), so that it says
/// what the table binds. Empty when nothing binds it (the test
/// `every_key_a_sentence_names_is_bound` holds the sentences' keys to the
/// table).
pub fn key_of(context: Context, action: Action) -> String {
    BINDINGS
        .iter()
        .find(|b| b.context == context && b.action == action)
        .and_then(|b| b.keys().first())
        .map_or_else(String::new, |key| notation::label(&[*key]))
}

/// The status-bar hints of `context`: "key hint" pairs joined by dots.
pub fn hints(context: Context) -> String {
    hints_of(&[context]).join(" · ")
}

/// The status-bar hints of every context of `contexts`, each "keys word",
/// in table order: a row's first key, and after it the first keys of the
/// later rows with the same word (`↑↓ move`, `1–5 rate`).
pub fn hints_of(contexts: &[Context]) -> Vec<String> {
    let mut hints: Vec<(&str, Vec<Key>)> = Vec::new();
    for b in BINDINGS.iter().filter(|b| contexts.contains(&b.context)) {
        let (Some(word), Some(&key)) = (b.hint, b.keys().first()) else {
            continue;
        };
        match hints.iter_mut().find(|(w, _)| *w == word) {
            Some((_, keys)) => keys.push(key),
            None => hints.push((word, vec![key])),
        }
    }
    hints
        .into_iter()
        .map(|(word, keys)| format!("{} {word}", notation::label(&keys)))
        .collect()
}

/// One section of a help: the rows of one context, under its title.
#[derive(Debug, Clone)]
pub struct Section {
    /// Where the rows work: the section's heading is its title.
    pub context: Context,
    /// The rows, in table order.
    pub rows: Vec<&'static Binding>,
}

/// The help's sections for `contexts`, one a context that binds a key, in
/// the order of `contexts`.
pub fn help_sections(contexts: &[Context]) -> Vec<Section> {
    contexts
        .iter()
        .map(|&context| Section {
            context,
            rows: BINDINGS.iter().filter(|b| b.context == context).collect(),
        })
        .filter(|s| !s.rows.is_empty())
        .collect()
}

/// Every context of the workbench (the annotation screen's left out: its
/// own help lists them), in the order the key table first names them: the
/// sections of the workbench's help.
pub fn workbench_contexts() -> Vec<Context> {
    let mut contexts: Vec<Context> = Vec::new();
    for b in BINDINGS.iter().filter(|b| !b.context.is_annotate()) {
        if !contexts.contains(&b.context) {
            contexts.push(b.context);
        }
    }
    contexts
}

/// A key bound in two of the contexts a key is looked up in together: the
/// row that wins (the earlier context's) and the row it hides.
#[derive(Debug, Clone, Copy)]
pub struct Clash {
    /// The key.
    pub key: Key,
    /// The row the key triggers.
    pub wins: &'static Binding,
    /// The row of a later context the key never reaches.
    pub hidden: &'static Binding,
}

/// Every key of `contexts` (a lookup's contexts, the first winning) that a
/// later context binds too: a key that does not do what its later row
/// says. Meant where the winning row is marked [`Binding::overrides`], a
/// mistake anywhere else (the tests walk every screen's contexts).
pub fn clashes(contexts: &[Context]) -> Vec<Clash> {
    let mut found = Vec::new();
    for (i, &later) in contexts.iter().enumerate() {
        for hidden in BINDINGS.iter().filter(|b| b.context == later) {
            for &key in hidden.keys() {
                let wins = binding_of(&contexts[..i], &key.event());
                if let Some(wins) = wins {
                    found.push(Clash { key, wins, hidden });
                }
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_is_bound_twice_in_one_context() {
        for (i, a) in BINDINGS.iter().enumerate() {
            for (n, ka) in a.keys().iter().enumerate() {
                let again = a.keys()[n + 1..].contains(ka)
                    || BINDINGS[i + 1..]
                        .iter()
                        .any(|b| b.context == a.context && b.keys().contains(ka));
                assert!(!again, "{ka} is bound twice in {:?}", a.context);
            }
        }
    }

    #[test]
    fn the_help_label_of_each_row_is_its_keys() {
        // The label is made from the keys; read back, it is those keys and
        // no others, so the help cannot show one key and bind another.
        for b in BINDINGS {
            let label = b.label();
            assert_eq!(
                notation::tests::read_label(&label),
                b.keys(),
                "{label} ({:?})",
                b.context
            );
        }
    }

    #[test]
    fn no_help_text_names_a_key_by_hand() {
        // Named keys only: a letter is a word too ("a", "o").
        let named: Vec<String> = pressable_keys()
            .into_iter()
            .filter(|e| !matches!(e.code, KeyCode::Char(c) if c != ' '))
            .map(|e| {
                Key {
                    code: e.code,
                    ctrl: false,
                }
                .to_string()
            })
            .collect();
        for b in BINDINGS {
            let words: Vec<&str> = b
                .help
                .split(|c: char| !c.is_alphanumeric() && c != '-')
                .collect();
            for key in &named {
                let names = if key.chars().all(char::is_alphanumeric) {
                    words.contains(&key.as_str())
                } else {
                    b.help.contains(key.as_str())
                };
                assert!(
                    !names && !b.help.contains("Ctrl-"),
                    "the help of {} names the key {key}: {}",
                    b.label(),
                    b.help
                );
            }
        }
    }

    #[test]
    fn every_overlay_binding_has_a_status_bar_hint() {
        for b in BINDINGS.iter().filter(|b| b.context.is_overlay()) {
            assert!(b.hint.is_some(), "{} has no hint", b.label());
        }
    }

    #[test]
    fn a_hint_shows_the_first_key_of_each_row_with_its_word() {
        assert_eq!(
            hints(Context::Panes),
            "? keys · Tab pane · r run · g ground truth · q quit"
        );
        assert_eq!(
            hints(Context::History),
            "↑↓ move · Enter loads the plan · space marks · d diffs · Esc closes"
        );
        let rating = hints_of(&[Context::AnnotateRating]);
        assert_eq!(rating, ["1–5 rate", "↑↓ step", "o w a r m x ! label"]);
    }

    #[test]
    fn a_clash_is_found_and_the_prompt_panes_are_marked() {
        let prompt = clashes(&[Context::Prompt, Context::Panes]);
        let shown: Vec<String> = prompt.iter().map(|c| c.key.to_string()).collect();
        assert_eq!(shown, ["→", "l", "←", "h", "S"]);
        assert!(prompt
            .iter()
            .all(|c| c.wins.overrides && !c.hidden.overrides));
        // The same contexts the other way round: the panes' keys win, none
        // of them marked.
        let reversed = clashes(&[Context::Panes, Context::Prompt]);
        assert_eq!(reversed.len(), prompt.len());
        assert!(reversed.iter().all(|c| !c.wins.overrides));
        assert!(clashes(&[Context::Always, Context::StepEditor]).is_empty());
    }

    #[test]
    fn the_workbench_help_has_a_section_a_context_and_no_annotation_key() {
        let sections = help_sections(&workbench_contexts());
        assert_eq!(sections[0].context, Context::Panes);
        let rows: usize = sections.iter().map(|s| s.rows.len()).sum();
        let workbench = BINDINGS.iter().filter(|b| !b.context.is_annotate());
        assert_eq!(rows, workbench.count());
        assert!(sections.iter().all(|s| !s.context.is_annotate()));
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
            assert_eq!(action(&steps, &with('z', modifiers)), None, "{modifiers:?}");
        }
        // Ctrl-D is half a page down, never the delete of a plain d.
        assert_eq!(
            action(&steps, &with('d', KeyModifiers::CONTROL)),
            Some(Action::HalfPage(1))
        );
        assert_eq!(action(&steps, &with('d', KeyModifiers::ALT)), None);
        let capital = with('O', KeyModifiers::SHIFT);
        assert_eq!(action(&steps, &capital), Some(Action::InsertBefore));
    }

    #[test]
    fn every_key_a_sentence_names_is_bound() {
        let named = [
            (Context::Panes, Action::Run, "r"),
            (Context::Panes, Action::CancelRun, "x"),
            (Context::Panes, Action::ModelForm, "m"),
            (Context::Panes, Action::Escape, "Esc"),
            (Context::Prompt, Action::EditPrompt, "Enter"),
            (Context::Prompt, Action::PromptStep(-1), "←"),
            (Context::Prompt, Action::PromptStep(1), "→"),
            (Context::Picker, Action::Accept, "Enter"),
            (Context::Picker, Action::Leave, "Esc"),
            (Context::AnnotateRating, Action::Move(-1), "↑"),
            (Context::AnnotateRating, Action::Move(1), "↓"),
            (Context::AnnotateReference, Action::NextPane, "g"),
        ];
        for (context, action, key) in named {
            assert_eq!(key_of(context, action), key, "{context:?} {action:?}");
        }
        assert_eq!(key_of(Context::Help, Action::Run), "");
    }
}
