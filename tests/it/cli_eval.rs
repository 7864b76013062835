//! `mapvlm eval`: the paper's Table 3 from the published plans of
//! ../shared/data/alfred30, and a live run against a local server.

use crate::agents_support;
use crate::common;

use std::path::{Path, PathBuf};
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
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{said}");
    assert_eq!(std::fs::read_dir(out.join("tasks")).unwrap().count(), 120);
    // Not on a terminal: the plain progress lines of a live eval.
    for done in (10..=120).step_by(10) {
        let line = format!("mapvlm: {done}/120 plans, 0 failed, ");
        assert!(said.contains(&line), "{line}: {said}");
    }

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
    let data = two_tasks(home.path());
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
    let args = eval_args(&data, &out, &base, &["--no-cache", "--concurrency", "2"]);
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
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{said}");
    assert!(said.contains("mapvlm: 2/2 plans, 0 failed, "), "{said}");
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

/// Two single-image tasks on one scene, under `home/data`.
fn two_tasks(home: &Path) -> std::path::PathBuf {
    let data = home.join("data");
    std::fs::create_dir_all(&data).unwrap();
    scene(&data);
    let tasks = [
        r#"{"id": "t-1", "task": "Put the mug in the sink", "image": "scene.png", "ground_truth": ["Walk to the sink.", "Put the mug in the sink."]}"#,
        r#"{"id": "t-2", "task": "Wash the mug", "image": "scene.png", "ground_truth": ["Walk to the sink.", "Wash the mug."]}"#,
    ];
    std::fs::write(data.join("tasks.jsonl"), tasks.join("\n")).unwrap();
    data
}

/// A config file pricing `test-model` at 2 and 8 dollars per million tokens.
fn priced_config(home: &Path) {
    let dir = home.join("config/mapvlm");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("config.toml"),
        "[prices.openai.\"test-model\"]\ninput_per_million = 2.0\noutput_per_million = 8.0\n",
    )
    .unwrap();
}

async fn run_blocking(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || {
        mapvlm(&args.iter().map(String::as_str).collect::<Vec<_>>(), &home)
    })
    .await
    .unwrap()
}

fn eval_args(data: &Path, out: &Path, base: &str, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = [
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
        "--model",
        "test-model",
    ]
    .map(str::to_string)
    .to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

/// Runs `eval` of `data` at `base` into `home/dir` with `extra` flags:
/// whether it succeeded, and its stderr.
async fn eval_into(
    home: &Path,
    data: &Path,
    base: &str,
    dir: &str,
    extra: &[&str],
) -> (bool, String) {
    let run = run_blocking(eval_args(data, &home.join(dir), base, extra), home).await;
    (
        run.status.success(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

/// A task's result JSON under `home/dir`.
fn task_json(home: &Path, dir: &str, file: &str) -> Value {
    let text = std::fs::read_to_string(home.join(dir).join("tasks").join(file)).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Two tasks, a config pricing `test-model`, and a server answering every
/// plan with the same two steps at its base URL.
async fn two_priced_tasks_and_a_planner() -> (tempfile::TempDir, PathBuf, MockServer, String) {
    let home = tempfile::tempdir().unwrap();
    let data = two_tasks(home.path());
    priced_config(home.path());
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    let plan = whole(provider, "1. Walk to the sink.\n2. Wash the mug.");
    answer(&server, provider, PLANNER_MARK, plan).await;
    let base = format!("{}/v1", server.uri());
    (home, data, server, base)
}

#[tokio::test(flavor = "multi_thread")]
async fn eval_reports_tokens_and_cost_per_task_and_cached_answers_cost_nothing() {
    let (home, data, server, base) = two_priced_tasks_and_a_planner().await;
    let requests = || async { server.received_requests().await.unwrap().len() };

    let (ok, stderr) = eval_into(
        home.path(),
        &data,
        &base,
        "refused",
        &["--max-cost", "0.0001"],
    )
    .await;
    assert!(!ok, "{stderr}");
    assert!(stderr.contains("estimate (rough"), "{stderr}");
    assert!(stderr.contains("exceeds --max-cost 0.0001"), "{stderr}");
    assert_eq!(requests().await, 0, "refused before any request");

    let (ok, stderr) = eval_into(home.path(), &data, &base, "paid", &["--max-cost", "1"]).await;
    assert!(ok, "{stderr}");
    assert_eq!(requests().await, 2);
    let result = task_json(home.path(), "paid", "t-1.single-image.json");
    let agent = &result["cost"]["agents"][0];
    assert_eq!(agent["role"], "single");
    assert_eq!(agent["billing"], "interactive");
    assert_eq!(agent["usage"]["input_tokens"], 100);
    assert_eq!(agent["usage"]["output_tokens"], 20);
    let usd = (100.0 * 2.0 + 20.0 * 8.0) / 1e6;
    assert!((result["cost"]["usd"].as_f64().unwrap() - usd).abs() < 1e-12);
    let total = stderr.lines().find(|l| l.starts_with("total")).unwrap();
    let fields: Vec<&str> = total.split_whitespace().collect();
    assert_eq!(
        fields,
        ["total", "2", "0", "200", "40", "0.0007"],
        "{stderr}"
    );

    let (ok, stderr) = eval_into(home.path(), &data, &base, "cached", &["--max-cost", "0"]).await;
    assert!(ok, "{stderr}");
    assert!(stderr.contains("0 requests to send, 2 cached"), "{stderr}");
    assert_eq!(requests().await, 2, "answers from the cache");
    let result = task_json(home.path(), "cached", "t-2.single-image.json");
    assert_eq!(result["cost"]["agents"][0]["billing"], "cached");
    assert_eq!(result["cost"]["usd"].as_f64(), Some(0.0));
}

#[test]
fn no_cache_turns_the_embedding_cache_off_too() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    let task = r#"{"id": "t-1", "task": "Wash the mug", "ground_truth": ["Walk to the sink.", "Wash the mug."], "single_agent_image": ["Go to the sink.", "Rinse the mug."]}"#;
    std::fs::write(data.join("tasks.jsonl"), task).unwrap();
    let pack = mapvlm::models::models_dir(None);
    let embeddings = home.path().join("cache/mapvlm/embeddings");
    let stored = || {
        std::fs::read_dir(&embeddings)
            .map(|dir| dir.count())
            .unwrap_or(0)
    };
    for (out, extra) in [("uncached", Some("--no-cache")), ("cached", None)] {
        let out = home.path().join(out);
        let mut args = dataset_plans_args(&data, &out, &["--metrics", "kas,pg2s"]);
        args.extend(extra);
        let run = mapvlm_command(&args, home.path())
            .env("MAPVLM_MODELS", &pack)
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let result: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("tasks/t-1.single-image.json")).unwrap(),
        )
        .unwrap();
        assert!(result["pg2s"].as_f64().is_some(), "{result}");
        if extra.is_some() {
            assert_eq!(stored(), 0, "--no-cache stores no embedding");
        }
    }
    assert!(stored() > 0, "without --no-cache the embeddings are stored");
}

#[tokio::test(flavor = "multi_thread")]
async fn eval_samples_are_written_one_file_each_and_a_rerun_asks_only_for_missing_ones() {
    let (home, data, server, base) = two_priced_tasks_and_a_planner().await;
    let requests = || async { server.received_requests().await.unwrap().len() };
    let samples = |n: &'static str| ["--no-cache", "--samples", n];

    let mut refused = samples("3").to_vec();
    refused.extend(["--max-cost", "0"]);
    let (ok, stderr) = eval_into(home.path(), &data, &base, "s", &refused).await;
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("6 requests to send"),
        "every sample counted: {stderr}"
    );
    assert_eq!(requests().await, 0);

    let (ok, stderr) = eval_into(home.path(), &data, &base, "s", &samples("2")).await;
    assert!(ok, "{stderr}");
    assert_eq!(requests().await, 4, "2 tasks × 2 samples");
    let first = task_json(home.path(), "s", "t-1.single-image.json");
    assert!(
        first.get("sample").is_none(),
        "the first sample's file as before"
    );
    let second = task_json(home.path(), "s", "t-1.single-image.s1.json");
    assert_eq!(second["sample"], 1);
    assert_eq!(second["record"]["sample"], 1);
    let markdown = std::fs::read_to_string(home.path().join("s/table3.md")).unwrap();
    assert!(
        markdown.contains("| t-1 | Put the mug in the sink | n/a | 0.750 ±0.000 |"),
        "{markdown}"
    );
    assert!(markdown.contains("Spread over 2 samples"), "{markdown}");

    std::fs::remove_file(home.path().join("s/tasks/t-2.single-image.s1.json")).unwrap();
    let (ok, stderr) = eval_into(home.path(), &data, &base, "s", &samples("2")).await;
    assert!(ok, "{stderr}");
    assert_eq!(requests().await, 5, "only the missing sample asked again");
    let (ok, stderr) = eval_into(home.path(), &data, &base, "s", &samples("3")).await;
    assert!(ok, "{stderr}");
    assert_eq!(requests().await, 7, "one more sample of each task");
    let manifest: Value = serde_json::from_str(
        &std::fs::read_to_string(home.path().join("s/manifest.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(manifest["results"].as_array().unwrap().len(), 6);
}

/// `eval` of the published plans of `data` into `out`, with `extra` flags.
fn dataset_plans_args<'a>(data: &'a Path, out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "eval",
        "--dataset",
        data.to_str().unwrap(),
        "--from-dataset-plans",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    args
}

/// The results of an eval output folder by file name.
fn results_of(out: &Path) -> std::collections::BTreeMap<String, Value> {
    std::fs::read_dir(out.join("tasks"))
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (
                name,
                serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap(),
            )
        })
        .collect()
}

#[test]
fn the_pg2s_flags_change_the_scores_as_score_does_and_a_resume_with_others_is_refused() {
    let home = tempfile::tempdir().unwrap();
    let (out, raised_out) = (home.path().join("eval"), home.path().join("raised"));
    let dataset = common::shared().join("data/alfred30");
    let eval = |out: &Path, extra: &[&str]| {
        let mut args = dataset_plans_args(&dataset, out, &["--approaches", "multi-image"]);
        args.extend_from_slice(extra);
        common::mapvlm(&args)
    };
    let run = eval(&out, &[]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let defaults = results_of(&out);
    assert_eq!(defaults.len(), 30);
    // The folder was scored with the defaults: resuming it with another
    // threshold would mix two settings, so it is refused, naming them.
    let mixed = eval(&out, &["--sentence-threshold", "0.7"]);
    let err = common::stderr(&mixed);
    assert!(!mixed.status.success() && err.contains("pg2s"), "{err}");
    let run = eval(&raised_out, &["--sentence-threshold", "0.7"]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let raised = results_of(&raised_out);

    let mut pairs = String::new();
    for (name, result) in &raised {
        let pair =
            serde_json::json!({"id": name, "gt": result["ground_truth"], "pred": result["steps"]});
        pairs.push_str(&format!("{pair}\n"));
        assert_eq!(
            result["provenance"]["pg2s_settings"]["sentence_threshold"], 0.7,
            "{name}"
        );
    }
    let pairs_file = home.path().join("pairs.jsonl");
    std::fs::write(&pairs_file, pairs).unwrap();
    let scored = common::mapvlm(&[
        "score",
        "--pairs",
        pairs_file.to_str().unwrap(),
        "--json",
        "--sentence-threshold",
        "0.7",
    ]);
    assert!(scored.status.success(), "{}", common::stderr(&scored));
    let mut changed = 0;
    for line in String::from_utf8_lossy(&scored.stdout).lines() {
        let score: Value = serde_json::from_str(line).unwrap();
        let name = score["id"].as_str().unwrap();
        let result = &raised[name];
        for field in ["s_plan", "s_goal", "pg2s"] {
            assert_eq!(result[field], score[field], "{name} {field}: eval as score");
        }
        changed += usize::from(defaults[name]["s_plan"] != result["s_plan"]);
    }
    assert!(
        changed > 0,
        "another threshold gives other scores: some S_plan moves"
    );
}

#[test]
fn eval_with_the_papers_vectors_records_their_identity_and_a_resume_with_glove_is_refused() {
    use mapvlm::models::{WORD2VEC_GOOGLE_NEWS, WORD2VEC_GOOGLE_NEWS_FILE};
    let home = tempfile::tempdir().unwrap();
    // A pack with the user's three models and, as the paper's vectors, the
    // gensim KeyedVectors fixture under the names the Hub's files have.
    let pack = home.path().join("pack");
    let paper = pack.join(WORD2VEC_GOOGLE_NEWS);
    std::fs::create_dir_all(&paper).unwrap();
    for model in [
        mapvlm::models::MPNET,
        mapvlm::models::EN_CORE_WEB_SM,
        mapvlm::models::GLOVE_6B_50D,
    ] {
        std::os::unix::fs::symlink(common::pack_dir().join(model), pack.join(model)).unwrap();
    }
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/keyed_vectors");
    let mut files = Vec::new();
    for (from, to) in [
        ("tiny.model", WORD2VEC_GOOGLE_NEWS_FILE.to_string()),
        (
            "tiny.model.vectors.npy",
            format!("{WORD2VEC_GOOGLE_NEWS_FILE}.vectors.npy"),
        ),
    ] {
        std::fs::copy(fixture.join(from), paper.join(&to)).unwrap();
        let sha = mapvlm::models::sha256_file(&paper.join(&to), |_| {}).unwrap();
        files.push(format!("{to}={sha}"));
    }
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::write(
        data.join("tasks.jsonl"),
        r#"{"id": "t-1", "task": "Put the mug in the sink", "ground_truth": ["Walk to the sink.", "Put the mug in the sink."], "single_agent_image": ["Walk to the sink.", "Drop the mug in the sink."]}"#,
    )
    .unwrap();
    let out = home.path().join("eval");
    let pack_arg = pack.to_string_lossy();
    let paper_run = dataset_plans_args(&data, &out, &["--models-dir", &pack_arg, "--paper"]);
    let run = common::mapvlm(&paper_run);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let expected = format!("{WORD2VEC_GOOGLE_NEWS}: {}", files.join(";"));
    let manifest: Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(
        manifest["provenance"]["word_vectors"].as_str(),
        Some(expected.as_str()),
        "{manifest}"
    );
    for (name, result) in results_of(&out) {
        assert_eq!(
            result["provenance"]["word_vectors"].as_str(),
            Some(expected.as_str()),
            "{name}"
        );
        assert!(result["pg2s"].is_number(), "{name}: {result}");
    }
    // The same folder resumed with the pack's GloVe is refused, naming the field.
    let glove = common::mapvlm(&dataset_plans_args(
        &data,
        &out,
        &["--models-dir", &pack_arg],
    ));
    common::assert_one_line_failure(&glove, "`word_vectors`");
}
