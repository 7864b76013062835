//! `mapvlm score` as a user runs it: JSON lines, bad input with one clear
//! line and a non-zero exit, never a panic.

use crate::common;

use std::path::Path;

use common::{assert_one_line_failure, mapvlm, stderr};

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    path.to_string_lossy().into_owned()
}

#[test]
fn kas_over_the_golden_pairs_prints_one_line_each() {
    let pairs = common::shared().join("golden/pairs.dev.jsonl");
    let out = mapvlm(&[
        "score",
        "--pairs",
        &pairs.to_string_lossy(),
        "--json",
        "--metrics",
        "kas",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let golden = common::golden("pg2s.dev.jsonl");
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert_eq!(lines.len(), golden.len());
    for (got, want) in lines.iter().zip(&golden) {
        assert_eq!(got["id"], want["id"]);
        assert_eq!(got["kas_chunks"], want["kas_chunks"]);
        match want["kas"].as_f64() {
            Some(k) => assert!((got["kas"].as_f64().unwrap_or(f64::NAN) - k).abs() <= 1e-9),
            None => {
                assert!(got["kas"].is_null());
                assert!(got["reasons"]["kas"].is_string());
            }
        }
    }
}

#[test]
fn step_files_are_parsed_like_model_output() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let gt = write(
        dir.path(),
        "gt.txt",
        b"Walk to the sink.\nPick up the cup.\n",
    );
    let pred = write(
        dir.path(),
        "pred.txt",
        b"Here is the plan:\n1. Walk to the sink.,\n2. Pick up the cup.,\n",
    );
    let out = mapvlm(&[
        "score",
        "--gt",
        &gt,
        "--pred",
        &pred,
        "--metrics",
        "kas",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert_eq!(
        v["pred"],
        serde_json::json!(["Walk to the sink.", "Pick up the cup."])
    );
    assert!((v["kas"].as_f64().unwrap_or_default() - 1.0).abs() < 1e-7);
}

#[test]
fn a_missing_file_is_one_line() {
    let out = mapvlm(&[
        "score",
        "--gt",
        "/nonexistent/gt.txt",
        "--pred",
        "/nonexistent/p.txt",
        "--metrics",
        "kas",
    ]);
    assert_one_line_failure(&out, "/nonexistent/gt.txt");
}

#[test]
fn invalid_utf8_is_one_line() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let gt = write(dir.path(), "gt.txt", b"Walk to the \xff sink.\n");
    let pred = write(dir.path(), "pred.txt", b"Walk.\n");
    let out = mapvlm(&["score", "--gt", &gt, "--pred", &pred, "--metrics", "kas"]);
    assert_one_line_failure(&out, "UTF-8");
}

#[test]
fn an_empty_plan_is_one_line() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let gt = write(dir.path(), "gt.txt", b"Walk.\n");
    let pred = write(dir.path(), "pred.txt", b"\n  \n");
    let out = mapvlm(&["score", "--gt", &gt, "--pred", &pred, "--metrics", "kas"]);
    assert_one_line_failure(&out, "no steps");
}

#[test]
fn a_malformed_pairs_line_is_reported_and_the_others_scored() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let pairs = write(
        dir.path(),
        "pairs.jsonl",
        b"{\"id\": \"a\", \"gt\": [\"Walk.\"], \"pred\": [\"Walk.\"]}\n{\"id\": \"b\", \"gt\": \n{\"id\": \"c\", \"gt\": [\"Go.\"], \"pred\": [\"Go.\"]}\n",
    );
    let out = mapvlm(&["score", "--pairs", &pairs, "--json", "--metrics", "kas"]);
    assert_one_line_failure(&out, "pairs.jsonl:2:");
    let ids: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap_or_default()["id"].to_string())
        .collect();
    assert_eq!(ids, ["\"a\"", "\"c\""]);
}

#[test]
fn a_closed_pipe_ends_the_run_quietly_with_status_0() {
    use std::io::{BufRead as _, BufReader};
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // Far more output than a pipe holds, so the writer meets the closed end.
    // (Ids are unique, as every pairs file's must be.)
    let lines: String = (0..5_000)
        .map(|n| {
            format!(
                "{{\"id\": \"p{n}\", \"gt\": [\"Walk to the sink.\", \"Wash the mug.\"], \"pred\": [\"Wash the mug.\"]}}\n"
            )
        })
        .collect();
    let pairs = write(dir.path(), "pairs.jsonl", lines.as_bytes());
    let mut child = common::mapvlm_command()
        .args(["score", "--metrics", "kas", "--pairs", &pairs])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{e}"));
    let stdout = child.stdout.take().unwrap_or_else(|| panic!("no stdout"));
    let mut first = String::new();
    BufReader::new(stdout)
        .read_line(&mut first)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(first, "p0\n", "the reader got its line, as `head -1` would");
    // The reader is dropped here: the pipe is closed with output still to come.
    let out = child.wait_with_output().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(stderr(&out), "", "nothing is said of the closed pipe");
    assert_eq!(out.status.code(), Some(0));
}

#[test]
fn the_explanation_shows_steps_as_data_in_the_characters_of_the_locale() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let gt = write(
        dir.path(),
        "gt.txt",
        "Walk to the sink.\nPick up the cup.\u{1b}]52;c;aGk=\u{7}\n".as_bytes(),
    );
    let pred = write(
        dir.path(),
        "pred.txt",
        "1. Walk to the sink.\n2. Pick up the \u{202e}cup.\n3. Rinse the \u{9b}2Jcup.\n".as_bytes(),
    );
    let explain = |lang: &str| {
        let out = common::mapvlm_command()
            .env_remove("LC_ALL")
            .env_remove("LC_CTYPE")
            .env("LANG", lang)
            .args(["score", "--gt", &gt, "--pred", &pred])
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(out.status.success(), "{}", stderr(&out));
        String::from_utf8(out.stdout).unwrap_or_else(|e| panic!("{e}"))
    };
    let utf8 = explain("en_GB.UTF-8");
    assert!(
        utf8.contains("✓ 1 → 1") && utf8.contains("S_plan"),
        "{utf8}"
    );
    let ascii = explain("C");
    assert!(
        ascii.contains("+ 1 > 1") && ascii.contains("S_plan"),
        "{ascii}"
    );
    assert!(ascii.is_ascii(), "{ascii}");
    for text in [&utf8, &ascii] {
        let unsafe_chars: Vec<char> = text
            .chars()
            .filter(|c| mapvlm::sanitize::is_unsafe(*c))
            .collect();
        assert!(unsafe_chars.is_empty(), "{unsafe_chars:?} in {text}");
        assert!(
            text.contains("\\u{1b}]52"),
            "the escape shown as data: {text}"
        );
    }
}
