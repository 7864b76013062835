//! What the annotation screen's tests start from: six items of three tasks
//! and a screen opened on them at a fixed time.

use std::path::PathBuf;
use std::time::Duration;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

use super::state::{Clock, Cmd, Judging, Msg, Setup};
use crate::annotate::guidelines::Guidelines;
use crate::annotate::{Annotations, Judgement};
use crate::dataset::Pair;

/// Six items of three tasks: an original and a changed copy each.
pub(crate) fn items() -> Vec<Pair> {
    let mut out = Vec::new();
    for (t, task) in [
        "Put a mug in the sink.",
        "Heat an apple.",
        "Put a pen in a box.",
    ]
    .into_iter()
    .enumerate()
    {
        let gt = vec![
            "Walk to the counter.".to_string(),
            "Pick up the thing.".into(),
        ];
        let mut original = Pair::new(
            format!("task{t}/multi_agent_image"),
            gt.clone(),
            vec![
                "Walk to the counter.".into(),
                "Pick up the thing.".into(),
                "Put it where it goes.".into(),
            ],
        );
        original.task = Some(task.into());
        let mut copy = original.clone();
        copy.id = format!("{}~object-swap", original.id);
        copy.source = Some(original.id.clone());
        copy.pred[1] = "Pick up the bread.".into();
        out.push(original);
        out.push(copy);
    }
    out
}

pub(crate) fn setup(pairwise: bool, existing: Annotations) -> Setup {
    Setup {
        items: items(),
        items_dir: PathBuf::from("/nowhere"),
        annotator: "ana".into(),
        pairwise,
        show_gt: false,
        guidelines: Guidelines::built_in(),
        existing,
        skipped: Default::default(),
        notices: vec![],
    }
}

/// The screen opened at a fixed time in a 100 × 30 window.
pub(crate) fn open(setup: Setup) -> (Judging, Vec<Cmd>) {
    let clock = Clock {
        elapsed: Duration::ZERO,
        unix: 1_700_000_000,
    };
    let (mut screen, cmds) = Judging::new(setup, clock);
    screen.update(Msg::Resize(100, 30));
    (screen, cmds)
}

pub(crate) fn press(screen: &mut Judging, c: char) -> Vec<Cmd> {
    screen.update(Msg::Key(KeyEvent::new(
        KeyCode::Char(c),
        KeyModifiers::NONE,
    )))
}

pub(crate) fn appended(cmds: &[Cmd]) -> Vec<Judgement> {
    cmds.iter()
        .filter_map(|c| match c {
            Cmd::Append { judgement, .. } => Some((**judgement).clone()),
            Cmd::LoadImage(_) | Cmd::Skip { .. } => None,
        })
        .collect()
}
