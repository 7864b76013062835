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

#[test]
fn labels_after_a_rating_undo_a_formula_note_and_a_skip_are_kept_as_meant() {
    let dir = tempfile::tempdir().unwrap();
    let items_path = write_items(dir.path(), "");
    let ann = dir.path().join("items.annotations.jsonl");
    let skips = dir.path().join("items.annotations.skips.jsonl");
    let order: Vec<Subject> = single_units(&items(), "ana")
        .into_iter()
        .map(|u| match u {
            Unit::Single(i) | Unit::Pair(i, _) => Subject::Item(format!("item-{i}")),
        })
        .collect();
    let args = format!("{} --annotator ana", items_path.display());
    let tmux = Tmux::new("annotate-meant");
    tmux.cmd(&["new-session", "-d", "-s", "keep", "sleep 300"]);
    open(&tmux, "one", dir.path(), &args);
    tmux.wait_for("one", "the first item", |s| s.contains("Item 1 of 4"));
    let on_disk = |n: usize, what: &str| {
        wait(what, || {
            (lines_of(&ann) == n)
                .then_some(())
                .ok_or(tmux.screen("one"))
        })
    };

    // Labels and a note added after the rating: one line each, with it.
    tmux.keys("one", &["4"]);
    on_disk(1, "the rating on disk");
    tmux.wait_for("one", "the second item", |s| s.contains("Item 2 of 4"));
    tmux.keys("one", &["p"]);
    tmux.wait_for("one", "the first item, its rating in words", |s| {
        s.contains("Item 1 of 4") && s.contains("yours: 4 (Good)")
    });
    tmux.keys("one", &["w"]);
    on_disk(2, "the label saved with the rating");
    tmux.keys("one", &["e"]);
    tmux.wait_for("one", "the note editor", |s| {
        s.contains("Enter keeps the note")
    });
    tmux.keys("one", &["-l", "=HYPERLINK(\"http://x\")"]);
    tmux.keys("one", &["Enter"]);
    on_disk(3, "the note saved with the rating");

    // 3, then 4, then undo: back to 3.
    tmux.keys("one", &["n"]);
    tmux.wait_for("one", "the second item", |s| s.contains("Item 2 of 4"));
    tmux.keys("one", &["3"]);
    on_disk(4, "the second item rated 3");
    tmux.wait_for("one", "the third item", |s| s.contains("Item 3 of 4"));
    tmux.keys("one", &["p"]);
    tmux.wait_for("one", "the second item rated 3", |s| {
        s.contains("Item 2 of 4") && s.contains("yours: 3 (Fair)")
    });
    tmux.keys("one", &["4"]);
    on_disk(5, "the second item rated 4");
    tmux.wait_for("one", "the third item again", |s| s.contains("Item 3 of 4"));
    tmux.keys("one", &["u"]);
    on_disk(6, "the undo on disk");
    tmux.wait_for("one", "back at the second item, rated 3", |s| {
        s.contains("Item 2 of 4") && s.contains("yours: 3 (Fair)")
    });

    // A skip, then quit.
    tmux.keys("one", &["n"]);
    tmux.wait_for("one", "the third item", |s| s.contains("Item 3 of 4"));
    tmux.keys("one", &["s"]);
    tmux.wait_for("one", "the fourth item", |s| s.contains("Item 4 of 4"));
    wait("the skip on disk", || {
        (lines_of(&skips) == 1)
            .then_some(())
            .ok_or(tmux.screen("one"))
    });
    tmux.keys("one", &["q"]);
    wait("mapvlm to quit", || {
        (!tmux.cmd(&["list-sessions"]).contains("one:"))
            .then_some(())
            .ok_or(tmux.screen("one"))
    });

    // The file reads as annotate.md §3 says.
    let read = Annotations::load(&ann).unwrap();
    assert_eq!(read.errors.len(), 0);
    let lines: Vec<_> = read.lines.iter().map(|(_, j)| j.clone()).collect();
    assert_eq!(lines.len(), 6);
    assert_eq!(lines[5].subject, order[1]);
    assert_eq!(
        lines[5].verdict, lines[3].verdict,
        "the undo is a whole copy of the 3"
    );
    let current = read.current();
    let mut ratings: Vec<_> = current
        .ratings()
        .map(|(i, _, r)| (i.to_string(), r))
        .collect();
    ratings.sort();
    let mut wanted = vec![(order[0].to_string(), 4), (order[1].to_string(), 3)];
    wanted.sort();
    assert_eq!(ratings, wanted);
    let first = current
        .judgements()
        .iter()
        .find(|j| j.subject == order[0])
        .and_then(|j| j.verdict.clone())
        .unwrap();
    assert_eq!(first.note, "=HYPERLINK(\"http://x\")");
    assert_eq!(first.step_labels.len(), 1);
    assert_eq!(first.step_labels[0].step, 0);

    // Reopened: the skipped item is left for last, the labels are there.
    open(&tmux, "two", dir.path(), &args);
    tmux.wait_for("two", "the first item neither judged nor skipped", |s| {
        s.contains("Item 4 of 4") && s.contains("2/4 judged · 1 skipped")
    });
    tmux.keys("two", &["p", "p", "p"]);
    tmux.wait_for("two", "the first item with its label", |s| {
        s.contains("Item 1 of 4") && s.contains("[wrong object]") && s.contains("yours: 4")
    });
    tmux.keys("two", &["q"]);
    wait("mapvlm to quit", || {
        (!tmux.cmd(&["list-sessions"]).contains("two:"))
            .then_some(())
            .ok_or(tmux.screen("two"))
    });

    // The note cannot run as a formula in a spreadsheet; steps count from 1.
    let csv = dir.path().join("out.csv");
    let (ok, err) = mapvlm(&[
        "--out",
        ann.to_str().unwrap(),
        "--export",
        csv.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert!(
        rows.contains(",\"'=HYPERLINK(\"\"http://x\"\")\","),
        "{rows}"
    );
    assert!(rows.contains(",1:wrong object,"), "{rows}");
}

#[test]
fn every_signal_that_stops_annotate_restores_the_terminal_and_keeps_the_judgements() {
    for signal in ["INT", "QUIT", "TERM", "HUP"] {
        let dir = tempfile::tempdir().unwrap();
        let home = dir.path();
        let items_path = write_items(home, "");
        let ann = home.join("items.annotations.jsonl");
        let tmux = Tmux::new(&format!("annotate-{signal}"));
        let command = Tmux::bracketed(
            home,
            &format!(
                "env -u NO_COLOR TERM=xterm-256color HOME={home} XDG_CACHE_HOME={home}/.cache {} annotate {} --annotator ana",
                env!("CARGO_BIN_EXE_mapvlm"),
                items_path.display(),
                home = home.display(),
            ),
        );
        tmux.open("sig", 160, 40, &command);
        tmux.wait_for("sig", "the first item", |s| s.contains("Item 1 of 4"));
        tmux.keys("sig", &["4"]);
        wait("the rating on disk", || {
            (lines_of(&ann) == 1)
                .then_some(())
                .ok_or(tmux.screen("sig"))
        });
        let shell = tmux.cmd(&["display-message", "-p", "-t", "sig", "#{pane_pid}"]);
        let shell = shell.trim();
        let pid = wait("annotate's PID", || {
            std::fs::read_to_string(format!("/proc/{shell}/task/{shell}/children"))
                .ok()
                .and_then(|c| c.split_whitespace().next().map(str::to_string))
                .ok_or_else(|| "no child yet".to_string())
        });
        let sent = Command::new("kill")
            .args([&format!("-{signal}"), &pid])
            .status()
            .unwrap();
        assert!(sent.success());
        tmux.assert_restored("sig", home, &format!("SIG{signal}"));
        let current = Annotations::load(&ann).unwrap().current();
        assert_eq!(current.ratings().count(), 1, "SIG{signal}: the rating kept");
    }
}
