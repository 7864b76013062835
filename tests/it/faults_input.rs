//! Fault matrix, input half: bad or hostile files and flags given to the
//! release commands, each with the behaviour promised (see the table in
//! `tests/FAULTS.md`). Real files, the real binary, no model unless said.

use std::io::Write as _;
use std::path::Path;
use std::process::{Output, Stdio};

use crate::common;

fn mapvlm_with_stdin(args: &[&str], stdin: &[u8]) -> Output {
    let mut child = common::mapvlm_command()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("running mapvlm: {e}"));
    if let Some(mut input) = child.stdin.take() {
        input
            .write_all(stdin)
            .unwrap_or_else(|e| panic!("writing stdin: {e}"));
    }
    child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("waiting for mapvlm: {e}"))
}

fn mapvlm(args: &[&str]) -> Output {
    mapvlm_with_stdin(args, b"")
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    path.to_string_lossy().into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn ids(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value =
                serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}"));
            v["id"].as_str().unwrap_or_default().to_string()
        })
        .collect()
}

fn no_panic(out: &Output) {
    assert!(!stderr(out).contains("panicked"), "{}", stderr(out));
}

/// `score --metrics kas --json` of two step files with these contents: the
/// run and its JSON line.
fn kas_of_step_files(gt: &[u8], pred: &[u8]) -> (Output, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (gt, pred) = (
        write(dir.path(), "gt.txt", gt),
        write(dir.path(), "pred.txt", pred),
    );
    let args = [
        "score",
        "--gt",
        &gt,
        "--pred",
        &pred,
        "--metrics",
        "kas",
        "--json",
    ];
    let out = mapvlm(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    let v = serde_json::from_slice(&out.stdout).unwrap_or_default();
    (out, v)
}

const PAIR_A: &[u8] = b"{\"id\": \"a\", \"gt\": [\"Walk.\"], \"pred\": [\"Walk.\"]}\n";
const PAIR_C: &[u8] = b"{\"id\": \"c\", \"gt\": [\"Go.\"], \"pred\": [\"Go.\"]}\n";

#[test]
fn a_bom_in_a_step_file_keeps_the_first_step() {
    let (_, v) = kas_of_step_files(
        b"\xef\xbb\xbfWalk to the sink.\nPick up the cup.\n",
        b"\xef\xbb\xbf1. Walk to the sink.\n2. Pick up the cup.\n",
    );
    let both = serde_json::json!(["Walk to the sink.", "Pick up the cup."]);
    assert_eq!(v["gt"], both);
    assert_eq!(v["pred"], both);
}

#[test]
fn a_bom_in_a_pairs_file_is_not_an_error() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let pairs = write(
        dir.path(),
        "p.jsonl",
        &[b"\xef\xbb\xbf", PAIR_A, PAIR_C].concat(),
    );
    let out = mapvlm(&["score", "--pairs", &pairs, "--json", "--metrics", "kas"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(ids(&out), ["a", "c"]);
}

#[test]
fn a_non_utf8_pairs_line_is_reported_with_its_number_and_the_others_scored() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let bad = b"{\"id\": \"b\", \"gt\": [\"W\xffalk.\"], \"pred\": [\"Walk.\"]}\n";
    let pairs = write(dir.path(), "p.jsonl", &[PAIR_A, bad, PAIR_C].concat());
    let out = mapvlm(&["score", "--pairs", &pairs, "--json", "--metrics", "kas"]);
    no_panic(&out);
    assert!(!out.status.success());
    assert_eq!(ids(&out), ["a", "c"]);
    let err = stderr(&out);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("p.jsonl:2: not UTF-8"), "{err}");
}

#[test]
fn pairs_from_standard_input() {
    let out = mapvlm_with_stdin(
        &["score", "--pairs", "-", "--json", "--metrics", "kas"],
        &[PAIR_A, b"{oops\n", PAIR_C].concat(),
    );
    no_panic(&out);
    assert_eq!(ids(&out), ["a", "c"]);
    assert!(
        stderr(&out).contains("standard input:2:"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn an_overlong_pairs_line_is_skipped_with_its_number() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let long = format!(
        "{{\"id\": \"b\", \"gt\": [\"{}\"], \"pred\": [\"Go.\"]}}\n",
        "a".repeat(mapvlm::dataset::MAX_PAIR_LINE_BYTES)
    );
    let pairs = write(
        dir.path(),
        "p.jsonl",
        &[PAIR_A, long.as_bytes(), PAIR_C].concat(),
    );
    let out = mapvlm(&["score", "--pairs", &pairs, "--json", "--metrics", "kas"]);
    no_panic(&out);
    assert_eq!(ids(&out), ["a", "c"]);
    assert!(
        stderr(&out).contains("p.jsonl:2: line of"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn an_overlong_step_is_cut_and_said_so() {
    let step = format!("Walk {}.\n", "very ".repeat(100_000));
    let (out, v) = kas_of_step_files(step.as_bytes(), b"Walk.\n");
    let kept = v["gt"][0].as_str().unwrap_or_default().chars().count();
    assert_eq!(kept, mapvlm::plan::MAX_STEP_CHARS);
    assert!(
        stderr(&out).contains("cut to that length"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn parse_cuts_a_line_of_any_length_and_says_so_never_skips_it() {
    // Over the reader's 40 KB of one line and under it: both cut alike.
    let huge = "Walk to the counter and ".repeat(5_000);
    let long = "Open the fridge door and ".repeat(600);
    let input = format!("{huge}\n{long}\nPick up the apple.\n");
    let out = mapvlm_with_stdin(&["parse", "--json"], input.as_bytes());
    no_panic(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    let texts: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value =
                serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}"));
            v["text"].as_str().unwrap_or_default().to_string()
        })
        .collect();
    let limit = 10_000; // the documented limit of `mapvlm parse`
    assert_eq!(texts.len(), 3, "no line skipped");
    assert_eq!(texts[0].chars().count(), limit);
    assert!(huge.starts_with(&texts[0]));
    assert_eq!(texts[1].chars().count(), limit);
    assert_eq!(texts[2], "Pick up the apple.");
    let err = stderr(&out);
    for line in [1, 2] {
        assert!(
            err.contains(&format!("line {line}: longer than {limit} characters")),
            "{err}"
        );
    }
}

#[test]
fn out_of_range_score_thresholds_are_refused() {
    for (flag, value) in [
        ("--sentence-threshold", "NaN"),
        ("--word-threshold", "7"),
        ("--alpha=-1", ""),
    ] {
        let mut args = vec!["score", "--metrics", "kas", flag];
        if !value.is_empty() {
            args.push(value);
        }
        let out = mapvlm(&args);
        no_panic(&out);
        assert!(!out.status.success(), "{flag} {value}");
        let name = flag.split('=').next().unwrap_or(flag);
        assert!(stderr(&out).contains(name), "{}", stderr(&out));
    }
}

#[test]
fn cache_sizes_and_delays_out_of_range_are_refused_naming_the_range() {
    let cases: [(&[&str], &str); 6] = [
        (
            &["score", "--metrics", "kas", "--cache-max-mb", "0"],
            "0 is not in 1..=1048576",
        ),
        (
            &[
                "score",
                "--metrics",
                "kas",
                "--cache-max-mb",
                "18446744073709551615",
            ],
            "18446744073709551615 is not in 1..=1048576",
        ),
        (
            &["score", "--metrics", "kas", "--cache-max-mb=-1"],
            "--cache-max-mb",
        ),
        (
            &["cache", "prune", "--max-mb", "1048577"],
            "1048577 is not in 0..=1048576",
        ),
        (
            &["tui", "--replay-delay", "10001"],
            "10001 is not in 0..=10000",
        ),
        (&["tui", "--replay-delay", "1e300"], "--replay-delay"),
    ];
    for (args, needle) in cases {
        let out = mapvlm(args);
        no_panic(&out);
        assert!(!out.status.success(), "{args:?}");
        let first = stderr(&out).lines().next().unwrap_or_default().to_string();
        assert!(first.contains(needle), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn a_model_pack_path_that_is_a_file_is_one_clear_line() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let file = write(dir.path(), "pack", b"x");
    let out = common::mapvlm_command()
        .args(["score", "--metrics", "pg2s"])
        .env("MAPVLM_MODELS", &file)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    no_panic(&out);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("is a file, not a folder"), "{err}");
}
