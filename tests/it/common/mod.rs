//! Helpers shared by the integration tests: the real binary with a cache of
//! its own, the shared data folder, the golden files, a tmux driver, a
//! local OpenAI-compatible server and a user's home with a config file.
#![allow(dead_code)]

pub mod pty;
pub mod server;
pub mod tmux;
pub mod workbench;

use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The real `mapvlm` binary, ready to run: its caches (`XDG_CACHE_HOME`,
/// e.g. the sentence embeddings PG2S writes) go to a temporary folder of
/// this test process, never to the user's, while the model pack is still
/// the user's (`MAPVLM_MODELS`, resolved before the cache is moved).
pub fn mapvlm_command() -> Command {
    mapvlm_command_program(env!("CARGO_BIN_EXE_mapvlm"))
}

/// `program` (a shell or wrapper that runs the real binary) with the
/// environment of [`mapvlm_command`].
pub fn mapvlm_command_program(program: &str) -> Command {
    let mut command = Command::new(program);
    command
        .env("XDG_CACHE_HOME", test_cache_home())
        .env("MAPVLM_MODELS", pack_dir());
    command
}

/// The model pack the user has, wherever the environment points.
pub fn pack_dir() -> PathBuf {
    static PACK: OnceLock<PathBuf> = OnceLock::new();
    PACK.get_or_init(|| mapvlm::models::models_dir(None))
        .clone()
}

/// The cache folder of the test binaries, inside Cargo's temporary folder
/// of the build (`target/tmp`): kept between runs as the user's cache would
/// be, but never the user's.
pub fn test_cache_home() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("xdg-cache")
}

/// Runs the real `mapvlm` binary with `args` (see [`mapvlm_command`]) and
/// waits for it.
pub fn mapvlm(args: &[&str]) -> Output {
    mapvlm_command()
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running mapvlm: {e}"))
}

/// What a run wrote on standard error.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts that `out` is a failure with exactly one line on stderr, naming
/// `needle`, and no panic.
pub fn assert_one_line_failure(out: &Output, needle: &str) {
    assert!(!out.status.success(), "expected failure");
    let err = stderr(out);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "{needle:?} not in {err}");
}

/// `../shared` beside the repository, where the specs, data and golden files live.
pub fn shared() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared")
}

/// Every line of a golden JSONL file, parsed.
pub fn golden(name: &str) -> Vec<serde_json::Value> {
    let path = shared().join("golden").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
        .collect()
}

/// The strings of a JSON array.
pub fn strings(value: &serde_json::Value) -> Vec<String> {
    value
        .as_array()
        .unwrap_or_else(|| panic!("not an array: {value}"))
        .iter()
        .map(|v| {
            v.as_str()
                .unwrap_or_else(|| panic!("not a string: {v}"))
                .to_string()
        })
        .collect()
}

/// The folder of model `folder` in the model pack; fails the test with what
/// to do when the pack is not installed (`./scripts/test` fetches it).
pub fn model_dir(folder: &str) -> PathBuf {
    let dir = mapvlm::models::models_dir(None).join(folder);
    assert!(
        dir.is_dir(),
        "no model at {}: run ./scripts/test (it fetches the model pack) or `mapvlm models fetch`",
        dir.display()
    );
    dir
}

/// Every file under `dir` with its bytes (nothing when `dir` does not
/// exist), for tests that search everything a run left on disk.
pub fn files_under(dir: &std::path::Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut found = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return found;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            found.extend(files_under(&path));
        } else {
            found.push((path.clone(), std::fs::read(&path).unwrap()));
        }
    }
    found
}

/// Runs `command` through `sh -c script` in a user and mount namespace of
/// its own (`unshare -rm`), with `$DISK` set to `disk` and the command as
/// `"$@"`: the script mounts what it needs (a small tmpfs for a full disk),
/// and nothing is left mounted when it ends. Fails without `unshare`.
pub fn in_own_mounts(command: &Command, script: &str, disk: &std::path::Path) -> Output {
    Command::new("unshare")
        .args(["-rm", "sh", "-c", script, "sh"])
        .arg(command.get_program())
        .args(command.get_args())
        .envs(command.get_envs().filter_map(|(k, v)| v.map(|v| (k, v))))
        .env("DISK", disk)
        .output()
        .unwrap_or_else(|e| panic!("unshare is needed for this test (util-linux): {e}"))
}
