//! `mapvlm eval`: the paper's Table 3 from the published plans of
//! ../shared/data/alfred30, and a live run against a local server.

mod agents_support;
mod common;

use std::path::Path;
use std::process::Output;

use agents_support::*;
use mapvlm::agents::ProviderKind;
use serde_json::Value;
use wiremock::MockServer;

fn mapvlm(args: &[&str], home: &Path) -> Output {
    mapvlm_command(args, home).output().unwrap()
}

#[test]
fn published_plans_give_table_3_for_all_30_tasks_and_4_approaches() {
    let home = tempfile::tempdir().unwrap();
    let out = home.path().join("eval");
    let dataset = common::shared().join("data/alfred30");
    let args = [
        "eval",
        "--dataset",
        dataset.to_str().unwrap(),
        "--from-dataset-plans",
        "--metrics",
        "kas",
        "--out",
        out.to_str().unwrap(),
    ];
    let run = mapvlm(&args, home.path());
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read_dir(out.join("tasks")).unwrap().count(), 120);

    let golden: Vec<Value> = common::golden("pg2s.dev.jsonl");
    let csv = std::fs::read_to_string(out.join("table3.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows[0][2..],
        [
            "single-table_pg2s",
            "single-table_kas",
            "multi-table_pg2s",
            "multi-table_kas",
            "single-image_pg2s",
            "single-image_kas",
            "multi-image_pg2s",
            "multi-image_kas"
        ]
    );
    assert_eq!(rows.len(), 1 + 30 + 1);
    let fields = [
        "single_agent_table",
        "multi_agent_table",
        "single_agent_image",
        "multi_agent_image",
    ];
    let mut compared = 0;
    for row in &rows[1..31] {
        for (column, field) in fields.iter().enumerate() {
            let id = format!("{}/{field}", row[0]);
            let expected = golden.iter().find(|g| g["id"] == id.as_str()).unwrap();
            let cell = row[row.len() - 8 + column * 2 + 1];
            match expected["kas"].as_f64() {
                Some(kas) => {
                    assert_eq!(cell, format!("{kas:.6}"), "{id}");
                    compared += 1;
                }
                None => assert_eq!(cell, "", "{id}"),
            }
        }
    }
    assert!(compared > 60, "{compared} KAS values compared");
    let markdown = std::fs::read_to_string(out.join("table3.md")).unwrap();
    assert_eq!(markdown.lines().count(), 2 + 30 + 1);
    assert!(markdown.lines().last().unwrap().starts_with("| **Mean** |"));

    let file = out.join("tasks/trial_T20190906_234735_610018-1.multi-image.json");
    let mut done: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(done["source"], "dataset");
    done["kas"] = Value::from(0.125);
    std::fs::write(&file, done.to_string()).unwrap();
    let again = mapvlm(&args, home.path());
    assert!(again.status.success());
    let csv = std::fs::read_to_string(out.join("table3.csv")).unwrap();
    assert!(
        csv.lines().nth(1).unwrap().ends_with(",0.125000"),
        "a re-run reads what is done instead of redoing it"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_live_eval_plans_each_task_once_and_resumes() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    scene(&data);
    let tasks = [
        r#"{"id": "t-1", "task": "Put the mug in the sink", "image": "scene.png", "ground_truth": ["Walk to the sink.", "Put the mug in the sink."]}"#,
        r#"{"id": "t-2", "task": "Wash the mug", "image": "scene.png", "ground_truth": ["Walk to the sink.", "Wash the mug."]}"#,
    ];
    std::fs::write(data.join("tasks.jsonl"), tasks.join("\n")).unwrap();
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    answer(
        &server,
        provider,
        PLANNER_MARK,
        streamed(
            provider,
            &["1. Walk to the sink.\n", "2. Put the mug in the sink."],
            true,
        ),
    )
    .await;
    let out = home.path().join("eval");
    let base = format!("{}/v1", server.uri());
    let args: Vec<String> = [
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
        &base,
        "--no-cache",
        "--concurrency",
        "2",
    ]
    .map(str::to_string)
    .to_vec();
    let home_path = home.path().to_path_buf();
    let run = {
        let (args, home_path) = (args.clone(), home_path.clone());
        tokio::task::spawn_blocking(move || {
            mapvlm(
                &args.iter().map(String::as_str).collect::<Vec<_>>(),
                &home_path,
            )
        })
        .await
        .unwrap()
    };
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(server.received_requests().await.unwrap().len(), 2);
    let result: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("tasks/t-1.single-image.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(result["source"], "model");
    assert_eq!(result["steps"][1], "Put the mug in the sink.");
    let expected = mapvlm::metrics::kas::kas(
        &["Walk to the sink.", "Put the mug in the sink."],
        &["Walk to the sink.", "Put the mug in the sink."],
    );
    assert_eq!(result["kas"].as_f64(), expected.kas);
    assert_eq!(result["record"]["agents"][0]["role"], "single");
    let rerun = tokio::task::spawn_blocking(move || {
        mapvlm(
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
            &home_path,
        )
    })
    .await
    .unwrap();
    assert!(rerun.status.success());
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        2,
        "nothing planned twice"
    );
    let csv = std::fs::read_to_string(out.join("table3.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
}
