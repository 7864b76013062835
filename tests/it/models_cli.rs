//! `mapvlm models verify|list` as a user runs them.

use std::process::Command;

fn mapvlm(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mapvlm"))
        .args(args)
        .env_remove("MAPVLM_MODELS")
        .output()
        .unwrap()
}

#[test]
fn verify_of_an_empty_pack_fails_and_says_to_fetch() {
    let pack = tempfile::tempdir().unwrap();
    let dir = pack.path().to_str().unwrap();
    let out = mapvlm(&["models", "verify", "--json", "--models-dir", dir]);
    assert_eq!(out.status.code(), Some(1));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["ok"], false);
    let statuses: Vec<_> = report["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| (m["model"].as_str().unwrap(), m["status"].as_str().unwrap()))
        .collect();
    assert_eq!(
        statuses,
        [
            ("all-mpnet-base-v2", "missing"),
            ("en_core_web_sm-3.8.0", "missing"),
            ("glove-6b-50d", "missing")
        ]
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("run `mapvlm models fetch`"), "{stderr}");
}

#[test]
fn list_reports_folders_sizes_and_status_without_hashing() {
    let pack = tempfile::tempdir().unwrap();
    let glove = pack.path().join("glove-6b-50d");
    std::fs::create_dir(&glove).unwrap();
    std::fs::write(glove.join("glove_6B_index.parquet"), b"12345").unwrap();
    let dir = pack.path().to_str().unwrap();
    let out = mapvlm(&["models", "--models-dir", dir, "list", "--json"]);
    assert!(out.status.success());
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let glove_row = &report["models"][2];
    assert_eq!(glove_row["model"], "glove-6b-50d");
    assert_eq!(glove_row["bytes"], 5);
    assert_eq!(glove_row["status"], "unverified");
    assert_eq!(report["models"][0]["status"], "missing");
}
