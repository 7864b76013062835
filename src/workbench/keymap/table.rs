//! The rows of the key table for the workbench: one binding a line, by
//! context, in the order the help lists them (its sections follow the
//! contexts in the order they first appear here).

use super::row::row;
use super::{Action, Binding, Context};
use crate::workbench::graph_view::Direction;

use Action as A;
use Context as C;

/// Every binding of the workbench's panes, editors and overlays.
#[rustfmt::skip]
pub(super) const WORKBENCH: &[Binding] = &[
    row(C::Panes, "?", A::Help, "this help: every key, by where it works").hint("keys"),
    row(C::Panes, "<Tab> <Right> l", A::NextPane, "the next pane (a click focuses any pane)").hint("pane"),
    row(C::Panes, "<S-Tab> <Left> h", A::PreviousPane, "the previous pane"),
    row(C::Panes, "r", A::Run, "run the agents whose inputs changed").hint("run"),
    row(C::Panes, "R", A::RunAll, "run every agent afresh, priced first: the same key again sends it, any other keeps the cache"),
    row(C::Panes, "g", A::ChooseGroundTruth, "choose a ground truth: demo, dataset task, step file, or type one").hint("ground truth"),
    row(C::Panes, "q", A::Quit, "quit (the session is saved)").hint("quit"),
    row(C::Panes, "<Down> j", A::Move(1), "the next step or neighbour, or scroll down a line (a click selects, the wheel scrolls)"),
    row(C::Panes, "<Up> k", A::Move(-1), "the step or neighbour before, or scroll up a line"),
    row(C::Panes, "<PgDn>", A::Move(10), "ten steps or lines down"),
    row(C::Panes, "<PgUp>", A::Move(-10), "ten steps or lines up"),
    row(C::Panes, "<C-d>", A::HalfPage(1), "half the pane down"),
    row(C::Panes, "<C-u>", A::HalfPage(-1), "half the pane up"),
    row(C::Panes, "<Home>", A::Move(isize::MIN), "the first step, or the top"),
    row(C::Panes, "<End>", A::Move(isize::MAX), "the last step, or the end"),
    row(C::Panes, "<Esc>", A::Escape, "leave zoom, clear the search or the message"),
    row(C::Panes, "/", A::Search, "search every pane"),
    row(C::Panes, "n", A::NextHit, "jump to the next hit of the search"),
    row(C::Panes, "z", A::Zoom, "zoom the focused pane, or leave the zoom"),
    row(C::Panes, "p", A::PublishedPlan, "load the task's published plan for the approach"),
    row(C::Panes, "a", A::NextApproach, "the next approach (tables if the task has one)"),
    row(C::Panes, "S", A::NextSamples, "samples each agent is asked for per run: 1, 3, 5, 10"),
    row(C::Panes, "x", A::CancelRun, "cancel the run in flight"),
    row(C::Panes, "m", A::ModelForm, "provider, model, temperature and token limit of an agent"),
    row(C::Panes, "f", A::Actions, "framed actions and their matches (S_goal)"),
    row(C::Panes, "T", A::GraphList, "the knowledge graph's triples as a list, or drawn again"),
    row(C::Panes, "H", A::History, "run history: mark runs, diff two, load a run's plan"),
    row(C::Panes, "M", A::Messages, "message log: every status message so far, whole, with its time"),
    row(C::Panes, "i", A::ToggleImage, "scene image on or off (for slow links)"),
    row(C::Panes, "t", A::NextTheme, "the next theme (NO_COLOR turns colour off)"),

    row(C::Always, "<C-c>", A::Quit, "quit, also while editing"),

    row(C::Steps, "<Enter> e", A::EditStep, "edit the selected step"),
    row(C::Steps, "o", A::InsertAfter, "insert a step after the selected one"),
    row(C::Steps, "O", A::InsertBefore, "insert a step before the selected one"),
    row(C::Steps, "d <Delete>", A::DeleteStep, "delete the selected step"),
    row(C::Steps, "J", A::StepDown, "move the selected step down"),
    row(C::Steps, "K", A::StepUp, "move the selected step up"),
    row(C::Steps, "u", A::Undo, "undo a step edit (200 deep)"),

    row(C::Plan, "c", A::Corrupt, "corrupt the plan into a new run (choose how); it is scored at once"),

    row(C::Prompt, "<Enter> e", A::EditPrompt, "edit the prompt"),
    row(C::Prompt, "1", A::PromptOf(0), "the SKM's prompt"),
    row(C::Prompt, "2", A::PromptOf(1), "the GKM's prompt"),
    row(C::Prompt, "3", A::PromptOf(2), "the Planner's prompt"),
    row(C::Prompt, "<Right> l", A::PromptStep(1), "the next agent's prompt").overrides(),
    row(C::Prompt, "<Left> h", A::PromptStep(-1), "the previous agent's prompt").overrides(),
    row(C::Prompt, "S", A::SavePromptSet, "save the prompts as a named set").overrides(),
    row(C::Prompt, "L", A::LoadPromptSet, "load a prompt set (asks before edits are lost)"),

    row(C::WholeGraph, "<Left> h", A::GraphStep(Direction::Left), "the nearest node to the left").overrides(),
    row(C::WholeGraph, "<Right> l", A::GraphStep(Direction::Right), "the nearest node to the right").overrides(),
    row(C::WholeGraph, "<Up> k", A::GraphStep(Direction::Up), "the nearest node above").overrides(),
    row(C::WholeGraph, "<Down> j", A::GraphStep(Direction::Down), "the nearest node below").overrides(),
    row(C::WholeGraph, "]", A::GraphSelect(1), "the next node"),
    row(C::WholeGraph, "[", A::GraphSelect(-1), "the previous node"),
    row(C::WholeGraph, "+", A::GraphZoom(1), "zoom in"),
    row(C::WholeGraph, "-", A::GraphZoom(-1), "zoom out"),
    row(C::WholeGraph, "v", A::GraphMode, "one node's neighbourhood instead"),

    row(C::Graph, "<Enter> <Right> l", A::GraphEnter, "go to the selected neighbour").overrides(),
    row(C::Graph, "<Left> h <Backspace>", A::GraphBack, "back to the node before").overrides(),
    row(C::Graph, "]", A::GraphNode(1), "the next node"),
    row(C::Graph, "[", A::GraphNode(-1), "the previous node"),
    row(C::Graph, "v", A::GraphMode, "back to the whole graph"),

    row(C::StepEditor, "<Enter>", A::Accept, "keep the edit").hint("keeps"),
    row(C::StepEditor, "<Esc>", A::Leave, "cancel the edit").hint("cancels"),
    row(C::StepEditor, "<C-z>", A::Undo, "undo the last change to the text"),

    row(C::PromptEditor, "<Esc>", A::Leave, "done editing the prompt").hint("done"),
    row(C::PromptEditor, "<C-r> <F5>", A::RunFromEditor, "run the agents with the edited prompt").hint("runs"),

    row(C::Search, "<Enter>", A::Accept, "jump to the next hit").hint("jumps"),
    row(C::Search, "<Esc>", A::Leave, "clear the search").hint("clears"),

    row(C::Picker, "<Up> k", A::Move(-1), "the choice above").hint("move"),
    row(C::Picker, "<Down> j", A::Move(1), "the choice below").hint("move"),
    row(C::Picker, "<Enter>", A::Accept, "choose").hint("chooses"),
    row(C::Picker, "<Esc> q", A::Leave, "close").hint("closes"),

    row(C::History, "<Up> k", A::Move(-1), "the run above").hint("move"),
    row(C::History, "<Down> j", A::Move(1), "the run below").hint("move"),
    row(C::History, "<Enter>", A::Accept, "load the run's plan").hint("loads the plan"),
    row(C::History, "<Space> m", A::MarkRun, "mark the run for comparison, or unmark it").hint("marks"),
    row(C::History, "d c", A::CompareRuns, "diff the marked run (or the one before) with this one").hint("diffs"),
    row(C::History, "<Esc> q", A::Leave, "close").hint("closes"),

    row(C::RunDiff, "<Up> k", A::Move(-1), "up a line").hint("scroll"),
    row(C::RunDiff, "<Down> j", A::Move(1), "down a line").hint("scroll"),
    row(C::RunDiff, "<PgUp>", A::Move(-10), "up a page").hint("scroll"),
    row(C::RunDiff, "<PgDn> <Space>", A::Move(10), "down a page").hint("scroll"),
    row(C::RunDiff, "<C-d>", A::HalfPage(1), "down half a page").hint("scroll"),
    row(C::RunDiff, "<C-u>", A::HalfPage(-1), "up half a page").hint("scroll"),
    row(C::RunDiff, "<Home>", A::Move(isize::MIN), "to the top").hint("scroll"),
    row(C::RunDiff, "<End>", A::Move(isize::MAX), "to the end").hint("scroll"),
    row(C::RunDiff, "<Esc> q", A::Leave, "back to the run history").hint("back"),

    row(C::PathPrompt, "<Enter>", A::Accept, "load the step file").hint("loads"),
    row(C::PathPrompt, "<Esc>", A::Leave, "cancel").hint("cancels"),

    row(C::ModelForm, "<Tab> <Down>", A::NextField, "the next field").hint("next field"),
    row(C::ModelForm, "<S-Tab> <Up>", A::PreviousField, "the previous field").hint("previous"),
    row(C::ModelForm, "<Enter>", A::Accept, "save the settings").hint("saves"),
    row(C::ModelForm, "<C-a>", A::EveryAgent, "save for every agent, or for this agent alone (toggle)").hint("every agent"),
    row(C::ModelForm, "<Esc>", A::Leave, "cancel").hint("cancels"),

    row(C::SetName, "<Enter>", A::Accept, "save the prompts as this set").hint("saves"),
    row(C::SetName, "<Esc>", A::Leave, "cancel").hint("cancels"),

    row(C::Viewer, "<Up> k", A::Move(-1), "up a line (the mouse wheel scrolls too)").hint("scroll"),
    row(C::Viewer, "<Down> j", A::Move(1), "down a line").hint("scroll"),
    row(C::Viewer, "<PgUp>", A::Move(-10), "up a page").hint("scroll"),
    row(C::Viewer, "<PgDn>", A::Move(10), "down a page").hint("scroll"),
    row(C::Viewer, "<C-d>", A::HalfPage(1), "down half a page").hint("scroll"),
    row(C::Viewer, "<C-u>", A::HalfPage(-1), "up half a page").hint("scroll"),
    row(C::Viewer, "<Home>", A::Move(isize::MIN), "to the top").hint("scroll"),
    row(C::Viewer, "<End>", A::Move(isize::MAX), "to the end").hint("scroll"),
    row(C::Viewer, "<Esc> q <Enter>", A::Leave, "close").hint("closes"),

    row(C::Help, "<Up> k", A::Move(-1), "up a line (the mouse wheel scrolls too)").hint("scroll"),
    row(C::Help, "<Down> j", A::Move(1), "down a line").hint("scroll"),
    row(C::Help, "<PgUp>", A::Move(-10), "up a page").hint("scroll"),
    row(C::Help, "<PgDn>", A::Move(10), "down a page").hint("scroll"),
    row(C::Help, "<Home>", A::Move(isize::MIN), "to the top").hint("scroll"),
    row(C::Help, "<End>", A::Move(isize::MAX), "to the end").hint("scroll"),
    row(C::Help, "/", A::Search, "filter: type words to show only the keys they are found with").hint("filter"),
    row(C::Help, "<Esc> q", A::Leave, "close this help (so does any key not listed here)").hint("closes"),

    row(C::HelpFilter, "<Enter>", A::Accept, "keep the filter and scroll what it shows").hint("keeps"),
    row(C::HelpFilter, "<Esc>", A::Leave, "drop the filter: every key again").hint("drops"),
];
