//! `mapvlm eval --batch` end to end against local servers that implement
//! the OpenAI Batch API (files, batches, output and error files) and
//! Anthropic's Message Batches (create, poll, results), over a few alfred30
//! tasks: a restart between submission and completion, staged multi-agent
//! plans, an expired request retried by the next run, and no key on disk.

use crate::agents_support;
use crate::common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use agents_support::*;
use serde_json::{json, Value};
use wiremock::matchers::any;
use wiremock::{Mock, MockServer, Request, Respond, ResponseTemplate};

/// The state of the fake batch service.
#[derive(Default)]
struct State {
    /// Uploaded OpenAI files: their JSONL lines.
    files: HashMap<String, Vec<Value>>,
    /// Each batch's requests (`custom_id` and the request body), by id.
    batches: Vec<(String, Vec<(String, Value)>)>,
    /// Status polls answered.
    polls: usize,
    /// Whether batches have ended.
    ready: bool,
    /// Requests whose body contains this text (with the GKM prompt) expire.
    expire: Option<String>,
    /// Requests that did not carry the key as the protocol says.
    unauthorised: usize,
    /// Bodies the key was found in.
    leaked: usize,
    /// The server's address, for Anthropic's `results_url`.
    origin: String,
}

/// A wiremock responder speaking both providers' batch protocols.
#[derive(Clone, Default)]
struct FakeBatches(Arc<Mutex<State>>);

impl FakeBatches {
    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.0.lock().unwrap()
    }

    /// The hand-written answer to a request body, or `None` when it expires.
    fn answer_to(&self, body: &Value) -> Option<String> {
        let text = body.to_string();
        let state = self.state();
        if let Some(mark) = &state.expire {
            if text.contains(mark.as_str()) && text.contains(GKM_MARK) {
                return None;
            }
        }
        Some(if text.contains(SKM_MARK) {
            SKM_TEXT.to_string()
        } else if text.contains(GKM_MARK) {
            format!("{GKM_TEXT} (the key was {KEY})")
        } else {
            PLAN_TEXT.to_string()
        })
    }

    fn openai(&self, request: &Request, path: &str) -> ResponseTemplate {
        let bearer = format!("Bearer {KEY}");
        // With credentials in the base URL, reqwest sends them as a Basic
        // authorization before the key's Bearer one.
        let authorised = request
            .headers
            .get_all("authorization")
            .iter()
            .any(|v| v.as_bytes() == bearer.as_bytes());
        if !authorised {
            self.state().unauthorised += 1;
            return ResponseTemplate::new(401);
        }
        let body = String::from_utf8_lossy(&request.body).into_owned();
        match (request.method.as_str(), path) {
            ("POST", "/v1/files") => {
                assert!(body.contains("name=\"purpose\"") && body.contains("\r\n\r\nbatch\r\n"));
                let lines: Vec<Value> = body
                    .lines()
                    .filter(|l| l.starts_with('{'))
                    .map(|l| serde_json::from_str(l).unwrap())
                    .collect();
                for line in &lines {
                    assert_eq!(line["method"], "POST");
                    assert_eq!(line["url"], "/v1/chat/completions");
                    assert_eq!(line["body"]["stream"], false);
                }
                let mut state = self.state();
                let id = format!("file-{}", state.files.len() + 1);
                state.files.insert(id.clone(), lines);
                ResponseTemplate::new(200)
                    .set_body_json(json!({"id": id, "object": "file", "purpose": "batch"}))
            }
            ("POST", "/v1/batches") => {
                let create: Value = serde_json::from_str(&body).unwrap();
                assert_eq!(create["endpoint"], "/v1/chat/completions");
                assert_eq!(create["completion_window"], "24h");
                let mut state = self.state();
                let Some(lines) = create["input_file_id"]
                    .as_str()
                    .and_then(|id| state.files.get(id))
                else {
                    return ResponseTemplate::new(400);
                };
                let requests = lines
                    .iter()
                    .map(|l| {
                        (
                            l["custom_id"].as_str().unwrap().to_string(),
                            l["body"].clone(),
                        )
                    })
                    .collect();
                let id = format!("batch_{}", state.batches.len() + 1);
                state.batches.push((id.clone(), requests));
                ResponseTemplate::new(200)
                    .set_body_json(json!({"id": id, "object": "batch", "status": "validating"}))
            }
            ("GET", _) if path.starts_with("/v1/batches/") => {
                let id = &path["/v1/batches/".len()..];
                let mut state = self.state();
                state.polls += 1;
                let ready = state.ready;
                let total = self.requests_of(&state, id).len();
                drop(state);
                let failed = if ready { self.results(id).1.len() } else { 0 };
                ResponseTemplate::new(200).set_body_json(json!({
                    "id": id, "object": "batch",
                    "status": if ready { "completed" } else { "in_progress" },
                    "request_counts": {"total": total, "completed": if ready { total - failed } else { 0 }, "failed": failed},
                    "output_file_id": ready.then(|| format!("out-{id}")),
                    "error_file_id": (ready && failed > 0).then(|| format!("err-{id}")),
                }))
            }
            ("GET", _) if path.starts_with("/v1/files/") => {
                let file = path["/v1/files/".len()..].trim_end_matches("/content");
                let (answered, expired) = match file.split_once('-') {
                    Some((_, id)) => self.results(id),
                    None => return ResponseTemplate::new(404),
                };
                let lines: Vec<String> = if file.starts_with("out-") {
                    answered
                        .iter()
                        .map(|(id, text)| {
                            json!({"id": "batch_req_1", "custom_id": id, "response": {"status_code": 200, "request_id": "req_1", "body": {
                                "id": "cmpl-1", "object": "chat.completion",
                                "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
                                "usage": {"prompt_tokens": 100, "completion_tokens": 20, "total_tokens": 120}
                            }}, "error": null})
                            .to_string()
                        })
                        .collect()
                } else {
                    expired
                        .iter()
                        .map(|id| {
                            json!({"id": "batch_req_2", "custom_id": id, "response": null,
                                "error": {"code": "batch_expired", "message": "This request could not be executed before the completion window expired."}})
                            .to_string()
                        })
                        .collect()
                };
                ResponseTemplate::new(200).set_body_string(lines.join("\n") + "\n")
            }
            _ => ResponseTemplate::new(404),
        }
    }

    fn anthropic(&self, request: &Request, path: &str) -> ResponseTemplate {
        let key = request.headers.get("x-api-key").map(|v| v.as_bytes());
        let version = request
            .headers
            .get("anthropic-version")
            .map(|v| v.as_bytes());
        if key != Some(KEY.as_bytes()) || version != Some(b"2023-06-01".as_slice()) {
            self.state().unauthorised += 1;
            return ResponseTemplate::new(401);
        }
        let origin = self.state().origin.clone();
        match (request.method.as_str(), path) {
            ("POST", "/v1/messages/batches") => {
                let create: Value = serde_json::from_slice(&request.body).unwrap();
                let requests: Vec<(String, Value)> = create["requests"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|r| {
                        assert!(r["params"]["max_tokens"].is_u64());
                        assert!(r["params"].get("stream").is_none());
                        (
                            r["custom_id"].as_str().unwrap().to_string(),
                            r["params"].clone(),
                        )
                    })
                    .collect();
                let mut state = self.state();
                let id = format!("msgbatch_{}", state.batches.len() + 1);
                let total = requests.len();
                state.batches.push((id.clone(), requests));
                ResponseTemplate::new(200).set_body_json(json!({
                    "id": id, "type": "message_batch", "processing_status": "in_progress",
                    "request_counts": {"processing": total, "succeeded": 0, "errored": 0, "canceled": 0, "expired": 0},
                    "results_url": null
                }))
            }
            ("GET", _) if path.ends_with("/results") => {
                let id = path["/v1/messages/batches/".len()..].trim_end_matches("/results");
                let (answered, expired) = self.results(id);
                let mut lines: Vec<String> = answered
                    .iter()
                    .map(|(id, text)| {
                        json!({"custom_id": id, "result": {"type": "succeeded", "message": {
                            "id": "msg_1", "type": "message", "role": "assistant",
                            "content": [{"type": "text", "text": text}],
                            "usage": {"input_tokens": 100, "output_tokens": 20}
                        }}})
                        .to_string()
                    })
                    .collect();
                lines.extend(
                    expired.iter().map(|id| {
                        json!({"custom_id": id, "result": {"type": "expired"}}).to_string()
                    }),
                );
                ResponseTemplate::new(200).set_body_string(lines.join("\n"))
            }
            ("GET", _) if path.starts_with("/v1/messages/batches/") => {
                let id = &path["/v1/messages/batches/".len()..];
                let mut state = self.state();
                state.polls += 1;
                let ready = state.ready;
                let total = self.requests_of(&state, id).len();
                drop(state);
                let (answered, expired) = if ready {
                    self.results(id)
                } else {
                    (Vec::new(), Vec::new())
                };
                ResponseTemplate::new(200).set_body_json(json!({
                    "id": id, "type": "message_batch",
                    "processing_status": if ready { "ended" } else { "in_progress" },
                    "request_counts": {"processing": if ready { 0 } else { total }, "succeeded": answered.len(), "errored": 0, "canceled": 0, "expired": expired.len()},
                    "results_url": ready.then(|| format!("{origin}/v1/messages/batches/{id}/results")),
                }))
            }
            _ => ResponseTemplate::new(404),
        }
    }

    fn requests_of(&self, state: &State, id: &str) -> Vec<(String, Value)> {
        state
            .batches
            .iter()
            .find(|(batch, _)| batch == id)
            .map(|(_, requests)| requests.clone())
            .unwrap_or_default()
    }

    /// The answered `(custom_id, text)` and the expired `custom_id`s of a batch.
    fn results(&self, id: &str) -> (Vec<(String, String)>, Vec<String>) {
        let requests = self.requests_of(&self.state(), id);
        let mut answered = Vec::new();
        let mut expired = Vec::new();
        for (custom_id, body) in requests {
            match self.answer_to(&body) {
                Some(text) => answered.push((custom_id, text)),
                None => expired.push(custom_id),
            }
        }
        (answered, expired)
    }
}

impl Respond for FakeBatches {
    fn respond(&self, request: &Request) -> ResponseTemplate {
        if String::from_utf8_lossy(&request.body).contains(KEY) {
            self.state().leaked += 1;
        }
        let path = request.url.path().to_string();
        if path.starts_with("/v1/messages") {
            self.anthropic(request, &path)
        } else {
            self.openai(request, &path)
        }
    }
}

async fn fake_server() -> (MockServer, FakeBatches) {
    let server = MockServer::start().await;
    let fake = FakeBatches::default();
    fake.state().origin = server.uri();
    Mock::given(any())
        .respond_with(fake.clone())
        .mount(&server)
        .await;
    (server, fake)
}

/// A dataset of the alfred30 tasks at `lines` (0-based), its image paths
/// made absolute, under `home/data`.
fn alfred_tasks(home: &Path, lines: &[usize]) -> PathBuf {
    let source = common::shared().join("data/alfred30");
    let text = std::fs::read_to_string(source.join("tasks.jsonl")).unwrap();
    let all: Vec<&str> = text.lines().collect();
    let picked: Vec<String> = lines.iter().map(|&i| all[i].to_string()).collect();
    let data = home.join("data");
    std::fs::create_dir_all(&data).unwrap();
    // The images stay shared, linked into the dataset as clusters do.
    std::os::unix::fs::symlink(source.join("images"), data.join("images")).unwrap();
    std::fs::write(data.join("tasks.jsonl"), picked.join("\n")).unwrap();
    data
}

fn batch_args(data: &Path, out: &Path, base: &str, provider: &str, approach: &str) -> Vec<String> {
    [
        "eval",
        "--dataset",
        data.to_str().unwrap(),
        "--approaches",
        approach,
        "--metrics",
        "kas",
        "--out",
        out.to_str().unwrap(),
        "--provider",
        provider,
        "--base-url",
        base,
        "--model",
        "test-model",
        "--max-image-edge",
        "64",
        "--batch",
        "--poll-interval",
        "0.02",
    ]
    .map(str::to_string)
    .to_vec()
}

async fn run(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || {
        mapvlm_command(&args, &home)
            .env("ANTHROPIC_API_KEY", KEY)
            .env_remove("ANTHROPIC_BASE_URL")
            .output()
            .unwrap()
    })
    .await
    .unwrap()
}

/// Every file under `dir` whose bytes contain `secret`.
fn files_with(dir: &Path, secret: &str) -> Vec<PathBuf> {
    common::files_under(dir)
        .into_iter()
        .filter(|(_, bytes)| String::from_utf8_lossy(bytes).contains(secret))
        .map(|(path, _)| path)
        .collect()
}

fn task_json(out: &Path, file: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("tasks").join(file)).unwrap()).unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn an_interrupted_openai_batch_eval_resumes_from_the_saved_ids_without_submitting_again() {
    let home = tempfile::tempdir().unwrap();
    let data = alfred_tasks(home.path(), &[0, 3, 6]);
    let (server, fake) = fake_server().await;
    let out = home.path().join("eval");
    // Credentials in the base URL reach the server, never batches.json.
    let base = format!("{}/v1", server.uri()).replace("://", "://user:url-secret@");
    let args = batch_args(&data, &out, &base, "openai", "single-image");

    let log = home.path().join("first.stderr");
    let mut first = mapvlm_command(&args, home.path())
        .stderr(Stdio::from(std::fs::File::create(&log).unwrap()))
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let saved = out.join("batches.json");
    let started = Instant::now();
    while !(saved.exists() && fake.state().polls >= 2) {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no batch was polled: {}",
            std::fs::read_to_string(&log).unwrap()
        );
        assert!(
            first.try_wait().unwrap().is_none(),
            "{}",
            std::fs::read_to_string(&log).unwrap()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    first.kill().unwrap();
    first.wait().unwrap();
    let first_log = std::fs::read_to_string(&log).unwrap();
    assert!(first_log.contains("estimate (rough"), "{first_log}");
    let saved_text = std::fs::read_to_string(&saved).unwrap();
    assert!(!saved_text.contains("url-secret"), "{saved_text}");
    assert!(saved_text.contains("://***@"), "{saved_text}");
    let ids: Value = serde_json::from_str(&saved_text).unwrap();
    assert_eq!(ids["batches"][0]["id"], "batch_1");
    assert_eq!(ids["batches"][0]["keys"].as_array().unwrap().len(), 3);
    assert_eq!(fake.state().batches.len(), 1);

    fake.state().ready = true;
    let second = run(args.clone(), home.path()).await;
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{stderr}");
    assert_eq!(
        fake.state().batches.len(),
        1,
        "the second run submitted nothing"
    );
    assert!(
        stderr.contains("0 batches submitted (0 requests), 3 answers collected"),
        "{stderr}"
    );
    let result = task_json(&out, "trial_T20190906_234735_610018-1.single-image.json");
    assert_eq!(result["source"], "model");
    assert_eq!(result["steps"][0], "Walk to the bathtub.");
    assert_eq!(result["cost"]["agents"][0]["billing"], "batch");
    assert_eq!(result["cost"]["agents"][0]["usage"]["input_tokens"], 100);
    let saved_now: Value = serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    assert_eq!(saved_now["batches"], json!([]));

    let requests_before = server.received_requests().await.unwrap().len();
    let mut live = args.clone();
    live.truncate(live.len() - 3);
    let again = home.path().join("again");
    let out_arg = live.iter().position(|a| a == "--out").unwrap() + 1;
    live[out_arg] = again.to_str().unwrap().to_string();
    let reuse = run(live, home.path()).await;
    assert!(
        reuse.status.success(),
        "{}",
        String::from_utf8_lossy(&reuse.stderr)
    );
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        requests_before,
        "a later run without --batch answers from the cache"
    );
    assert_eq!(
        task_json(&again, "trial_T20190906_234735_610018-1.single-image.json")["cost"]["agents"][0]
            ["billing"],
        "cached"
    );

    let state = fake.state();
    assert_eq!((state.unauthorised, state.leaked), (0, 0));
    assert_eq!(files_with(home.path(), KEY), Vec::<PathBuf>::new());
    assert_eq!(files_with(home.path(), "url-secret"), Vec::<PathBuf>::new());
}

#[tokio::test(flavor = "multi_thread")]
async fn anthropic_batches_run_in_stages_and_an_expired_request_is_retried_by_the_next_run() {
    let home = tempfile::tempdir().unwrap();
    let data = alfred_tasks(home.path(), &[0, 3]);
    let text = std::fs::read_to_string(data.join("tasks.jsonl")).unwrap();
    let second_task: Value = serde_json::from_str(text.lines().nth(1).unwrap()).unwrap();
    let (server, fake) = fake_server().await;
    {
        let mut state = fake.state();
        state.ready = true;
        state.expire = Some(second_task["task"].as_str().unwrap().to_string());
    }
    let out = home.path().join("eval");
    let args = batch_args(&data, &out, &server.uri(), "anthropic", "multi-image");

    let first = run(args.clone(), home.path()).await;
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(!first.status.success(), "{stderr}");
    let sizes: Vec<usize> = fake.state().batches.iter().map(|(_, r)| r.len()).collect();
    assert_eq!(sizes, [4, 1], "the miners of both tasks, then one Planner");
    let expired: Vec<&str> = stderr
        .lines()
        .filter(|l| {
            l.starts_with("mapvlm: batch msgbatch_1 request ")
                && l.ends_with(": expired before it was answered")
        })
        .collect();
    assert_eq!(expired.len(), 1, "{stderr}");
    let failed_task = format!(
        "mapvlm: {} multi-image: gkm has no answer from the batch",
        second_task["id"].as_str().unwrap()
    );
    assert!(stderr.contains(&failed_task), "{stderr}");
    assert!(
        stderr.contains("run the same command again to retry"),
        "{stderr}"
    );
    let done = task_json(&out, "trial_T20190906_234735_610018-1.multi-image.json");
    let agents = done["cost"]["agents"].as_array().unwrap();
    let roles: Vec<&str> = agents.iter().map(|a| a["role"].as_str().unwrap()).collect();
    assert_eq!(roles, ["skm", "gkm", "planner"]);
    assert!(agents.iter().all(|a| a["billing"] == "batch"));
    assert_eq!(done["steps"].as_array().unwrap().len(), 6);
    let total = stderr.lines().find(|l| l.starts_with("total")).unwrap();
    let fields: Vec<&str> = total.split_whitespace().collect();
    assert_eq!(
        fields[..5],
        ["total", "4", "0", "400", "80"],
        "the stranded SKM answer is paid too: {stderr}"
    );
    assert!(done["record"]["agents"][1]["output"]
        .as_str()
        .unwrap()
        .contains("[redacted]"));

    fake.state().expire = None;
    let second = run(args, home.path()).await;
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{stderr}");
    let sizes: Vec<usize> = fake.state().batches.iter().map(|(_, r)| r.len()).collect();
    assert_eq!(
        sizes,
        [4, 1, 1, 1],
        "only the expired request, then its Planner"
    );
    let retried = task_json(
        &out,
        &format!("{}.multi-image.json", second_task["id"].as_str().unwrap()),
    );
    assert_eq!(retried["cost"]["agents"][0]["billing"], "cached");
    assert_eq!(retried["cost"]["agents"][1]["billing"], "batch");

    let state = fake.state();
    assert_eq!((state.unauthorised, state.leaked), (0, 0));
    assert_eq!(files_with(home.path(), KEY), Vec::<PathBuf>::new());
}
