//! The annotation screen over every item of `mapvlm corrupt --dataset
//! alfred30 --seed 7`, through its real `update` and drawing on ratatui's
//! test backend, at 80 × 24 and 60 × 20, rating (plain and `--show-gt`)
//! and pairwise: moving the selection to each step shows that step's whole
//! text on screen, and a label can be given to it (issue 22). Nothing on
//! screen may be hidden without a sign, and no step may be labelled unseen.

use crate::common;

use std::path::Path;
use std::time::Duration;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

use mapvlm::annotate::guidelines::Guidelines;
use mapvlm::annotate::order::Unit;
use mapvlm::annotate::{Annotations, StepLabelKind};
use mapvlm::dataset::{open_pairs, Pair};
use mapvlm::workbench::annotate::state::{Clock, Judging, Msg, Setup};
use mapvlm::workbench::annotate::view;
use mapvlm::workbench::theme::Theme;

/// The items of `corrupt --dataset alfred30 --seed 7`, made with the real
/// binary and models.
fn corrupted_items(dir: &Path) -> Vec<Pair> {
    let out = dir.join("items.jsonl");
    let dataset = common::shared().join("data/alfred30");
    let run = common::mapvlm(&[
        "corrupt",
        "--dataset",
        &dataset.to_string_lossy(),
        "--seed",
        "7",
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let items: Vec<Pair> = open_pairs(&out)
        .unwrap()
        .map(|line| line.unwrap_or_else(|e| panic!("{e}")))
        .collect();
    assert!(items.len() > 200, "only {} items", items.len());
    items
}

fn screen(items: &[Pair], pairwise: bool, show_gt: bool, size: (u16, u16)) -> Judging {
    let setup = Setup {
        items: items.to_vec(),
        items_dir: "/nowhere".into(),
        annotator: "ana".into(),
        pairwise,
        show_gt,
        guidelines: Guidelines::built_in(),
        existing: Annotations::default(),
        skipped: Default::default(),
        notices: vec![],
    };
    let (mut s, _) = Judging::new(
        setup,
        Clock {
            elapsed: Duration::ZERO,
            unix: 1_700_000_000,
        },
    );
    s.update(Msg::Resize(size.0, size.1));
    s
}

fn press(s: &mut Judging, c: char) {
    s.update(Msg::Key(KeyEvent::new(
        KeyCode::Char(c),
        KeyModifiers::NONE,
    )));
}

/// The screen's cells, row by row.
fn rows(s: &Judging) -> Vec<Vec<String>> {
    let (w, h) = s.size.unwrap();
    let mut terminal = Terminal::new(TestBackend::new(w, h)).unwrap();
    let theme = Theme::no_color();
    terminal
        .draw(|f| {
            let area = f.area();
            view::draw(f, area, s, &theme);
        })
        .unwrap();
    let buffer = terminal.backend().buffer();
    (0..h)
        .map(|y| {
            (0..w)
                .map(|x| buffer[(x, y)].symbol().to_string())
                .collect()
        })
        .collect()
}

/// The rows inside the framed pane whose title starts with `title`;
/// `None` when no such pane is drawn.
fn pane(rows: &[Vec<String>], title: &str) -> Option<Vec<String>> {
    let wanted: Vec<String> = title.chars().map(|c| c.to_string()).collect();
    for (y, row) in rows.iter().enumerate() {
        let Some(x) = (0..row.len()).find(|&x| row[x..].starts_with(&wanted)) else {
            continue;
        };
        let left = (0..x).rev().find(|&i| row[i] == "┌")?;
        let right = (x..row.len()).find(|&i| row[i] == "┐")?;
        let mut text = Vec::new();
        for below in &rows[y + 1..] {
            if below[left] == "└" {
                break;
            }
            text.push(below[left + 1..right].concat());
        }
        return Some(text);
    }
    None
}

fn collapse(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Asserts that in each of `panes` (title, steps, 0-based step) the step
/// is selected and can be read whole: at once, or, when it is taller than
/// the pane, by ↓ scrolling inside it (one line a press) without the
/// selection moving on.
fn read_whole(s: &mut Judging, panes: &[(&str, &[String], usize)], what: &str) {
    let shown = |s: &Judging| -> Vec<Vec<String>> {
        let rows = rows(s);
        panes
            .iter()
            .map(|(title, ..)| {
                pane(&rows, title).unwrap_or_else(|| panic!("{what}: no pane {title}"))
            })
            .collect()
    };
    let wanted: Vec<String> = panes
        .iter()
        .map(|(_, steps, n)| collapse(&format!("▸ {}. {}", n + 1, steps[*n])))
        .collect();
    let mut last = shown(s);
    let mut seen = last.clone();
    for _ in 0..100 {
        let read = seen
            .iter()
            .zip(&wanted)
            .all(|(rows, w)| collapse(&rows.join(" ")).contains(w.as_str()));
        if read {
            return;
        }
        let before = (s.step, s.reference_step);
        press(s, 'j');
        assert_eq!(
            (s.step, s.reference_step),
            before,
            "{what}: the selection moved on before its step was read whole: {wanted:?}\n{}",
            rows(s)
                .iter()
                .map(|r| r.concat())
                .collect::<Vec<_>>()
                .join("\n")
        );
        for (i, now) in shown(s).into_iter().enumerate() {
            if now != last[i] {
                seen[i].extend(now.last().cloned());
                last[i] = now;
            }
        }
    }
    panic!("{what}: {wanted:?} never read whole");
}

/// Walks every single item: every step shown whole as ↓ reaches it, then
/// every step labelled (a label moves the selection on), and with the
/// reference plan shown, every step of it reached with `g` and ↓.
fn walk_rating(items: &[Pair], show_gt: bool, size: (u16, u16)) -> usize {
    let mut s = screen(items, false, show_gt, size);
    let mut steps_seen = 0;
    for pos in 0..s.units.len() {
        let what = format!("item {} at {size:?}, reference {show_gt}", pos + 1);
        assert_eq!(s.pos, pos, "{what}");
        let Unit::Single(i) = s.units[pos] else {
            panic!("a pair on the rating screen")
        };
        let plan = items[i].pred.clone();
        // j walks the steps one at a time (scrolling through a long one
        // first); each is read whole below, with its label, where a label
        // makes it longer.
        for n in 0..plan.len().saturating_sub(1) {
            for _ in 0..100 {
                if s.step != n {
                    break;
                }
                press(&mut s, 'j');
            }
            assert_eq!(s.step, n + 1, "{what}");
        }
        s.update(Msg::Key(KeyEvent::new(KeyCode::Home, KeyModifiers::NONE)));
        for n in 0..plan.len() {
            assert_eq!(s.step, n, "{what}");
            read_whole(&mut s, &[("Plan (", &plan, n)], &what);
            press(&mut s, 'w');
            assert_eq!(
                s.draft.labels.get(&n),
                Some(&StepLabelKind::WrongObject),
                "{what}: step {} not labelled",
                n + 1
            );
            steps_seen += 1;
        }
        if show_gt {
            let gt = items[i].gt.clone();
            press(&mut s, 'g');
            for n in 0..gt.len() {
                assert_eq!(s.reference_step, n, "{what}");
                read_whole(&mut s, &[("Reference plan (", &gt, n)], &what);
                press(&mut s, 'j');
            }
            press(&mut s, 'g');
        }
        press(&mut s, 'n');
    }
    steps_seen
}

/// Walks every pair: both plans' steps shown whole as the shared selection
/// reaches them.
fn walk_pairwise(items: &[Pair], size: (u16, u16)) -> usize {
    let mut s = screen(items, true, false, size);
    assert!(!s.units.is_empty());
    let mut steps_seen = 0;
    for pos in 0..s.units.len() {
        let what = format!("pair {} at {size:?}", pos + 1);
        assert_eq!(s.pos, pos, "{what}");
        let Unit::Pair(l, r) = s.units[pos] else {
            panic!("a single item on the pairwise screen")
        };
        let (left, right) = (items[l].pred.clone(), items[r].pred.clone());
        for n in 0..left.len().max(right.len()) {
            assert_eq!(s.step, n, "{what}");
            // A side shorter than the other stays on its last step, read
            // already.
            let sides: Vec<(&str, &[String], usize)> =
                [("Left plan", &left), ("Right plan", &right)]
                    .into_iter()
                    .filter(|(_, steps)| n < steps.len())
                    .map(|(title, steps)| (title, steps.as_slice(), n))
                    .collect();
            read_whole(&mut s, &sides, &what);
            press(&mut s, 'j');
            steps_seen += 1;
        }
        press(&mut s, 'n');
    }
    steps_seen
}

#[test]
fn every_step_of_every_corrupted_item_can_be_read_whole_and_labelled_at_80x24_and_60x20() {
    let dir = tempfile::tempdir().unwrap();
    let items = corrupted_items(dir.path());
    let total_steps: usize = items.iter().map(|i| i.pred.len()).sum();
    for size in [(80, 24), (60, 20)] {
        for show_gt in [false, true] {
            assert_eq!(walk_rating(&items, show_gt, size), total_steps);
        }
        assert!(walk_pairwise(&items, size) > 0);
    }
}

#[test]
fn below_the_minimum_size_the_screen_says_so_and_takes_no_judgement() {
    let mut item = Pair::new(
        "a".to_string(),
        vec!["Walk to the sink.".into()],
        vec!["Walk to the sink.".into(), "Turn the tap on.".into()],
    );
    item.task = Some("Wash a mug.".into());
    let items = vec![item];
    let mut s = screen(&items, false, false, (39, 15));
    let text: String = rows(&s).iter().map(|r| r.concat()).collect();
    assert!(text.contains("too small"), "{text}");
    assert!(!text.contains("Walk to the sink"), "{text}");
    press(&mut s, 'w');
    press(&mut s, '4');
    assert_eq!(
        s.judged(),
        0,
        "a rating given in a window too small to judge in"
    );
    assert!(
        s.draft.labels.is_empty(),
        "a label given to a step not shown"
    );
    s.update(Msg::Resize(80, 24));
    press(&mut s, '4');
    assert_eq!(s.judged(), 1);
}
