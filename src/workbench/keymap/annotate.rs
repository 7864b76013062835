//! The rows of the key table for the annotation screen (`mapvlm annotate`),
//! one binding a line, by context, in the order its help and its status
//! bar list them (the help and the quitting hints last: the status bar
//! keeps the last two when it is short of room).

use super::row::row;
use super::{Action, Binding, Context};
use crate::annotate::{Preference, StepLabelKind};

use Action as A;
use Context as C;
use StepLabelKind as L;

/// Every binding of the annotation screen.
#[rustfmt::skip]
pub(super) const ANNOTATE: &[Binding] = &[
    row(C::AnnotateRating, "1", A::Rate(1), "rate the plan 1 on the scale, save, next").hint("rate"),
    row(C::AnnotateRating, "2", A::Rate(2), "rate the plan 2 on the scale, save, next").hint("rate"),
    row(C::AnnotateRating, "3", A::Rate(3), "rate the plan 3 on the scale, save, next").hint("rate"),
    row(C::AnnotateRating, "4", A::Rate(4), "rate the plan 4 on the scale, save, next").hint("rate"),
    row(C::AnnotateRating, "5", A::Rate(5), "rate the plan 5 on the scale, save, next").hint("rate"),
    row(C::AnnotateRating, "<Up> k", A::Move(-1), "the step above; a long plan scrolls to it, a long step scrolls inside itself (also the mouse wheel)").hint("step"),
    row(C::AnnotateRating, "<Down> j", A::Move(1), "the step below").hint("step"),
    row(C::AnnotateRating, "<PgUp>", A::Move(-10), "a page of steps up"),
    row(C::AnnotateRating, "<PgDn>", A::Move(10), "a page of steps down"),
    row(C::AnnotateRating, "<C-d>", A::HalfPage(1), "half a page of steps down"),
    row(C::AnnotateRating, "<C-u>", A::HalfPage(-1), "half a page of steps up"),
    row(C::AnnotateRating, "<Home>", A::Move(isize::MIN), "the first step"),
    row(C::AnnotateRating, "<End>", A::Move(isize::MAX), "the last step"),
    row(C::AnnotateRating, "o", A::Label(L::Ok), "label the step: ok. Every label moves the selection on to the next step; the same label again takes it off").hint("label"),
    row(C::AnnotateRating, "w", A::Label(L::WrongObject), "label the step: wrong object").hint("label"),
    row(C::AnnotateRating, "a", A::Label(L::WrongAction), "label the step: wrong action").hint("label"),
    row(C::AnnotateRating, "r", A::Label(L::WrongOrder), "label the step: wrong order").hint("label"),
    row(C::AnnotateRating, "m", A::Label(L::MissingStepBefore), "label the step: missing step before").hint("label"),
    row(C::AnnotateRating, "x", A::Label(L::Unnecessary), "label the step: unnecessary").hint("label"),
    row(C::AnnotateRating, "!", A::Label(L::Unsafe), "label the step: unsafe").hint("label"),
    row(C::AnnotateRating, "<Backspace> <Delete>", A::ClearLabel, "take the label off the step"),

    row(C::AnnotatePairwise, "1", A::Prefer(Preference::Left), "the left plan is better; save, next").hint("left"),
    row(C::AnnotatePairwise, "2", A::Prefer(Preference::Right), "the right plan is better; save, next").hint("right"),
    row(C::AnnotatePairwise, "0", A::Prefer(Preference::Neither), "neither is better; save, next").hint("neither"),
    row(C::AnnotatePairwise, "<Up> k", A::Move(-1), "up a step in both plans; long plans scroll (also the mouse wheel)").hint("steps"),
    row(C::AnnotatePairwise, "<Down> j", A::Move(1), "down a step in both plans").hint("steps"),
    row(C::AnnotatePairwise, "<PgUp>", A::Move(-10), "a page up in both plans"),
    row(C::AnnotatePairwise, "<PgDn>", A::Move(10), "a page down in both plans"),
    row(C::AnnotatePairwise, "<C-d>", A::HalfPage(1), "half a page down in both plans"),
    row(C::AnnotatePairwise, "<C-u>", A::HalfPage(-1), "half a page up in both plans"),
    row(C::AnnotatePairwise, "<Home>", A::Move(isize::MIN), "the first steps"),
    row(C::AnnotatePairwise, "<End>", A::Move(isize::MAX), "the last steps"),

    row(C::AnnotateReference, "g", A::NextPane, "move in the reference plan (the keys that move then scroll it), or back in the plan").hint("reference"),

    row(C::Annotate, "e", A::WriteNote, "write or change the note of the judgement").hint("note"),
    row(C::Annotate, "<Left> p", A::PreviousItem, "the previous item").hint("move"),
    row(C::Annotate, "<Right> n", A::NextItem, "the next item").hint("move"),
    row(C::Annotate, "<Tab>", A::NextUnjudged, "the next item not judged yet"),
    row(C::Annotate, "s", A::SkipItem, "skip: leave this one for last (kept for the next sitting too)").hint("skip"),
    row(C::Annotate, "u", A::Undo, "undo the last change you saved: what was there before comes back (a first judgement is withdrawn)").hint("undo"),
    row(C::Annotate, "?", A::Help, "this help").hint("keys"),
    row(C::Annotate, "q <Esc>", A::Quit, "quit (every judgement is already saved)").hint("quit"),

    row(C::AnnotateNote, "<Enter>", A::Accept, "keep the note; it is saved with the judgement").hint("keeps the note"),
    row(C::AnnotateNote, "<Esc>", A::Leave, "drop the change to the note").hint("drops the change"),

    row(C::AnnotateHelp, "<Up> k", A::Move(-1), "up a line (the mouse wheel scrolls too)").hint("scroll"),
    row(C::AnnotateHelp, "<Down> j", A::Move(1), "down a line").hint("scroll"),
    row(C::AnnotateHelp, "<PgUp>", A::Move(-10), "up a page").hint("scroll"),
    row(C::AnnotateHelp, "<PgDn>", A::Move(10), "down a page").hint("scroll"),
    row(C::AnnotateHelp, "<C-d>", A::HalfPage(1), "down half a page").hint("scroll"),
    row(C::AnnotateHelp, "<C-u>", A::HalfPage(-1), "up half a page").hint("scroll"),
    row(C::AnnotateHelp, "<Home>", A::Move(isize::MIN), "to the top").hint("scroll"),
    row(C::AnnotateHelp, "<End>", A::Move(isize::MAX), "to the end").hint("scroll"),
    row(C::AnnotateHelp, "<Esc> q", A::Leave, "close this help (so does any key not listed here)").hint("closes"),
];
