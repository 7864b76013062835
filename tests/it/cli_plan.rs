//! `mapvlm plan` end to end against a local OpenAI-compatible server.

use crate::agents_support;

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

fn samples_args(server: &MockServer, image: &Path, samples: u32) -> Vec<String> {
    let mut args = plan_args(server, image);
    args.extend([
        "--no-stream".into(),
        "--samples".into(),
        samples.to_string(),
    ]);
    args
}

fn bodies(requests: &[wiremock::Request], mark: &str) -> Vec<String> {
    requests
        .iter()
        .map(|r| String::from_utf8_lossy(&r.body).into_owned())
        .filter(|body| body.contains(mark))
        .collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn samples_are_asked_once_each_and_each_planner_reads_its_own_miners() {
    let home = tempfile::tempdir().unwrap();
    let image = scene(home.path());
    let server = MockServer::start().await;
    wiremock::Mock::given(wiremock::matchers::method("POST"))
        .respond_with(Numbered::default())
        .mount(&server)
        .await;
    let first = mapvlm(samples_args(&server, &image, 3), home.path()).await;
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let requests = server.received_requests().await.unwrap();
    assert_eq!(requests.len(), 9, "3 samples of SKM, GKM and the Planner");
    let run: Value = serde_json::from_slice(&first.stdout).unwrap();
    let samples = run["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 3);
    assert_eq!(
        run["steps"], samples[0]["steps"],
        "the first sample at the top"
    );
    assert_eq!(run["agents"], samples[0]["agents"]);
    let planners = bodies(&requests, PLANNER_MARK);
    assert_eq!(planners.len(), 3);
    let mut outputs = std::collections::BTreeSet::new();
    for (k, sample) in samples.iter().enumerate() {
        assert_eq!(sample["sample"].as_u64().unwrap_or(0), k as u64);
        let skm = sample["agents"][0]["output"].as_str().unwrap();
        let gkm = sample["agents"][1]["output"].as_str().unwrap();
        let marks = [
            skm.rsplit("skm-answer-")
                .next()
                .unwrap()
                .trim_end_matches(')'),
            gkm.rsplit(' ').next().unwrap(),
        ];
        let read: Vec<&String> = planners
            .iter()
            .filter(|body| body.contains(&format!("skm-answer-{}", marks[0])))
            .collect();
        assert_eq!(read.len(), 1, "one Planner read SKM {k}'s answer");
        assert!(read[0].contains(marks[1]), "and GKM {k}'s: {}", read[0]);
        outputs.insert(sample["steps"][1].as_str().unwrap().to_string());
    }
    assert_eq!(outputs.len(), 3, "each sample its own plan");

    let again = mapvlm(samples_args(&server, &image, 3), home.path()).await;
    assert!(again.status.success());
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        9,
        "all from the cache"
    );
    let cached: Value = serde_json::from_slice(&again.stdout).unwrap();
    assert_eq!(cached["samples"].as_array().unwrap().len(), 3);
    for (old, new) in samples.iter().zip(cached["samples"].as_array().unwrap()) {
        assert_eq!(old["steps"], new["steps"], "sample k served as sample k");
    }

    let more = mapvlm(samples_args(&server, &image, 4), home.path()).await;
    assert!(more.status.success());
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        12,
        "one more sample asks only for that one"
    );
    let four: Value = serde_json::from_slice(&more.stdout).unwrap();
    let four = four["samples"].as_array().unwrap();
    assert_eq!(four.len(), 4);
    assert_eq!(four[3]["agents"][2]["cached"], false);
    assert_eq!(four[2]["agents"][2]["cached"], true);
}

#[tokio::test(flavor = "multi_thread")]
async fn samples_out_of_range_and_missing_in_a_recording_fail_in_one_line() {
    let home = tempfile::tempdir().unwrap();
    let image = scene(home.path());
    let server = multi_agent_server(ProviderKind::Openai, false, Duration::ZERO).await;
    for bad in ["0", "101"] {
        let mut args = samples_args(&server, &image, 1);
        let at = args.len() - 1;
        args[at] = bad.into();
        let refused = mapvlm(args, home.path()).await;
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success());
        assert!(
            stderr.starts_with(&format!(
                "error: invalid value '{bad}' for '--samples <N>': {bad} is not in 1..=100"
            )),
            "{stderr}"
        );
    }
    assert!(server.received_requests().await.unwrap().is_empty());

    let recording = home.path().join("one.json");
    let mut record = samples_args(&server, &image, 1);
    record.extend(["--record".into(), recording.display().to_string()]);
    assert!(mapvlm(record, home.path()).await.status.success());
    let mut replay: Vec<String> = samples_args(&server, &image, 2)
        .into_iter()
        .filter(|a| a != "--json")
        .collect();
    replay.extend([
        "--replay".into(),
        recording.display().to_string(),
        "--instant".into(),
    ]);
    let replayed = mapvlm(replay, home.path()).await;
    let stderr = String::from_utf8_lossy(&replayed.stderr);
    assert!(!replayed.status.success());
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        3,
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&replayed.stdout);
    assert!(
        stdout.starts_with("Sample 1 of 2:\n1. Walk to the bathtub."),
        "{stdout}"
    );
    assert!(
        stderr.lines().any(|l| l.starts_with("mapvlm: skm (sample 2 of 2) failed: the recording has no sample 2 of this request to test-model")
            && l.ends_with("record it again with --samples 2 or more, or ask for fewer")),
        "{stderr}"
    );
}
