//! Fault matrix, provider half (see `tests/FAULTS.md`): the release commands
//! against a local server (wiremock) that misbehaves, and runs whose output
//! cannot be written.

use crate::agents_support;
use crate::common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};
use std::sync::{Arc, Mutex};

use agents_support::*;
use mapvlm::agents::cache::ResponseCache;
use mapvlm::agents::replay::Recording;
use mapvlm::agents::{Approach, ProviderKind};
use mapvlm::workbench::session::{self, GroundTruthSource, PlanSource, Session, SESSION_VERSION};
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

/// `eval` of `data` through the single-image agent at `base`, into `out`
/// (also the hostile half's).
pub(crate) fn eval_args(data: &Path, out: &Path, base: &str) -> Vec<String> {
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

pub(crate) async fn planning_server() -> MockServer {
    let server = MockServer::start().await;
    answer_plans(&server).await;
    server
}

/// Mounts on `server` the streamed two-step plan of [`planning_server`].
pub(crate) async fn answer_plans(server: &MockServer) {
    let provider = ProviderKind::Openai;
    let plan = streamed(
        provider,
        &["1. Walk to the sink.\n", "2. Wash the mug."],
        true,
    );
    answer(server, provider, PLANNER_MARK, plan).await;
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

/// `plan --approach single-image` of a fresh scene against `base`, with
/// `extra` flags; the image is made under `home`.
pub(crate) fn plan_args(home: &Path, base: &str, extra: &[&str]) -> Vec<String> {
    let image = scene(home);
    let mut args = strings(&[
        "plan",
        "--task",
        "Wash the mug",
        "--image",
        image.to_str().unwrap(),
        "--approach",
        "single-image",
        "--base-url",
        base,
    ]);
    args.extend(strings(extra));
    args
}

fn err_of(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn contains(haystack: &[u8], needle: &str) -> bool {
    haystack
        .windows(needle.len())
        .any(|w| w == needle.as_bytes())
}

#[tokio::test(flavor = "multi_thread")]
async fn an_echoed_key_never_reaches_cache_record_or_output() {
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        for stream in [true, false] {
            let home = tempfile::tempdir().unwrap();
            let server = MockServer::start().await;
            let (head, tail) = KEY.split_at(9);
            let text = format!("1. Walk to the sink, key {KEY}.\n2. Wash the mug.");
            let response = if stream {
                streamed(
                    provider,
                    &[
                        "1. Walk to the sink, key ",
                        head,
                        tail,
                        ".\n2. Wash the mug.",
                    ],
                    true,
                )
            } else {
                whole(provider, &text)
            };
            answer(&server, provider, PLANNER_MARK, response).await;
            let base = base_url(&server, provider);
            let record = home.path().join("rec.json");
            let mut extra = vec![
                "--provider",
                provider.name(),
                "--json",
                "--record",
                record.to_str().unwrap(),
            ];
            if !stream {
                extra.push("--no-stream");
            }
            let args = plan_args(home.path(), &base, &extra);
            let home_path = home.path().to_path_buf();
            let out = tokio::task::spawn_blocking(move || {
                mapvlm_command(&args, &home_path)
                    .env("ANTHROPIC_API_KEY", KEY)
                    .output()
                    .unwrap()
            })
            .await
            .unwrap();
            let err = err_of(&out);
            let label = format!("{provider:?} stream={stream}");
            assert!(out.status.success(), "{label}: {err}");
            assert!(
                contains(&out.stdout, "[redacted]"),
                "{label}: the echo is shown redacted: {}",
                String::from_utf8_lossy(&out.stdout)
            );
            assert!(
                !contains(&out.stdout, KEY) && !err.contains(KEY),
                "{label}: key in output"
            );
            let files = common::files_under(home.path());
            assert!(
                files
                    .iter()
                    .any(|(p, _)| p.starts_with(home.path().join("cache"))),
                "{label}: cached"
            );
            assert!(record.is_file(), "{label}: recorded");
            for (path, bytes) in files {
                assert!(!contains(&bytes, KEY), "{label}: key in {}", path.display());
            }
        }
    }
}

/// The echoed answer of the planner, streamed with the key split across
/// pieces or whole.
fn echo(provider: ProviderKind, stream: bool) -> wiremock::ResponseTemplate {
    let (head, tail) = KEY.split_at(9);
    if stream {
        let pieces = [
            "1. Walk to the sink, key ",
            head,
            tail,
            ".\n2. Wash the mug.",
        ];
        streamed(provider, &pieces, true)
    } else {
        whole(
            provider,
            &format!("1. Walk to the sink, key {KEY}.\n2. Wash the mug."),
        )
    }
}

/// The session the workbench would save after `record`'s run.
fn session_of(record: &mapvlm::agents::pipeline::PlanRecord) -> Session {
    let agents = record.agents.clone();
    Session {
        version: SESSION_VERSION,
        current: session::SourceState {
            task_id: None,
            approach: record.approach,
            ground_truth_source: GroundTruthSource::Typed,
            ground_truth: vec!["Walk to the sink.".into()],
            plan_source: PlanSource::Run { run: 1 },
            plan: record.steps.clone(),
            settings: agents
                .iter()
                .map(|a| (a.role, a.settings.clone()))
                .collect(),
            outputs: agents
                .iter()
                .map(|a| (a.role, a.output_text().to_string()))
                .collect(),
            ran_with: BTreeMap::new(),
            runs: vec![session::RunRecord {
                id: 1,
                started_unix: 0,
                approach: record.approach,
                task: record.task.clone(),
                agents,
                prompts: BTreeMap::new(),
                plan: record.steps.clone(),
                ground_truth: vec!["Walk to the sink.".into()],
                scores: None,
                state: session::RunState::Finished,
                error: None,
                reason: None,
                corrupted: None,
                steps: Vec::new(),
                samples: Vec::new(),
            }],
        },
        parked: Vec::new(),
        prompts: BTreeMap::new(),
        theme: "dark".into(),
        image: true,
        samples: 1,
        draft: None,
    }
}

/// `grep -r -F -l NEEDLE DIR`: the files under `dir` holding `needle`.
/// Fails the test when grep cannot run.
fn grep_files(needle: &str, dir: &Path) -> Vec<String> {
    let out = Command::new("grep")
        .args(["-r", "-F", "-l", "--", needle])
        .arg(dir)
        .output()
        .unwrap_or_else(|e| panic!("grep is needed for this test: {e}"));
    let code = out.status.code();
    assert!(
        matches!(code, Some(0 | 1)),
        "grep failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

/// The echo case as a reviewer would check it: a server echoing the key in
/// a successful answer (both providers, streamed and whole), answered to
/// the binary (`RUST_LOG=debug`, its stdout and stderr kept in files, its
/// response cache and record) and to the library (every tracing event at
/// TRACE written to a log file, its cache and recording, and the session
/// the workbench saves through the session module); then `grep -r` of the
/// key over all of it finds nothing, while the redacted echo is there.
#[tokio::test(flavor = "multi_thread")]
async fn grep_finds_no_echoed_key_in_cache_record_session_log_or_output() {
    let home = tempfile::tempdir().unwrap();
    let log_path = home.path().join("log/trace.log");
    std::fs::create_dir_all(home.path().join("log")).unwrap();
    let log = std::fs::File::create(&log_path).unwrap();
    let subscriber = tracing_subscriber::fmt()
        .with_max_level(tracing::Level::TRACE)
        .with_ansi(false)
        .with_writer(Mutex::new(log))
        .finish();
    // Global, so that events from the runtime's worker threads are kept too.
    tracing::subscriber::set_global_default(subscriber).unwrap();
    let recording = Arc::new(Mutex::new(Recording::new("echo")));
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        for stream in [true, false] {
            let label = format!(
                "{}-{}",
                provider.name(),
                if stream { "stream" } else { "whole" }
            );
            let server = MockServer::start().await;
            answer(&server, provider, PLANNER_MARK, echo(provider, stream)).await;
            let record = home.path().join(format!("records/{label}.json"));
            let mut extra = vec!["--provider", provider.name(), "--json", "--record"];
            extra.push(record.to_str().unwrap());
            if !stream {
                extra.push("--no-stream");
            }
            let args = plan_args(home.path(), &base_url(&server, provider), &extra);
            let run_home = home.path().to_path_buf();
            let out = tokio::task::spawn_blocking(move || {
                mapvlm_command(&args, &run_home)
                    .env("ANTHROPIC_API_KEY", KEY)
                    .env("RUST_LOG", "debug")
                    .output()
                    .unwrap()
            })
            .await
            .unwrap();
            assert!(out.status.success(), "{label}: {}", err_of(&out));
            let outputs = home.path().join("output");
            std::fs::create_dir_all(&outputs).unwrap();
            std::fs::write(outputs.join(format!("{label}.stdout")), &out.stdout).unwrap();
            std::fs::write(outputs.join(format!("{label}.stderr")), &out.stderr).unwrap();

            let runner = runner(settings(&server, provider, stream))
                .with_cache(ResponseCache::new(home.path().join("library-cache")))
                .with_recorder(recording.clone());
            let image = image_input(scene(home.path()));
            let (done, _) = plan_with_events(&runner, Approach::SingleImage, &image).await;
            assert!(!done.steps.is_empty(), "{label}: planned");
            let path = home.path().join(format!("state/{label}.session.json"));
            session::save(&path, &session_of(&done)).unwrap();
        }
    }
    let recorded = home.path().join("records/library.json");
    recording.lock().unwrap().save(&recorded).unwrap();
    assert!(
        std::fs::metadata(&log_path).unwrap().len() > 0,
        "tracing wrote the log"
    );

    assert_eq!(
        grep_files(KEY, home.path()),
        Vec::<String>::new(),
        "the key on disk"
    );
    let redacted = grep_files("[redacted]", home.path());
    for part in [
        "/cache/",
        "/library-cache/",
        "/records/",
        "/state/",
        "/output/",
    ] {
        let under = |f: &String| f.contains(part);
        assert!(
            redacted.iter().any(under),
            "no redacted echo under {part}: {redacted:?}"
        );
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_key_in_an_error_body_is_redacted() {
    let home = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let body = format!(r#"{{"error": {{"message": "bad request for key {KEY}"}}}}"#);
    let response = wiremock::ResponseTemplate::new(400).set_body_string(body);
    answer(&server, ProviderKind::Openai, PLANNER_MARK, response).await;
    let base = base_url(&server, ProviderKind::Openai);
    let out = mapvlm(plan_args(home.path(), &base, &["--no-cache"]), home.path()).await;
    let err = err_of(&out);
    assert!(!out.status.success());
    assert!(err.contains("bad request for key [redacted]"), "{err}");
    assert!(!err.contains(KEY), "{err}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_401_names_the_variable_to_set() {
    let home = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let refused = wiremock::ResponseTemplate::new(401).set_body_string("no");
    answer(&server, ProviderKind::Openai, PLANNER_MARK, refused).await;
    let base = base_url(&server, ProviderKind::Openai);
    let out = mapvlm(plan_args(home.path(), &base, &["--no-cache"]), home.path()).await;
    let err = err_of(&out);
    assert!(!out.status.success());
    assert!(err.contains("set OPENAI_API_KEY"), "{err}");
}

#[tokio::test(flavor = "multi_thread")]
async fn an_html_page_with_status_200_is_named_a_web_page() {
    for stream in [true, false] {
        let home = tempfile::tempdir().unwrap();
        let server = MockServer::start().await;
        let page = wiremock::ResponseTemplate::new(200).set_body_raw(
            "<html><body>Welcome</body></html>",
            "text/html; charset=utf-8",
        );
        answer(&server, ProviderKind::Openai, PLANNER_MARK, page).await;
        let base = base_url(&server, ProviderKind::Openai);
        let extra: &[&str] = if stream {
            &["--no-cache"]
        } else {
            &["--no-cache", "--no-stream"]
        };
        let out = mapvlm(plan_args(home.path(), &base, extra), home.path()).await;
        let err = err_of(&out);
        assert!(!out.status.success());
        assert!(
            err.contains("sent a web page (text/html)"),
            "stream={stream}: {err}"
        );
        assert!(err.contains("/v1"), "{err}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn malformed_base_urls_and_numbers_are_refused_before_any_request() {
    let home = tempfile::tempdir().unwrap();
    let server = planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    let cases: [(&str, &[&str], &str); 14] = [
        ("localhost:8000/v1", &[], "not http or https"),
        ("http//localhost/v1", &[], "is not a URL"),
        (
            &base,
            &["--timeout", "1e30"],
            "timeout 1000000000000000000000000000000",
        ),
        (&base, &["--timeout", "-3"], "give a number of seconds"),
        (&base, &["--timeout", "NaN"], "give a number of seconds"),
        (
            &base,
            &["--max-tokens", "0"],
            "max_tokens 0 is outside 1..=1000000",
        ),
        (
            &base,
            &["--max-tokens", "4294967295"],
            "max_tokens 4294967295 is outside 1..=1000000",
        ),
        (
            &base,
            &["--temperature", "1e300"],
            "temperature 1e300 is outside 0..=2",
        ),
        (
            &base,
            &["--temperature", "NaN"],
            "temperature NaN is outside 0..=2",
        ),
        (
            &base,
            &["--temperature", "-0.5"],
            "temperature -0.5 is outside 0..=2",
        ),
        (
            &base,
            &["--agent", "planner.temperature=inf"],
            "planner: temperature inf is outside 0..=2",
        ),
        (&base, &["--max-cost", "NaN"], "--max-cost NaN"),
        (
            &base,
            &["--max-cost", "-1"],
            "--max-cost -1: give a number of US dollars",
        ),
        (&base, &["--max-image-edge", "0"], "max image edge 0"),
    ];
    for (url, extra, needle) in cases {
        let out = mapvlm(plan_args(home.path(), url, extra), home.path()).await;
        let err = err_of(&out);
        assert!(!out.status.success(), "{url} {extra:?}");
        assert!(err.contains(needle), "{url} {extra:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
    let config = home.path().join("config.toml");
    std::fs::write(&config, "timeout_secs = 1e30\n").unwrap();
    let extra = ["--config", config.to_str().unwrap()];
    let out = mapvlm(plan_args(home.path(), &base, &extra), home.path()).await;
    assert!(
        err_of(&out).contains("give a number of seconds"),
        "{}",
        err_of(&out)
    );
    assert_eq!(requests(&server).await, 0);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_retry_after_past_the_timeout_ends_at_once_and_short_waits_are_announced() {
    let home = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let busy = wiremock::ResponseTemplate::new(429).insert_header("retry-after", "3600");
    answer(&server, ProviderKind::Openai, PLANNER_MARK, busy).await;
    let base = base_url(&server, ProviderKind::Openai);
    let extra = ["--no-cache", "--timeout", "5"];
    let out = mapvlm(plan_args(home.path(), &base, &extra), home.path()).await;
    let err = err_of(&out);
    assert!(!out.status.success());
    assert!(
        err.contains(
            "the server asks to wait 3600 s (Retry-After), past the limit of 5.0 s (--timeout)"
        ),
        "{err}"
    );
    assert_eq!(requests(&server).await, 1, "no wait, no retry");

    let server = MockServer::start().await;
    let soon = wiremock::ResponseTemplate::new(503).insert_header("retry-after", "0.2");
    wiremock::Mock::given(wiremock::matchers::method("POST"))
        .respond_with(soon)
        .up_to_n_times(1)
        .with_priority(1)
        .mount(&server)
        .await;
    let plan = streamed(ProviderKind::Openai, &["1. Wash the mug."], true);
    answer(&server, ProviderKind::Openai, PLANNER_MARK, plan).await;
    let base = base_url(&server, ProviderKind::Openai);
    let out = mapvlm(plan_args(home.path(), &base, &extra), home.path()).await;
    let err = err_of(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("answered HTTP 503; waiting 0.2 s (Retry-After) before retry 1 of 4"),
        "{err}"
    );
}

/// A local server that answers every request with an event stream whose
/// one line never ends: up to `total` bytes written lazily, 64 KiB at a
/// time, until the client hangs up. Returns its base URL and the count of
/// bytes it managed to send. (wiremock holds a whole body in memory and
/// cannot tell how much of it the client read.)
fn endless_line_server(total: usize) -> (String, Arc<Mutex<usize>>) {
    use std::io::{BufRead, BufReader, Write};
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}/v1", listener.local_addr().unwrap());
    let sent = Arc::new(Mutex::new(0));
    let count = Arc::clone(&sent);
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { return };
            let mut reader = BufReader::new(stream.try_clone().unwrap());
            let mut line = String::new();
            // The request's head, up to its blank line; its body is not read.
            while reader.read_line(&mut line).is_ok_and(|n| n > 0) && line != "\r\n" {
                line.clear();
            }
            let head = "HTTP/1.1 200 OK\r\ncontent-type: text/event-stream\r\nconnection: close\r\n\r\ndata: ";
            let mut written = stream.write_all(head.as_bytes()).map(|()| 0);
            let piece = vec![b'a'; 64 << 10];
            while let Ok(done) = written {
                if done >= total || stream.write_all(&piece).is_err() {
                    break;
                }
                *count.lock().unwrap() += piece.len();
                written = Ok(done + piece.len());
            }
        }
    });
    (base, sent)
}

#[tokio::test(flavor = "multi_thread")]
async fn a_stream_line_that_never_ends_is_refused_at_the_limit() {
    let home = tempfile::tempdir().unwrap();
    let total = 100 << 20;
    let (base, sent) = endless_line_server(total);
    let out = mapvlm(plan_args(home.path(), &base, &["--no-cache"]), home.path()).await;
    let err = err_of(&out);
    assert!(!out.status.success());
    let last = err.trim_end().lines().last().unwrap_or_default();
    assert!(
        last.contains("a stream line or event longer than the limit of 1 MiB (1048576 bytes)"),
        "{err}"
    );
    // The client hung up near the limit, so it never held the 100 MB: what
    // it read is bounded by what the server could send (the limit plus the
    // sockets' buffers).
    let sent = *sent.lock().unwrap();
    assert!(
        sent < 16 << 20,
        "{sent} bytes sent before the client hung up"
    );
}
