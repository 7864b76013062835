//! The embedding cache as a user meets it: `score` through the real binary,
//! cold then warm, with the same bytes out; `mapvlm cache stats|prune|clear`.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

/// mapvlm with its caches in `cache_home` and the real model pack.
fn mapvlm(cache_home: &Path, args: &[&str]) -> Output {
    let pack = mapvlm::models::models_dir(None);
    Command::new(env!("CARGO_BIN_EXE_mapvlm"))
        .args(args)
        .env("XDG_CACHE_HOME", cache_home)
        .env("MAPVLM_MODELS", pack)
        .output()
        .unwrap_or_else(|e| panic!("running mapvlm: {e}"))
}

fn ok(out: Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap_or_else(|e| panic!("{e}"))
}

fn embeddings(cache_home: &Path) -> serde_json::Value {
    let stats = ok(mapvlm(cache_home, &["cache", "stats", "--json"]));
    let stats: serde_json::Value = serde_json::from_str(&stats).unwrap_or_else(|e| panic!("{e}"));
    stats["embeddings"].clone()
}

#[test]
fn a_warm_score_prints_the_bytes_of_the_cold_one() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let golden = common::shared().join("golden/pairs.dev.jsonl");
    let text = std::fs::read_to_string(&golden).unwrap_or_else(|e| panic!("{e}"));
    let pairs = dir.path().join("pairs.jsonl");
    let first: Vec<&str> = text.lines().take(4).collect();
    std::fs::write(&pairs, first.join("\n")).unwrap_or_else(|e| panic!("{e}"));
    let pairs = pairs.to_string_lossy().into_owned();
    let score = ["score", "--pairs", &pairs, "--json"];

    assert_eq!(embeddings(home.path())["entries"], 0);
    let cold = ok(mapvlm(home.path(), &score));
    let stored = embeddings(home.path());
    let distinct: std::collections::HashSet<String> = first
        .iter()
        .flat_map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}"));
            let mut steps = common::strings(&v["gt"]);
            steps.extend(common::strings(&v["pred"]));
            steps
        })
        .collect();
    assert_eq!(
        stored["entries"],
        distinct.len(),
        "one entry per distinct step"
    );
    let warm = ok(mapvlm(home.path(), &score));
    assert_eq!(cold.lines().count(), 4);
    assert!(cold == warm, "warm output differs from cold");
    assert_eq!(embeddings(home.path()), stored, "a warm run adds nothing");

    let uncached = ok(mapvlm(
        home.path(),
        &["score", "--pairs", &pairs, "--json", "--no-cache"],
    ));
    assert_eq!(uncached.lines().count(), 4);
    assert_eq!(embeddings(home.path()), stored, "--no-cache writes nothing");

    let pruned = ok(mapvlm(home.path(), &["cache", "prune", "--max-mb", "0"]));
    assert!(
        pruned.contains(&format!("removed {} entries", distinct.len())),
        "{pruned}"
    );
    assert_eq!(embeddings(home.path())["entries"], 0);
    ok(mapvlm(home.path(), &score));
    let cleared = ok(mapvlm(home.path(), &["cache", "clear"]));
    assert!(cleared.starts_with("embeddings: removed"), "{cleared}");
    assert_eq!(embeddings(home.path())["entries"], 0);
}

/// A cache whose embeddings folder is a plain file: scoring still works, and
/// the binary says once, on stderr, that embeddings cannot be kept, whether
/// RUST_LOG is unset, empty or `warn`; with `--log FILE` the line goes to
/// the file and stderr stays empty.
#[test]
fn an_unwritable_embedding_cache_is_said_once_on_stderr() {
    let home = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(home.path().join("mapvlm")).unwrap();
    std::fs::write(home.path().join("mapvlm/embeddings"), b"not a folder").unwrap();
    let pairs = home.path().join("pairs.jsonl");
    let golden = std::fs::read_to_string(common::shared().join("golden/pairs.dev.jsonl")).unwrap();
    let first: Vec<&str> = golden.lines().take(2).collect();
    std::fs::write(&pairs, first.join("\n") + "\n").unwrap();
    let warning = "cannot store embeddings";
    for filter in [None, Some(""), Some("warn")] {
        let mut command = common::mapvlm_command();
        command
            .env("XDG_CACHE_HOME", home.path())
            .env_remove("RUST_LOG");
        if let Some(filter) = filter {
            command.env("RUST_LOG", filter);
        }
        let out = command
            .args(["score", "--json", "--pairs"])
            .arg(&pairs)
            .output()
            .unwrap();
        let err = common::stderr(&out);
        assert!(out.status.success(), "RUST_LOG={filter:?}: {err}");
        assert_eq!(
            err.matches(warning).count(),
            1,
            "RUST_LOG={filter:?}: {err}"
        );
    }
    let log = home.path().join("mapvlm.log");
    let out = common::mapvlm_command()
        .env("XDG_CACHE_HOME", home.path())
        .env("RUST_LOG", "trace")
        .args(["score", "--json", "--log"])
        .arg(&log)
        .arg("--pairs")
        .arg(&pairs)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", common::stderr(&out));
    assert_eq!(
        common::stderr(&out),
        "",
        "with --log nothing goes to stderr"
    );
    let logged = std::fs::read_to_string(&log).unwrap();
    assert!(logged.contains(warning), "{logged}");
}
