//! End to end: `mapvlm annotate` on the real binary, in tmux as a person
//! would use it, and its answers to bad input.

use crate::common;

use common::tmux::{wait, Tmux};

use std::path::{Path, PathBuf};
use std::process::Command;

use mapvlm::annotate::order::{single_units, Unit};
use mapvlm::annotate::{Annotations, Subject};
use mapvlm::dataset::Pair;

/// Opens the annotation screen in a new session `name`; `exec` makes the
/// pane's process mapvlm itself, so it can be killed. HOME and the cache
/// folder are the test's own.
fn open(tmux: &Tmux, name: &str, dir: &Path, args: &str) {
    let command = format!(
        "exec env -u NO_COLOR TERM=xterm-256color HOME={home} XDG_CACHE_HOME={home}/.cache {} annotate {args}",
        env!("CARGO_BIN_EXE_mapvlm"),
        home = dir.display(),
    );
    tmux.open(name, 160, 40, &command);
}

fn items() -> Vec<Pair> {
    [
        "Heat a mug.",
        "Wash an apple.",
        "Open the box.",
        "Put a pen away.",
    ]
    .iter()
    .enumerate()
    .map(|(n, task)| {
        let mut item = Pair::new(
            format!("item-{n}"),
            vec!["Walk to the counter.".into()],
            vec!["Walk to the counter.".into(), format!("Do step {n}.")],
        );
        item.task = Some(task.to_string());
        item.image = Some("images/missing.png".into());
        item
    })
    .collect()
}

fn write_items(dir: &Path, extra: &str) -> PathBuf {
    let path = dir.join("items.jsonl");
    let mut text: String = items()
        .iter()
        .map(|i| serde_json::to_string(i).unwrap() + "\n")
        .collect();
    text.push_str(extra);
    std::fs::write(&path, text).unwrap();
    path
}

fn lines_of(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |t| t.lines().count())
}

#[test]
fn first_key_rates_undo_withdraws_and_a_killed_session_resumes_at_the_withdrawn_item() {
    let dir = tempfile::tempdir().unwrap();
    let items_path = write_items(dir.path(), "{not an item\n");
    let ann = dir.path().join("items.annotations.jsonl");
    std::fs::write(&ann, "{\"broken\": \n").unwrap();
    let order: Vec<String> = single_units(&items(), "ana")
        .into_iter()
        .map(|u| match u {
            Unit::Single(i) | Unit::Pair(i, _) => format!("item-{i}"),
        })
        .collect();
    let args = format!("{} --annotator ana", items_path.display());
    let tmux = Tmux::new("annotate-resume");
    // Keeps the server up while no screen is open (between kill and reopen).
    tmux.cmd(&["new-session", "-d", "-s", "keep", "sleep 300"]);
    open(&tmux, "one", dir.path(), &args);
    // A missing image is said in its place, judging goes on, and the bad
    // items line is named. The wait covers every string asserted, so a
    // frame captured half drawn (before the status line) is never judged.
    tmux.wait_for("one", "the first item with the bad line named", |s| {
        s.contains("Item 1 of 4") && s.contains("cannot") && s.contains("(first: line 5)")
    });

    // The very first key after start rates the first item.
    tmux.keys("one", &["4"]);
    wait("the first rating on disk", || {
        (lines_of(&ann) == 2)
            .then_some(())
            .ok_or(tmux.screen("one"))
    });
    tmux.wait_for("one", "the second item", |s| s.contains("Item 2 of 4"));
    tmux.keys("one", &["3"]);
    tmux.wait_for("one", "the third item", |s| s.contains("Item 3 of 4"));
    tmux.keys("one", &["5"]);
    tmux.wait_for("one", "the fourth item", |s| s.contains("Item 4 of 4"));
    tmux.keys("one", &["u"]);
    tmux.wait_for("one", "back at the third", |s| {
        s.contains("Item 3 of 4") && s.contains("2/4 judged")
    });
    wait("the withdrawal on disk", || {
        (lines_of(&ann) == 5)
            .then_some(())
            .ok_or(tmux.screen("one"))
    });
    let pid = tmux
        .cmd(&["display-message", "-p", "-t", "one", "#{pane_pid}"])
        .trim()
        .to_string();
    let killed = Command::new("kill").args(["-9", &pid]).status().unwrap();
    assert!(killed.success());

    let read = Annotations::load(&ann).unwrap();
    assert_eq!(read.errors.len(), 1, "the broken line is kept as it was");
    let lines: Vec<_> = read.lines.iter().map(|(_, j)| j).collect();
    assert_eq!(lines.len(), 4);
    let ratings: Vec<_> = lines
        .iter()
        .map(|j| (j.subject.clone(), j.verdict.as_ref().and_then(|v| v.rating)))
        .collect();
    let item = |n: usize| Subject::Item(order[n].clone());
    assert_eq!(
        ratings,
        [
            (item(0), Some(4)),
            (item(1), Some(3)),
            (item(2), Some(5)),
            (item(2), None)
        ]
    );
    assert!(lines[3].verdict.is_none(), "the last line is a withdrawal");

    open(&tmux, "two", dir.path(), &args);
    tmux.wait_for("two", "judging resumes at the withdrawn item", |s| {
        s.contains("Item 3 of 4") && s.contains("2/4 judged")
    });
    tmux.keys("two", &["2"]);
    wait("the new rating on disk", || {
        (lines_of(&ann) == 6)
            .then_some(())
            .ok_or(tmux.screen("two"))
    });
    tmux.keys("two", &["q"]);
    wait("mapvlm to quit", || {
        (!tmux.cmd(&["list-sessions"]).contains("two:"))
            .then_some(())
            .ok_or(tmux.screen("two"))
    });
    let current = Annotations::load(&ann).unwrap().current();
    assert_eq!(current.ratings().count(), 3);
}

fn mapvlm(args: &[&str]) -> (bool, String) {
    let out = common::mapvlm_command()
        .arg("annotate")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_input_gets_one_clear_line_and_loses_no_judgement() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.jsonl");
    std::fs::write(&empty, "{\"id\": \"a\", \"gt\": [\"A.\"], \"pred\": []}\n").unwrap();
    let (ok, err) = mapvlm(&[empty.to_str().unwrap(), "--annotator", "ana"]);
    assert!(!ok);
    assert!(err.contains("no plans to judge"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");

    let items = write_items(dir.path(), "");
    let ann = dir.path().join("items.annotations.jsonl");
    let kept = "{\"item\": \"item-1\", \"annotator\": \"bo\", \"rating\": 2, \"at\": 1}\n";
    std::fs::write(&ann, kept).unwrap();
    let guide = dir.path().join("guide.png");
    std::fs::write(&guide, [0x89, b'P', b'N', b'G', 0, 0xff]).unwrap();
    let (ok, err) = mapvlm(&[
        items.to_str().unwrap(),
        "--annotator",
        "ana",
        "--guidelines",
        guide.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("guide.png") && err.contains("not UTF-8 text"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(
        std::fs::read_to_string(&ann).unwrap(),
        kept,
        "no judgement lost"
    );

    // --export: the golden file's current judgements, a bad line named.
    let golden = common::shared().join("golden/agree.dev.annotations.jsonl");
    let with_bad = dir.path().join("ann.jsonl");
    let mut text = std::fs::read_to_string(&golden).unwrap();
    text.push_str("{\"item\": 3}\n");
    std::fs::write(&with_bad, &text).unwrap();
    let csv = dir.path().join("out.csv");
    let (ok, err) = mapvlm(&[
        "--out",
        with_bad.to_str().unwrap(),
        "--export",
        csv.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("ann.jsonl:386:"), "{err}");
    let rows = std::fs::read_to_string(&csv).unwrap();
    let current = Annotations::load(&golden).unwrap().current();
    assert_eq!(rows.lines().count(), current.judgements().len() + 1);
    assert!(rows.starts_with("item,left,right,annotator,rating,"));
}
