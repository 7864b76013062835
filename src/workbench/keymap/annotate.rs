//! The rows of the key table for the annotation screen (`mapvlm annotate`),
//! in the order its help lists them.

use crossterm::event::KeyCode;

use super::row::{bind, ch, hinted, key, SCROLL_KEYS, SCROLL_LABEL};
use super::{Action, Binding, Context};
use crate::annotate::{Preference, StepLabelKind};

use Action as A;
use Context as C;

/// Every binding of the annotation screen.
pub(super) const ANNOTATE: &[Binding] = &[
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
            SCROLL_KEYS,
            SCROLL_LABEL,
            "select a step; a long plan scrolls to it, a long step scrolls inside itself (also the mouse wheel)",
        ),
        "↑↓",
        "step",
    ),
    hinted(
        bind(
            C::AnnotatePairwise,
            SCROLL_KEYS,
            SCROLL_LABEL,
            "move through the steps of both plans; long plans scroll (also the mouse wheel)",
        ),
        "↑↓",
        "steps",
    ),
    bind(
        C::AnnotateRating,
        &[(ch('o'), A::Label(StepLabelKind::Ok))],
        "o",
        "label the step: ok. Every label moves the selection on to the next step; the same label again takes it off",
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
            "skip: leave this one for last (kept for the next sitting too)",
        ),
        "s",
        "skip",
    ),
    hinted(
        bind(
            C::Annotate,
            &[(ch('u'), A::Undo)],
            "u",
            "undo the last change you saved: what was there before comes back (a first judgement is withdrawn)",
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
            C::AnnotateReference,
            &[(ch('g'), A::NextPane)],
            "g",
            "move in the reference plan (the keys above then scroll it), or back in the plan",
        ),
        "g",
        "reference",
    ),
    bind(
        C::AnnotateHelp,
        SCROLL_KEYS,
        "↑↓ j k, PgUp PgDn, Home End (help)",
        "scroll this help (also the mouse wheel); any other key closes it",
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
];
