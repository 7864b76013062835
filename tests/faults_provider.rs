//! Fault matrix, provider half (see `tests/FAULTS.md`): the release commands
//! against a local server (wiremock) that misbehaves, and runs whose output
//! cannot be written.

mod agents_support;

use std::path::Path;
use std::process::Output;

use agents_support::*;
use mapvlm::agents::ProviderKind;
use wiremock::MockServer;

/// Runs mapvlm off the async runtime, so that the mock server keeps answering.
async fn mapvlm(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || mapvlm_command(&args, &home).output().unwrap())
        .await
        .unwrap()
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

/// `eval` of `data` through the single-image agent at `base`, into `out`.
fn eval_args(data: &Path, out: &Path, base: &str) -> Vec<String> {
    strings(&[
        "eval",
        "--dataset",
        data.to_str().unwrap(),
        "--approaches",
        "single-image",
        "--metrics",
        "kas",
        "--out",
        out.to_str().unwrap(),
        "--base-url",
        base,
        "--no-cache",
    ])
}

async fn requests(server: &MockServer) -> usize {
    server.received_requests().await.unwrap().len()
}

async fn planning_server() -> MockServer {
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    let plan = streamed(
        provider,
        &["1. Walk to the sink.\n", "2. Wash the mug."],
        true,
    );
    answer(&server, provider, PLANNER_MARK, plan).await;
    server
}

#[tokio::test(flavor = "multi_thread")]
async fn eval_fails_bad_images_alone_writes_the_rest_and_resumes() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    scene(&data);
    std::fs::write(data.join("empty.png"), b"").unwrap();
    let task = |id: &str, image: &str| {
        format!(
            r#"{{"id": "{id}", "task": "Wash the mug", "image": "{image}", "ground_truth": ["Walk to the sink.", "Wash the mug."]}}"#
        )
    };
    let tasks = [
        task("t-1", "scene.png"),
        task("t-2", "missing.png"),
        task("t-3", "empty.png"),
        task("t-4", "scene.png"),
    ];
    std::fs::write(data.join("tasks.jsonl"), tasks.join("\n")).unwrap();
    let server = planning_server().await;
    let out = home.path().join("eval");
    let base = format!("{}/v1", server.uri());
    let args = eval_args(&data, &out, &base);
    let run = mapvlm(args.clone(), home.path()).await;
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("t-2 single-image: image") && err.contains("missing.png"),
        "{err}"
    );
    assert!(
        err.contains("t-3 single-image: image") && err.contains("the file is empty"),
        "{err}"
    );
    assert!(err.contains("2 failed"), "{err}");
    assert_eq!(requests(&server).await, 2, "only the good tasks were asked");
    for id in ["t-1", "t-4"] {
        assert!(out.join(format!("tasks/{id}.single-image.json")).is_file());
    }
    assert!(!out.join("tasks/t-2.single-image.json").exists());

    std::fs::copy(data.join("scene.png"), data.join("missing.png")).unwrap();
    let again = mapvlm(args, home.path()).await;
    assert!(!again.status.success(), "t-3 still fails");
    assert_eq!(requests(&server).await, 3, "the re-run made only t-2");
    assert!(out.join("tasks/t-2.single-image.json").is_file());
}

#[tokio::test(flavor = "multi_thread")]
async fn unwritable_outputs_are_refused_before_any_request() {
    let home = tempfile::tempdir().unwrap();
    let server = planning_server().await;
    let blocker = home.path().join("a-file");
    std::fs::write(&blocker, b"x").unwrap();
    let image = scene(home.path());
    let base = format!("{}/v1", server.uri());
    let under_file = blocker.join("out");
    let record = blocker.join("rec.json");
    let plan = strings(&[
        "plan",
        "--task",
        "Wash the mug",
        "--image",
        image.to_str().unwrap(),
        "--approach",
        "single-image",
        "--base-url",
        &base,
        "--no-cache",
        "--record",
        record.to_str().unwrap(),
    ]);
    let run = mapvlm(plan, home.path()).await;
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        err.contains("--record") && err.contains("rec.json"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");

    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::copy(&image, data.join("scene.png")).unwrap();
    std::fs::write(
        data.join("tasks.jsonl"),
        r#"{"id": "t-1", "task": "Wash", "image": "scene.png", "ground_truth": ["Wash."]}"#,
    )
    .unwrap();
    let eval = eval_args(&data, &under_file, &base);
    let run = mapvlm(eval, home.path()).await;
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(err.contains("nothing was asked"), "{err}");
    assert_eq!(requests(&server).await, 0);
}
