//! `mapvlm plan` end to end against a local OpenAI-compatible server.

mod agents_support;

use std::path::Path;
use std::process::Output;
use std::time::Duration;

use agents_support::*;
use mapvlm::agents::ProviderKind;
use serde_json::Value;
use wiremock::{MockServer, ResponseTemplate};

async fn mapvlm(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || mapvlm_command(&args, &home).output().unwrap())
        .await
        .unwrap()
}

fn plan_args(server: &MockServer, image: &Path) -> Vec<String> {
    [
        "plan",
        "--task",
        "Place a wet sponge inside the bathtub",
        "--image",
        image.to_str().unwrap(),
        "--approach",
        "multi-image",
        "--json",
        "--base-url",
        &format!("{}/v1", server.uri()),
        "--model",
        "test-model",
        "--agent",
        "planner.temperature=0.5",
    ]
    .map(str::to_string)
    .to_vec()
}

#[tokio::test(flavor = "multi_thread")]
async fn plan_prints_the_whole_run_and_reuses_the_cache() {
    let home = tempfile::tempdir().unwrap();
    let image = scene(home.path());
    let server = multi_agent_server(ProviderKind::Openai, true, Duration::ZERO).await;
    let first = mapvlm(plan_args(&server, &image), home.path()).await;
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(first.status.success(), "{stderr}");
    let run: Value = serde_json::from_slice(&first.stdout).unwrap();
    assert_eq!(run["approach"], "multi-image");
    assert_eq!(run["agents"][0]["role"], "skm");
    assert_eq!(run["agents"][0]["output"], SKM_TEXT);
    assert_eq!(run["agents"][1]["output"], GKM_TEXT);
    assert_eq!(run["agents"][2]["temperature"], 0.5);
    assert_eq!(run["agents"][2]["prompt"], "multi-image-planner");
    assert_eq!(run["agents"][2]["prompt_hash"].as_str().unwrap().len(), 16);
    assert_eq!(run["triples"]["triples"][0]["subject"], "sponge");
    assert_eq!(run["steps"][5], "Place the sponge in the bathtub.");
    assert_eq!(run["usage"]["input_tokens"], 300);
    assert!(run["agents"][0]["elapsed_ms"].is_u64());
    assert_eq!(server.received_requests().await.unwrap().len(), 3);

    let second = mapvlm(plan_args(&server, &image), home.path()).await;
    assert!(second.status.success());
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        3,
        "served from the cache"
    );
    let again: Value = serde_json::from_slice(&second.stdout).unwrap();
    assert_eq!(again["steps"], run["steps"]);
    assert_eq!(again["agents"][2]["cached"], true);
    for output in [&first, &second] {
        assert!(!String::from_utf8_lossy(&output.stdout).contains(KEY));
        assert!(!String::from_utf8_lossy(&output.stderr).contains(KEY));
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn plan_fails_in_one_line_when_the_key_is_refused_or_the_image_is_bad() {
    let home = tempfile::tempdir().unwrap();
    let image = scene(home.path());
    let server = MockServer::start().await;
    answer(
        &server,
        ProviderKind::Openai,
        "",
        ResponseTemplate::new(401),
    )
    .await;
    let mut args = plan_args(&server, &image);
    args.retain(|a| a != "--json");
    let refused = mapvlm(args.clone(), home.path()).await;
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    let last = stderr.lines().last().unwrap();
    assert!(
        last.starts_with("mapvlm: skm failed: openai refused the API key"),
        "{stderr}"
    );
    assert!(!stderr.contains(KEY));

    let bad = home.path().join("broken.jpg");
    std::fs::write(&bad, b"not an image").unwrap();
    let image_arg = args.iter().position(|a| a == "--image").unwrap() + 1;
    args[image_arg] = bad.display().to_string();
    let failed = mapvlm(args, home.path()).await;
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(!failed.status.success());
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("broken.jpg") && stderr.contains("not an image"),
        "{stderr}"
    );
}
