//! The rows of the key table: every binding of the workbench, in the order
//! the help lists them (each row made with [`super::row`]'s constructors).

use crossterm::event::KeyCode;

use super::row::{bind, ch, ctrl, hinted, key, MOVE_KEYS, SCROLL_KEYS};
use super::{Action, Binding, Context};
use crate::workbench::graph_view::Direction;

use Action as A;
use Context as C;

/// Every binding of the workbench's panes and overlays, in the order the
/// help lists them.
pub(super) const WORKBENCH: &[Binding] = &[
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
            "run the agents whose inputs changed; all afresh, priced first",
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
        &[
            (ch('J'), A::StepDown),
            (ch('K'), A::StepUp),
            (ch('u'), A::Undo),
        ],
        "J, K, u (steps)",
        "move the selected step down or up; undo a step edit (200 deep)",
    ),
    bind(
        C::Plan,
        &[(ch('c'), A::Corrupt)],
        "c (plan)",
        "corrupt the plan into a new run (choose how); it is scored at once",
    ),
    bind(
        C::Panes,
        &[(ch('p'), A::PublishedPlan)],
        "p",
        "load the task's published plan for the approach",
    ),
    bind(
        C::Panes,
        &[(ch('a'), A::NextApproach), (ch('S'), A::NextSamples)],
        "a, S",
        "next approach (tables if the task has one); samples 1, 3, 5, 10",
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
    bind(
        C::Prompt,
        &[(ch('S'), A::SavePromptSet), (ch('L'), A::LoadPromptSet)],
        "S L (prompt)",
        "save prompts as a set; load one (asks before edits are lost)",
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
    bind(
        C::StepEditor,
        &[(ctrl('z'), A::Undo)],
        "Ctrl-Z (editing a step)",
        "undo the last change to the text",
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
        C::Panes,
        &[(ch('T'), A::GraphList)],
        "T",
        "the knowledge graph's triples as a list, or drawn again",
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
        &[(ch('M'), A::Messages)],
        "M",
        "message log: every status message so far, whole, with its time",
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
        bind(C::Picker, MOVE_KEYS, "↑↓ j k (choosing)", "move"),
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
        bind(C::History, MOVE_KEYS, "↑↓ j k (run history)", "move"),
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
            &[(ch('c'), A::CompareRuns), (ch('d'), A::CompareRuns)],
            "c d (run history)",
            "diff the marked run (or the one before) with this one",
        ),
        "d",
        "diffs",
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
            C::SetName,
            &[(key(KeyCode::Enter), A::Accept)],
            "Enter (prompt set name)",
            "save the prompts as this set",
        ),
        "Enter",
        "saves",
    ),
    hinted(
        bind(
            C::SetName,
            &[(key(KeyCode::Esc), A::Leave)],
            "Esc (prompt set name)",
            "cancel",
        ),
        "Esc",
        "cancels",
    ),
    hinted(
        bind(
            C::ModelForm,
            &[(ctrl('a'), A::EveryAgent)],
            "Ctrl-A (model form)",
            "save for every agent, or for this agent alone (toggle)",
        ),
        "Ctrl-A",
        "every agent",
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
            C::Help,
            SCROLL_KEYS,
            "↑↓ j k, PgUp PgDn, Home End (help)",
            "scroll this help (also the mouse wheel); any other key closes it",
        ),
        "↑↓ PgUp PgDn",
        "scroll · any other key closes",
    ),
    hinted(
        bind(
            C::Viewer,
            &[
                (key(KeyCode::Esc), A::Leave),
                (ch('q'), A::Leave),
                (key(KeyCode::Enter), A::Leave),
            ],
            "Esc q Enter (actions, messages)",
            "close",
        ),
        "Esc",
        "closes",
    ),
    hinted(
        bind(
            C::Viewer,
            SCROLL_KEYS,
            "↑↓ j k, PgUp PgDn, Home End (actions, messages)",
            "scroll (also the mouse wheel)",
        ),
        "↑↓",
        "scroll",
    ),
    hinted(
        bind(C::RunDiff, MOVE_KEYS, "↑↓ j k (run diff)", "scroll a line"),
        "↑↓",
        "scroll",
    ),
    hinted(
        bind(
            C::RunDiff,
            &[
                (key(KeyCode::PageUp), A::Move(-10)),
                (key(KeyCode::PageDown), A::Move(10)),
                (ch(' '), A::Move(10)),
                (key(KeyCode::Home), A::Move(isize::MIN)),
                (key(KeyCode::End), A::Move(isize::MAX)),
            ],
            "PgUp PgDn space Home End (run diff)",
            "scroll a page, to the top or the end",
        ),
        "PgDn",
        "pages",
    ),
    hinted(
        bind(
            C::RunDiff,
            &[(key(KeyCode::Esc), A::Leave), (ch('q'), A::Leave)],
            "Esc q (run diff)",
            "back to the run history",
        ),
        "Esc",
        "back",
    ),
    bind(
        C::Panes,
        &[],
        "mouse",
        "click focuses and selects; the wheel scrolls",
    ),
];
