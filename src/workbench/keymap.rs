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
    /// A view to read and close: the framed actions, two runs compared.
    Viewer,
    /// The annotation screen, rating single plans or choosing between two.
    Annotate,
    /// The annotation screen rating single plans.
    AnnotateRating,
    /// The annotation screen choosing between two plans.
    AnnotatePairwise,
    /// Writing a note on the annotation screen.
    AnnotateNote,
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
                | Context::Viewer
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
            Context::Viewer => Some("VIEW"),
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
    /// Run the agents whose inputs changed.
    Run,
    /// Run every agent again.
    RunAll,
    /// Cancel the run in flight.
    CancelRun,
    /// Open the model form of an agent.
    ModelForm,
    /// Show the framed actions and their matches.
    Actions,
    /// Open the run history.
    History,
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
    /// Compare the marked run with the highlighted one.
    CompareRuns,
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
    /// Withdraw the last judgement and show its item again.
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
    /// Whether `event` is this key. A key without Ctrl matches whatever
    /// the modifiers are, as the handlers always did.
    pub fn matches(self, event: &KeyEvent) -> bool {
        event.code == self.code && (!self.ctrl || event.modifiers.contains(KeyModifiers::CONTROL))
    }
}

const fn key(code: KeyCode) -> Key {
    Key { code, ctrl: false }
}

const fn ch(c: char) -> Key {
    key(KeyCode::Char(c))
}

const fn ctrl(c: char) -> Key {
    Key {
        code: KeyCode::Char(c),
        ctrl: true,
    }
}

/// One line of the key help: keys, each with its action, in one context.
#[derive(Debug)]
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

const fn bind(
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

const fn hinted(binding: Binding, key: &'static str, hint: &'static str) -> Binding {
    Binding {
        hint: Some((key, hint)),
        ..binding
    }
}

use Action as A;
use Context as C;

/// Every binding of the workbench, in the order the help lists them.
pub const BINDINGS: &[Binding] = &[
    hinted(
        bind(C::Panes, &[(ch('?'), A::Help)], "?", "this help"),
        "?",
        "keys",
    ),
    hinted(
        bind(
            C::Panes,
            &[
                (key(KeyCode::Tab), A::NextPane),
                (key(KeyCode::BackTab), A::PreviousPane),
                (key(KeyCode::Right), A::NextPane),
                (key(KeyCode::Left), A::PreviousPane),
                (ch('l'), A::NextPane),
                (ch('h'), A::PreviousPane),
            ],
            "Tab, Shift-Tab, ←/→, h/l",
            "next or previous pane",
        ),
        "Tab",
        "pane",
    ),
    hinted(
        bind(
            C::Panes,
            &[(ch('r'), A::Run), (ch('R'), A::RunAll)],
            "r, R",
            "run the agents whose inputs changed; re-run all",
        ),
        "r",
        "run",
    ),
    hinted(
        bind(
            C::Panes,
            &[(ch('g'), A::ChooseGroundTruth)],
            "g",
            "choose a ground truth: demo, dataset task, step file, or type one",
        ),
        "g",
        "ground truth",
    ),
    hinted(
        bind(
            C::Panes,
            &[(ch('q'), A::Quit)],
            "q",
            "quit (the session is saved)",
        ),
        "q",
        "quit",
    ),
    bind(
        C::Always,
        &[(ctrl('c'), A::Quit)],
        "Ctrl-C",
        "quit, also while editing",
    ),
    bind(
        C::Panes,
        &[
            (key(KeyCode::Down), A::Move(1)),
            (key(KeyCode::Up), A::Move(-1)),
            (ch('j'), A::Move(1)),
            (ch('k'), A::Move(-1)),
            (key(KeyCode::PageDown), A::Move(10)),
            (key(KeyCode::PageUp), A::Move(-10)),
        ],
        "↑/↓, j/k, PgUp/PgDn",
        "select a step, a neighbour, or scroll",
    ),
    bind(
        C::Panes,
        &[(key(KeyCode::Esc), A::Escape)],
        "Esc",
        "leave zoom, clear the search or the message",
    ),
    bind(
        C::Panes,
        &[(ch('/'), A::Search), (ch('n'), A::NextHit)],
        "/ then n",
        "search every pane, then jump to the next hit",
    ),
    bind(
        C::Panes,
        &[(ch('z'), A::Zoom)],
        "z",
        "zoom the focused pane",
    ),
    bind(
        C::Steps,
        &[(key(KeyCode::Enter), A::EditStep), (ch('e'), A::EditStep)],
        "Enter, e (steps)",
        "edit the selected step",
    ),
    bind(
        C::Steps,
        &[(ch('o'), A::InsertAfter), (ch('O'), A::InsertBefore)],
        "o, O (steps)",
        "insert a step after or before the selected one",
    ),
    bind(
        C::Steps,
        &[
            (ch('d'), A::DeleteStep),
            (key(KeyCode::Delete), A::DeleteStep),
        ],
        "d, Delete (steps)",
        "delete the selected step",
    ),
    bind(
        C::Steps,
        &[(ch('J'), A::StepDown), (ch('K'), A::StepUp)],
        "J, K (steps)",
        "move the selected step down or up",
    ),
    bind(
        C::Panes,
        &[(ch('p'), A::PublishedPlan)],
        "p",
        "load the task's published plan for the approach",
    ),
    bind(
        C::Panes,
        &[(ch('a'), A::NextApproach)],
        "a",
        "next approach (table ones when the task has a table)",
    ),
    bind(
        C::Panes,
        &[(ch('x'), A::CancelRun)],
        "x",
        "cancel the run in flight",
    ),
    bind(
        C::Prompt,
        &[
            (key(KeyCode::Enter), A::EditPrompt),
            (ch('e'), A::EditPrompt),
            (ch('1'), A::PromptOf(0)),
            (ch('2'), A::PromptOf(1)),
            (ch('3'), A::PromptOf(2)),
            (key(KeyCode::Right), A::PromptStep(1)),
            (key(KeyCode::Left), A::PromptStep(-1)),
            (ch('l'), A::PromptStep(1)),
            (ch('h'), A::PromptStep(-1)),
        ],
        "Enter, e, 1 2 3, ←/→ (prompt)",
        "edit the prompt; the prompt of SKM, GKM, Planner; other agent",
    ),
    hinted(
        bind(
            C::PromptEditor,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (editing a prompt)",
            "done editing the prompt",
        ),
        "Esc",
        "done",
    ),
    hinted(
        bind(
            C::PromptEditor,
            &[
                (ctrl('r'), A::RunFromEditor),
                (key(KeyCode::F(5)), A::RunFromEditor),
            ],
            "Ctrl-R, F5 (editing a prompt)",
            "run the agents with the edited prompt",
        ),
        "Ctrl-R",
        "runs",
    ),
    hinted(
        bind(
            C::StepEditor,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (editing a step)",
            "keep the edit",
        ),
        "Enter",
        "keeps",
    ),
    hinted(
        bind(
            C::StepEditor,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (editing a step)",
            "cancel the edit",
        ),
        "Esc",
        "cancels",
    ),
    hinted(
        bind(
            C::Search,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (searching)",
            "jump to the next hit",
        ),
        "Enter",
        "jumps",
    ),
    hinted(
        bind(
            C::Search,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (searching)",
            "clear the search",
        ),
        "Esc",
        "clears",
    ),
    bind(
        C::Panes,
        &[(ch('m'), A::ModelForm)],
        "m",
        "provider, model, temperature and token limit of an agent",
    ),
    bind(
        C::WholeGraph,
        &[
            (key(KeyCode::Left), A::GraphStep(Direction::Left)),
            (key(KeyCode::Right), A::GraphStep(Direction::Right)),
            (key(KeyCode::Up), A::GraphStep(Direction::Up)),
            (key(KeyCode::Down), A::GraphStep(Direction::Down)),
            (ch('h'), A::GraphStep(Direction::Left)),
            (ch('l'), A::GraphStep(Direction::Right)),
            (ch('k'), A::GraphStep(Direction::Up)),
            (ch('j'), A::GraphStep(Direction::Down)),
            (ch(']'), A::GraphSelect(1)),
            (ch('['), A::GraphSelect(-1)),
        ],
        "←↑↓→ hjkl [ ] (whole graph)",
        "the nearest node that way; the next or previous node",
    ),
    bind(
        C::WholeGraph,
        &[
            (ch('+'), A::GraphZoom(1)),
            (ch('-'), A::GraphZoom(-1)),
            (ch('v'), A::GraphMode),
        ],
        "+ - v (whole graph)",
        "zoom in or out; one node's neighbourhood instead",
    ),
    bind(
        C::Graph,
        &[(ch('v'), A::GraphMode)],
        "v (neighbourhood)",
        "back to the whole graph",
    ),
    bind(
        C::Graph,
        &[
            (key(KeyCode::Enter), A::GraphEnter),
            (key(KeyCode::Right), A::GraphEnter),
            (ch('l'), A::GraphEnter),
            (key(KeyCode::Left), A::GraphBack),
            (ch('h'), A::GraphBack),
            (key(KeyCode::Backspace), A::GraphBack),
            (ch(']'), A::GraphNode(1)),
            (ch('['), A::GraphNode(-1)),
        ],
        "Enter → ← Backspace [ ] (neighbourhood)",
        "go to the neighbour; back; other nodes",
    ),
    bind(
        C::Panes,
        &[(ch('f'), A::Actions)],
        "f",
        "framed actions and their matches (S_goal)",
    ),
    bind(
        C::Panes,
        &[(ch('H'), A::History)],
        "H",
        "run history: space marks, c compares, Enter loads the plan",
    ),
    bind(
        C::Panes,
        &[(ch('i'), A::ToggleImage)],
        "i",
        "scene image on or off (for slow links)",
    ),
    bind(
        C::Panes,
        &[(ch('t'), A::NextTheme)],
        "t",
        "next theme (NO_COLOR turns colour off)",
    ),
    hinted(
        bind(
            C::Picker,
            &[
                (key(KeyCode::Up), A::Move(-1)),
                (key(KeyCode::Down), A::Move(1)),
                (ch('k'), A::Move(-1)),
                (ch('j'), A::Move(1)),
            ],
            "↑↓ j k (choosing)",
            "move",
        ),
        "↑↓",
        "move",
    ),
    hinted(
        bind(
            C::Picker,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (choosing)",
            "choose",
        ),
        "Enter",
        "chooses",
    ),
    hinted(
        bind(
            C::Picker,
            &[(key(KeyCode::Esc), A::Leave), (ch('q'), A::Leave)],
            "Esc q (choosing)",
            "close",
        ),
        "Esc",
        "closes",
    ),
    hinted(
        bind(
            C::History,
            &[
                (key(KeyCode::Up), A::Move(-1)),
                (key(KeyCode::Down), A::Move(1)),
                (ch('k'), A::Move(-1)),
                (ch('j'), A::Move(1)),
            ],
            "↑↓ j k (run history)",
            "move",
        ),
        "↑↓",
        "move",
    ),
    hinted(
        bind(
            C::History,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (run history)",
            "load the run's plan",
        ),
        "Enter",
        "loads the plan",
    ),
    hinted(
        bind(
            C::History,
            &[(ch(' '), A::MarkRun), (ch('m'), A::MarkRun)],
            "space m (run history)",
            "mark the run for comparison",
        ),
        "space",
        "marks",
    ),
    hinted(
        bind(
            C::History,
            &[(ch('c'), A::CompareRuns)],
            "c (run history)",
            "compare the marked run with this one",
        ),
        "c",
        "compares",
    ),
    hinted(
        bind(
            C::History,
            &[(key(KeyCode::Esc), A::Leave), (ch('q'), A::Leave)],
            "Esc q (run history)",
            "close",
        ),
        "Esc",
        "closes",
    ),
    hinted(
        bind(
            C::PathPrompt,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (step file path)",
            "load the step file",
        ),
        "Enter",
        "loads",
    ),
    hinted(
        bind(
            C::PathPrompt,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (step file path)",
            "cancel",
        ),
        "Esc",
        "cancels",
    ),
    hinted(
        bind(
            C::ModelForm,
            &[
                (key(KeyCode::Tab), A::NextField),
                (key(KeyCode::Down), A::NextField),
            ],
            "Tab ↓ (model form)",
            "next field",
        ),
        "Tab",
        "next field",
    ),
    hinted(
        bind(
            C::ModelForm,
            &[
                (key(KeyCode::BackTab), A::PreviousField),
                (key(KeyCode::Up), A::PreviousField),
            ],
            "Shift-Tab ↑ (model form)",
            "previous field",
        ),
        "Shift-Tab",
        "previous",
    ),
    hinted(
        bind(
            C::ModelForm,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (model form)",
            "save the settings",
        ),
        "Enter",
        "saves",
    ),
    hinted(
        bind(
            C::ModelForm,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (model form)",
            "cancel",
        ),
        "Esc",
        "cancels",
    ),
    hinted(
        bind(
            C::Viewer,
            &[
                (key(KeyCode::Esc), A::Leave),
                (ch('q'), A::Leave),
                (key(KeyCode::Enter), A::Leave),
            ],
            "Esc q Enter (actions, comparison)",
            "close",
        ),
        "Esc",
        "closes",
    ),
    hinted(
        bind(
            C::AnnotateRating,
            &[
                (ch('1'), A::Rate(1)),
                (ch('2'), A::Rate(2)),
                (ch('3'), A::Rate(3)),
                (ch('4'), A::Rate(4)),
                (ch('5'), A::Rate(5)),
            ],
            "1–5",
            "rate the plan (the scale is on screen), save, next",
        ),
        "1–5",
        "rate",
    ),
    hinted(
        bind(
            C::AnnotatePairwise,
            &[(ch('1'), A::Prefer(Preference::Left))],
            "1",
            "the left plan is better; save, next",
        ),
        "1",
        "left",
    ),
    hinted(
        bind(
            C::AnnotatePairwise,
            &[(ch('2'), A::Prefer(Preference::Right))],
            "2",
            "the right plan is better; save, next",
        ),
        "2",
        "right",
    ),
    hinted(
        bind(
            C::AnnotatePairwise,
            &[(ch('0'), A::Prefer(Preference::Neither))],
            "0",
            "neither is better; save, next",
        ),
        "0",
        "neither",
    ),
    hinted(
        bind(
            C::AnnotateRating,
            &[
                (key(KeyCode::Down), A::Move(1)),
                (ch('j'), A::Move(1)),
                (key(KeyCode::Up), A::Move(-1)),
                (ch('k'), A::Move(-1)),
            ],
            "↓ j, ↑ k",
            "select the next or previous step",
        ),
        "↑↓",
        "step",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('o'), A::Label(StepLabelKind::Ok))],
        "o",
        "label the step: ok",
    ),
    hinted(
        bind(
            C::AnnotateRating,
            &[(ch('w'), A::Label(StepLabelKind::WrongObject))],
            "w",
            "label the step: wrong object",
        ),
        "w a r m x ! o",
        "label",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('a'), A::Label(StepLabelKind::WrongAction))],
        "a",
        "label the step: wrong action",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('r'), A::Label(StepLabelKind::WrongOrder))],
        "r",
        "label the step: wrong order",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('m'), A::Label(StepLabelKind::MissingStepBefore))],
        "m",
        "label the step: missing step before",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('x'), A::Label(StepLabelKind::Unnecessary))],
        "x",
        "label the step: unnecessary",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('!'), A::Label(StepLabelKind::Unsafe))],
        "!",
        "label the step: unsafe",
    ),
    bind(
        C::AnnotateRating,
        &[
            (key(KeyCode::Backspace), A::ClearLabel),
            (key(KeyCode::Delete), A::ClearLabel),
        ],
        "Backspace, Delete",
        "take the label off the step",
    ),
    hinted(
        bind(
            C::Annotate,
            &[(ch('e'), A::WriteNote)],
            "e",
            "write a note (Enter keeps it, Esc drops the change)",
        ),
        "e",
        "note",
    ),
    hinted(
        bind(
            C::Annotate,
            &[
                (key(KeyCode::Right), A::NextItem),
                (ch('n'), A::NextItem),
                (key(KeyCode::Left), A::PreviousItem),
                (ch('p'), A::PreviousItem),
            ],
            "→ n, ← p",
            "next or previous item",
        ),
        "→ ←",
        "move",
    ),
    bind(
        C::Annotate,
        &[(key(KeyCode::Tab), A::NextUnjudged)],
        "Tab",
        "next item not judged yet",
    ),
    hinted(
        bind(
            C::Annotate,
            &[(ch('s'), A::SkipItem)],
            "s",
            "skip: leave this one for later",
        ),
        "s",
        "skip",
    ),
    hinted(
        bind(
            C::Annotate,
            &[(ch('u'), A::Undo)],
            "u",
            "undo the last judgement (it is withdrawn)",
        ),
        "u",
        "undo",
    ),
    hinted(
        bind(C::Annotate, &[(ch('?'), A::Help)], "?", "this help"),
        "?",
        "keys",
    ),
    hinted(
        bind(
            C::Annotate,
            &[(ch('q'), A::Quit), (key(KeyCode::Esc), A::Quit)],
            "q, Esc",
            "quit (every judgement is already saved)",
        ),
        "q",
        "quit",
    ),
    hinted(
        bind(
            C::AnnotateNote,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (writing a note)",
            "keep the note; it is saved with the judgement",
        ),
        "Enter",
        "keeps the note",
    ),
    hinted(
        bind(
            C::AnnotateNote,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (writing a note)",
            "drop the change to the note",
        ),
        "Esc",
        "drops the change",
    ),
    bind(
        C::Panes,
        &[],
        "mouse",
        "click focuses and selects; the wheel scrolls",
    ),
];

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
}
