//! `mapvlm eval` where money is at stake: SIGTERM and SIGHUP stop it as
//! Ctrl-C does (results, tables, manifest and recording kept; a re-run asks
//! only for the rest), a second eval into the same `--out` is refused
//! naming the first one's PID, a full disk stops the requests, and PG2S
//! that cannot load stops the run before any request. All against a local
//! server that counts what it is asked.

use crate::agents_support;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use agents_support::*;
use mapvlm::agents::ProviderKind;
use serde_json::Value;
use wiremock::MockServer;

/// `n` single-image tasks on one scene, under `home/data`.
fn tasks(home: &Path, n: usize) -> PathBuf {
    let data = home.join("data");
    std::fs::create_dir_all(&data).unwrap();
    scene(&data);
    let lines: Vec<String> = (1..=n)
        .map(|i| {
            format!(r#"{{"id": "t-{i}", "task": "Wash mug {i}", "image": "scene.png", "ground_truth": ["Walk to the sink.", "Wash the mug."]}}"#)
        })
        .collect();
    std::fs::write(data.join("tasks.jsonl"), lines.join("\n")).unwrap();
    data
}

/// A server answering every plan with two steps, each answer after `delay`.
async fn planner(delay: Duration) -> (MockServer, String) {
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    let plan = whole(provider, "1. Walk to the sink.\n2. Wash the mug.").set_delay(delay);
    answer(&server, provider, PLANNER_MARK, plan).await;
    let base = format!("{}/v1", server.uri());
    (server, base)
}

/// `eval` of `data` at `base` into `out`, KAS only, no cache.
fn eval_args(data: &Path, out: &Path, base: &str, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = [
        "eval",
        "--dataset",
        &data.to_string_lossy(),
        "--approaches",
        "single-image",
        "--metrics",
        "kas",
        "--out",
        &out.to_string_lossy(),
        "--base-url",
        base,
        "--model",
        "test-model",
        "--no-cache",
    ]
    .map(|s| s.to_string())
    .to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

fn spawn(args: &[String], home: &Path) -> Child {
    mapvlm_command(args, home)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Runs `mapvlm` with `args` and `env` to its end, off the async threads.
async fn run_to_end(args: &[String], home: &Path, env: Vec<(&'static str, PathBuf)>) -> Output {
    let (args, home) = (args.to_vec(), home.to_path_buf());
    tokio::task::spawn_blocking(move || mapvlm_command(&args, &home).envs(env).output().unwrap())
        .await
        .unwrap()
}

async fn requests(server: &MockServer) -> usize {
    server.received_requests().await.unwrap().len()
}

/// Waits until `server` has been asked `n` times (at most a minute).
async fn wait_for_requests(server: &MockServer, n: usize) {
    let start = Instant::now();
    while requests(server).await < n {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the server was asked {} times, not {n}",
            requests(server).await
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Waits for `child` to end, at most `limit`; its output.
fn wait_at_most(mut child: Child, limit: Duration) -> Output {
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("eval did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn signal(child: &Child, name: &str) {
    let sent = Command::new("kill")
        .arg(format!("-{name}"))
        .arg(child.id().to_string())
        .status()
        .unwrap();
    assert!(sent.success(), "kill -{name}");
}

fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn result_files(out: &Path) -> usize {
    std::fs::read_dir(out.join("tasks"))
        .map(|dir| dir.count())
        .unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread")]
async fn sigterm_and_sighup_keep_what_was_made_and_a_rerun_asks_only_for_the_rest() {
    for name in ["TERM", "HUP"] {
        let home = tempfile::tempdir().unwrap();
        let data = tasks(home.path(), 6);
        let (server, base) = planner(Duration::from_millis(400)).await;
        let out = home.path().join("eval");
        let record = home.path().join("run.record.json");
        let record_arg = record.to_string_lossy().into_owned();
        let extra = ["--concurrency", "1", "--record", &record_arg];
        let args = eval_args(&data, &out, &base, &extra);
        let child = spawn(&args, home.path());
        // Two plans made and written, the third asked for.
        wait_for_requests(&server, 3).await;
        signal(&child, name);
        let stopped =
            tokio::task::spawn_blocking(move || wait_at_most(child, Duration::from_secs(5)))
                .await
                .unwrap();
        let said = stderr(&stopped);
        assert!(!stopped.status.success(), "{name}: {said}");
        assert!(
            stopped.status.code().is_some(),
            "{name}: exits, is not killed: {said}"
        );
        assert!(said.contains("interrupted"), "{name}: {said}");
        let manifest = json(&out.join("manifest.json"));
        let written = manifest["results"].as_array().unwrap().len();
        let failed = manifest["failed"].as_array().unwrap().len();
        assert!(written >= 2, "{name}: {manifest}");
        assert_eq!(
            written + failed,
            6,
            "{name}: the cancelled tasks are listed: {manifest}"
        );
        assert_eq!(result_files(&out), written, "{name}");
        let csv = std::fs::read_to_string(out.join("table3.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + written + 1, "{name}: {csv}");
        let recording = json(&record);
        let answers = recording["answers"].as_object().map_or(0, |a| a.len());
        assert!(answers >= written, "{name}: {answers} answers recorded");

        let asked = requests(&server).await;
        let rerun = run_to_end(&args, home.path(), Vec::new()).await;
        assert!(rerun.status.success(), "{name}: {}", stderr(&rerun));
        assert_eq!(
            requests(&server).await - asked,
            6 - written,
            "{name}: the re-run asks only for the rest"
        );
        assert_eq!(result_files(&out), 6);
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_second_eval_into_one_out_is_refused_naming_the_first_and_kill_9_frees_it() {
    let home = tempfile::tempdir().unwrap();
    let data = tasks(home.path(), 3);
    let (server, base) = planner(Duration::from_millis(1500)).await;
    let out = home.path().join("eval");
    let args = eval_args(&data, &out, &base, &["--concurrency", "1"]);
    let first = spawn(&args, home.path());
    wait_for_requests(&server, 1).await;
    let second = run_to_end(&args, home.path(), Vec::new()).await;
    let said = stderr(&second);
    assert!(!second.status.success(), "{said}");
    assert_eq!(said.trim_end().lines().count(), 1, "{said}");
    assert!(said.contains(&format!("PID {}", first.id())), "{said}");
    assert!(said.contains("mapvlm eval"), "{said}");
    assert_eq!(requests(&server).await, 1, "the second asked nothing");

    signal(&first, "KILL");
    let killed = tokio::task::spawn_blocking(move || wait_at_most(first, Duration::from_secs(5)))
        .await
        .unwrap();
    assert!(killed.status.code().is_none(), "killed by the signal");
    let again = run_to_end(&args, home.path(), Vec::new()).await;
    assert!(
        again.status.success(),
        "the kernel freed the lock: {}",
        stderr(&again)
    );
    assert_eq!(result_files(&out), 3);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_full_disk_stops_the_requests_at_the_first_write_error() {
    let home = tempfile::tempdir().unwrap();
    let data = tasks(home.path(), 20);
    let (server, base) = planner(Duration::from_millis(50)).await;
    let disk = home.path().join("disk");
    std::fs::create_dir_all(&disk).unwrap();
    let args = eval_args(&data, &disk.join("out"), &base, &["--concurrency", "2"]);
    // A 64 KiB tmpfs, 40 KiB of it filled, in a mount namespace of its own
    // (`unshare`: nothing is left mounted when the run ends).
    let script = r#"mount -t tmpfs -o size=64k tmpfs "$DISK" || exit 99
head -c 40960 /dev/zero > "$DISK/filler" || exit 98
"$@"; rc=$?
ls "$DISK/out/tasks" 2>/dev/null | grep -c json
exit $rc"#;
    let run = tokio::task::spawn_blocking({
        let home = home.path().to_path_buf();
        move || crate::common::in_own_mounts(&mapvlm_command(&args, &home), script, &disk)
    })
    .await
    .unwrap();
    let said = stderr(&run);
    assert_ne!(run.status.code(), Some(99), "mount failed: {said}");
    assert_ne!(run.status.code(), Some(98), "filling failed: {said}");
    assert!(!run.status.success(), "{said}");
    let written: usize = String::from_utf8_lossy(&run.stdout)
        .trim()
        .parse()
        .unwrap_or_else(|e| panic!("{e}: {:?}", run.stdout));
    assert!(said.contains("No space left"), "{said}");
    assert!(said.contains("no further plan was asked for"), "{said}");
    let asked = requests(&server).await;
    // Each plan is one request; a plan starts only once the one before it
    // is written, so after the first failed write only the plans already in
    // flight (at most --concurrency) were asked for.
    assert!(
        asked <= written + 2,
        "{asked} requests, {written} results written: {said}"
    );
    assert!(asked < 20, "{asked} requests");
}

#[tokio::test(flavor = "multi_thread")]
async fn pg2s_that_cannot_load_stops_eval_before_any_request() {
    let home = tempfile::tempdir().unwrap();
    let data = tasks(home.path(), 2);
    let (server, base) = planner(Duration::ZERO).await;
    let out = home.path().join("eval");
    let empty = home.path().join("no-models");
    std::fs::create_dir_all(&empty).unwrap();
    let mut args = eval_args(&data, &out, &base, &[]);
    // The default metrics: KAS and PG2S.
    let metrics = args.iter().position(|a| a == "--metrics").unwrap();
    args.drain(metrics..metrics + 2);
    let env = vec![
        ("MAPVLM_MODELS", empty),
        ("HF_HUB_OFFLINE", PathBuf::from("1")),
        ("HF_HOME", home.path().join("hf")),
        ("PATH", PathBuf::from("/nonexistent")),
    ];
    let run = run_to_end(&args, home.path(), env).await;
    let said = stderr(&run);
    assert!(!run.status.success(), "{said}");
    assert!(said.contains("PG2S could not be loaded"), "{said}");
    assert!(said.contains("--metrics kas"), "{said}");
    assert!(!said.contains("KAS only"), "{said}");
    assert_eq!(requests(&server).await, 0);
    assert!(!out.join("manifest.json").exists());

    let kas_only = run_to_end(&eval_args(&data, &out, &base, &[]), home.path(), Vec::new()).await;
    assert!(kas_only.status.success(), "{}", stderr(&kas_only));
    let manifest = json(&out.join("manifest.json"));
    assert_eq!(
        manifest["provenance"]["metrics"],
        serde_json::json!(["kas"])
    );
    assert!(manifest["provenance"]["pg2s_settings"].is_null());
    let result = json(&out.join("tasks/t-1.single-image.json"));
    assert_eq!(result["provenance"], manifest["provenance"]);
}
