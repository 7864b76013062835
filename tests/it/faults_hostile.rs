//! Fault matrix, hostile half (see `tests/FAULTS.md`, rows H…): text from
//! outside is data. The real binary against a local server whose answers
//! and errors carry terminal control sequences, credentials in the base URL,
//! and binary error bodies.

use crate::agents_support::*;

use std::path::{Path, PathBuf};
use std::process::Output;

use mapvlm::agents::ProviderKind;
use wiremock::MockServer;

/// What a hostile model or server writes: OSC 52 (clipboard), OSC 0
/// (title), CSI 6n and DECRQSS (the terminal answers on our stdin), `ESC[2J`,
/// backspaces, a bare `\r` faking a step, a C1 CSI and bidi overrides.
const HOSTILE: &str = "\u{1b}]52;c;SGVsbG8=\u{7} \u{1b}]0;pwned\u{7} \u{1b}[6n \u{1b}P$qm\u{1b}\\ \u{1b}[2J back\u{8}\u{8}\u{8} \u{9b}6n \u{202e}gum\u{202c} \u{2066}x\u{2069} \u{7f}\u{0}";

/// The hostile answer of each agent: still a triple list, a description
/// and a numbered plan, so that every agent succeeds and the plan prints.
fn hostile_answer(mark: &str) -> String {
    if mark == SKM_MARK {
        format!("(sponge{HOSTILE}, on, bathtub)\n(towel, hangs on, rack)")
    } else if mark == GKM_MARK {
        format!("The sponge is on the bathtub.{HOSTILE}")
    } else {
        format!("1. Walk to the sink.\r6. FAKE STEP\n2. Wash the mug {HOSTILE}.\n3. Dry it.")
    }
}

/// Fails the test when `bytes` hold what a terminal would act on: a C0
/// control but newline and tab, DEL, a C1 control (as UTF-8) or a bidi
/// override.
fn assert_terminal_safe(label: &str, what: &str, bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let bad = bytes
        .iter()
        .position(|&b| (b < 0x20 && b != b'\n' && b != b'\t') || b == 0x7f);
    assert!(
        bad.is_none(),
        "{label}: {what} holds a control byte: {text}"
    );
    let bad = text
        .chars()
        .find(|c| matches!(c, '\u{80}'..='\u{9f}' | '\u{202a}'..='\u{202e}'));
    assert!(bad.is_none(), "{label}: {what} holds {bad:?}: {text}");
}

/// Runs mapvlm with `RUST_LOG=trace` off the async runtime.
async fn traced(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || {
        mapvlm_command(&args, &home)
            .env("ANTHROPIC_API_KEY", KEY)
            .env("RUST_LOG", "trace")
            .output()
            .unwrap()
    })
    .await
    .unwrap()
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

/// `plan` of `approach` on a fresh scene against `base`, no cache.
fn plan_args(home: &Path, base: &str, approach: &str, extra: &[&str]) -> Vec<String> {
    let mut flags = vec!["--no-cache"];
    flags.extend(extra);
    let mut args = crate::faults_provider::plan_args(home, base, &flags);
    if let Some(at) = args.iter().position(|a| a == "--approach") {
        args[at + 1] = approach.to_string();
    }
    args
}

/// Mounts a whole OpenAI answer `text` for the requests holding `mark`.
async fn answer_whole(server: &MockServer, mark: &str, text: &str) {
    answer(
        server,
        ProviderKind::Openai,
        mark,
        whole(ProviderKind::Openai, text),
    )
    .await;
}

#[tokio::test(flavor = "multi_thread")]
async fn hostile_answers_reach_stdout_and_stderr_only_as_data() {
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        for stream in [true, false] {
            let server = MockServer::start().await;
            for mark in [SKM_MARK, GKM_MARK, PLANNER_MARK] {
                let text = hostile_answer(mark);
                let response = if stream {
                    streamed(provider, &pieces(&text, 5), true)
                } else {
                    whole(provider, &text)
                };
                answer(&server, provider, mark, response).await;
            }
            for json in [false, true] {
                let home = tempfile::tempdir().unwrap();
                let mut extra = vec!["--provider", provider.name()];
                if !stream {
                    extra.push("--no-stream");
                }
                if json {
                    extra.push("--json");
                }
                let base = base_url(&server, provider);
                let args = plan_args(home.path(), &base, "multi-image", &extra);
                let out = traced(args, home.path()).await;
                let label = format!("{provider:?} stream={stream} json={json}");
                let shown = String::from_utf8_lossy(&out.stdout).into_owned();
                let err = String::from_utf8_lossy(&out.stderr).into_owned();
                assert!(out.status.success(), "{label}: {err}");
                assert_terminal_safe(&label, "stdout", &out.stdout);
                assert_terminal_safe(&label, "stderr", &out.stderr);
                if json {
                    // The JSON reads back as exactly what the model sent.
                    let run: serde_json::Value = serde_json::from_str(&shown).unwrap();
                    let steps = run["steps"].as_array().unwrap();
                    assert_eq!(steps[1], format!("Wash the mug {HOSTILE}."), "{label}");
                } else {
                    // The bare `\r` fakes no line: the step stays one line.
                    assert!(
                        shown.contains("1. Walk to the sink.\\u{d}6. FAKE STEP\n"),
                        "{label}: {shown}"
                    );
                    assert!(!shown.contains("\n6. FAKE STEP"), "{label}: {shown}");
                    assert!(shown.contains("\\u{1b}]52;c;"), "{label}: {shown}");
                }
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn hostile_and_binary_error_bodies_are_printed_as_data() {
    let gzip = [
        0x1f_u8, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3, 0xcb, 0x48, 0xcd, 0xc9, 0xc9, 7, 0,
    ];
    let json_error = serde_json::json!({"error": {"message": format!("bad model {HOSTILE}")}});
    let cases: Vec<(&str, wiremock::ResponseTemplate, &str)> = vec![
        (
            "json error",
            wiremock::ResponseTemplate::new(400).set_body_json(json_error),
            "bad model \\u{1b}]52;c;",
        ),
        (
            "text error",
            wiremock::ResponseTemplate::new(404)
                .set_body_string(format!("no such route\r\nmapvlm: all good {HOSTILE}")),
            "no such route\\u{d}\nmapvlm: all good",
        ),
        (
            "binary error",
            wiremock::ResponseTemplate::new(400)
                .insert_header("content-type", "application/octet-stream")
                .set_body_bytes(gzip.to_vec()),
            "binary body, 17 bytes",
        ),
        (
            "invalid answer",
            wiremock::ResponseTemplate::new(200)
                .insert_header("content-type", "application/json")
                .set_body_string(format!("{{\"choices\": {HOSTILE}")),
            "invalid JSON",
        ),
    ];
    for (label, response, said) in cases {
        let server = MockServer::start().await;
        answer(&server, ProviderKind::Openai, PLANNER_MARK, response).await;
        let home = tempfile::tempdir().unwrap();
        let base = base_url(&server, ProviderKind::Openai);
        let args = plan_args(home.path(), &base, "single-image", &["--no-stream"]);
        let out = traced(args, home.path()).await;
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "{label}: {err}");
        assert!(!err.contains("panicked"), "{label}: {err}");
        assert!(err.contains(said), "{label}: {err}");
        assert_terminal_safe(label, "stdout", &out.stdout);
        assert_terminal_safe(label, "stderr", &out.stderr);
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn credentials_in_a_base_url_never_reach_output_records_or_errors() {
    const SECRET: &str = "sk-url-Secret-42";
    let server = MockServer::start().await;
    for mark in [SKM_MARK, GKM_MARK, PLANNER_MARK] {
        let text = hostile_answer(mark).replace(HOSTILE, "");
        answer_whole(&server, mark, &text).await;
    }
    let served = base_url(&server, ProviderKind::Openai);
    let with_user = served.replace("http://", &format!("http://user:{SECRET}@"));
    let closed = format!("http://{SECRET}@127.0.0.1:1/v1");
    let bad = format!("ftp://user:{SECRET}@host/v1");
    for (label, base, ok) in [
        ("answered", with_user.as_str(), true),
        ("unreachable", closed.as_str(), false),
        ("not http", bad.as_str(), false),
    ] {
        let home = tempfile::tempdir().unwrap();
        let record = home.path().join("run.rec.json");
        let extra = [
            "--no-stream",
            "--json",
            "--record",
            record.to_str().unwrap(),
            "--timeout",
            "20",
        ];
        let args = plan_args(home.path(), base, "multi-image", &extra);
        let out = traced(args, home.path()).await;
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        let shown = String::from_utf8_lossy(&out.stdout).into_owned();
        assert_eq!(out.status.success(), ok, "{label}: {err}");
        assert!(
            !err.contains(SECRET) && !shown.contains(SECRET),
            "{label}: {err}{shown}"
        );
        assert!(
            err.contains("***@") || shown.contains("***@"),
            "{label}: {err}{shown}"
        );
        for (path, bytes) in crate::common::files_under(home.path()) {
            let text = String::from_utf8_lossy(&bytes);
            assert!(
                !text.contains(SECRET),
                "{label}: the secret is in {}",
                path.display()
            );
        }
        if ok {
            let run: serde_json::Value = serde_json::from_str(&shown).unwrap();
            let agent = &run["agents"][0];
            assert!(
                agent["base_url"]
                    .as_str()
                    .unwrap()
                    .starts_with("http://***@127.0.0.1:"),
                "{label}: {agent}"
            );
        }
    }
}

#[test]
fn a_key_in_a_config_file_others_may_read_or_change_is_warned_of_naming_the_mode() {
    use std::os::unix::fs::PermissionsExt;
    let keyed = "[defaults]\napi_key = \"sk-from-file\"\n";
    let per_agent = "[agents.single]\napi_key = \"sk-from-file\"\n";
    let keyless = "[defaults]\nmodel = \"m\"\n";
    for (text, mode, said) in [
        (keyed, 0o644, Some("permissions 0644 for config file")),
        (keyed, 0o666, Some("others may read and change")),
        (per_agent, 0o620, Some("permissions 0620")),
        (keyed, 0o600, None),
        (keyless, 0o666, None),
    ] {
        let home = tempfile::tempdir().unwrap();
        let config = home.path().join("config.toml");
        std::fs::write(&config, text).unwrap();
        std::fs::set_permissions(&config, std::fs::Permissions::from_mode(mode)).unwrap();
        let mut args = plan_args(home.path(), "http://127.0.0.1:1/v1", "single-image", &[]);
        args.extend(strings(&["--config", config.to_str().unwrap()]));
        let out = mapvlm_command(&args, home.path()).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            err.contains("could not be reached"),
            "{mode:o}: the run went on: {err}"
        );
        let warnings = err.matches("are too open").count();
        match said {
            Some(said) => {
                assert!(err.contains(said), "{mode:o}: {err}");
                assert!(err.contains("run chmod 600 "), "{mode:o}: {err}");
                assert_eq!(warnings, 1, "{mode:o}: said once: {err}");
            }
            None => assert_eq!(warnings, 0, "{mode:o}: {err}"),
        }
        assert!(!err.contains("sk-from-file"), "{err}");
    }
}

/// A whole answer the provider says it cut at the token limit.
fn cut_whole(provider: ProviderKind, text: &str) -> wiremock::ResponseTemplate {
    let body = match provider {
        ProviderKind::Openai => serde_json::json!({
            "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "length"}],
            "usage": {"prompt_tokens": 100, "completion_tokens": 20}
        }),
        _ => serde_json::json!({
            "content": [{"type": "text", "text": text}],
            "stop_reason": "max_tokens",
            "usage": {"input_tokens": 100, "output_tokens": 20}
        }),
    };
    wiremock::ResponseTemplate::new(200).set_body_json(body)
}

/// A streamed answer the provider says it cut at the token limit.
fn cut_stream(provider: ProviderKind, text: &str) -> wiremock::ResponseTemplate {
    let body = match provider {
        ProviderKind::Openai => {
            let piece = serde_json::json!({"choices": [{"index": 0, "delta": {"content": text}, "finish_reason": null}]});
            let stop = serde_json::json!({"choices": [{"index": 0, "delta": {}, "finish_reason": "length"}]});
            format!("data: {piece}\n\ndata: {stop}\n\ndata: [DONE]\n\n")
        }
        _ => {
            let piece = serde_json::json!({"type": "content_block_delta", "index": 0, "delta": {"type": "text_delta", "text": text}});
            let delta = serde_json::json!({"type": "message_delta", "delta": {"stop_reason": "max_tokens"}, "usage": {"output_tokens": 20}});
            format!("event: content_block_delta\ndata: {piece}\n\nevent: message_delta\ndata: {delta}\n\nevent: message_stop\ndata: {{\"type\": \"message_stop\"}}\n\n")
        }
    };
    wiremock::ResponseTemplate::new(200)
        .insert_header("content-type", "text/event-stream")
        .set_body_string(body)
}

/// Runs mapvlm (no trace) off the async runtime, the Anthropic key set too.
async fn run(args: Vec<String>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || {
        mapvlm_command(&args, &home)
            .env("ANTHROPIC_API_KEY", KEY)
            .output()
            .unwrap()
    })
    .await
    .unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn a_cut_answer_is_never_cached_and_plan_fails_naming_it() {
    let text = "1. Walk to the sink.\n2. Wash the m";
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        for stream in [true, false] {
            let label = format!("{provider:?} stream={stream}");
            let server = MockServer::start().await;
            let response = if stream {
                cut_stream(provider, text)
            } else {
                cut_whole(provider, text)
            };
            answer(&server, provider, PLANNER_MARK, response).await;
            let home = tempfile::tempdir().unwrap();
            let cache = home.path().join("responses");
            let mut extra = vec![
                "--provider",
                provider.name(),
                "--cache-dir",
                cache.to_str().unwrap(),
            ];
            if !stream {
                extra.push("--no-stream");
            }
            let mut args = plan_args(
                home.path(),
                &base_url(&server, provider),
                "single-image",
                &extra,
            );
            args.retain(|a| a != "--no-cache");
            for round in 1..=2 {
                let out = run(args.clone(), home.path()).await;
                let err = String::from_utf8_lossy(&out.stderr).into_owned();
                assert!(!out.status.success(), "{label}: {err}");
                assert!(err.contains("cut the answer"), "{label}: {err}");
                let reason = if provider == ProviderKind::Openai {
                    "`length`"
                } else {
                    "`max_tokens`"
                };
                assert!(
                    err.contains(reason) && err.contains("raise --max-tokens"),
                    "{label}: {err}"
                );
                assert!(
                    !String::from_utf8_lossy(&out.stdout).contains("Wash the m"),
                    "{label}"
                );
                let asked = server.received_requests().await.unwrap().len();
                assert_eq!(asked, round, "{label}: asked again, never from the cache");
            }
            let cached = crate::common::files_under(&cache);
            assert!(
                cached.is_empty(),
                "{label}: {:?}",
                cached.iter().map(|c| &c.0).collect::<Vec<_>>()
            );
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_refusal_or_an_answer_past_max_tokens_is_not_a_plan() {
    let huge = format!("1. {}", "word ".repeat(400));
    let cases: Vec<(&str, wiremock::ResponseTemplate, &str, &str)> = vec![
        (
            "refusal",
            whole(
                ProviderKind::Openai,
                "I am sorry, but I cannot help with that request.",
            ),
            "the answer is not a plan",
            "1024",
        ),
        (
            "streamed refusal",
            streamed(
                ProviderKind::Openai,
                &["I'm sorry, ", "I can't assist with that."],
                true,
            ),
            "the answer is not a plan",
            "1024",
        ),
        (
            "past max_tokens",
            streamed(ProviderKind::Openai, &pieces(&huge, 64), true),
            "longer than the limit of 800 bytes (8 bytes a token of max_tokens 100)",
            "100",
        ),
        (
            "whole past max_tokens",
            whole(ProviderKind::Openai, &huge),
            "longer than the limit of 800 bytes",
            "100",
        ),
        (
            "usage past max_tokens",
            whole(ProviderKind::Openai, "1. Go."),
            "the server reports 20 output tokens, past max_tokens 10",
            "10",
        ),
    ];
    for (label, response, said, max_tokens) in cases {
        let server = MockServer::start().await;
        answer(&server, ProviderKind::Openai, PLANNER_MARK, response).await;
        let home = tempfile::tempdir().unwrap();
        let base = base_url(&server, ProviderKind::Openai);
        let args = plan_args(
            home.path(),
            &base,
            "single-image",
            &["--max-tokens", max_tokens],
        );
        let out = run(args, home.path()).await;
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "{label}: {err}");
        assert!(err.contains(said), "{label}: {err}");
        assert!(!err.contains("panicked"), "{label}: {err}");
    }
    // A plan of one line with several sentences, or several lines, is a plan.
    for text in [
        "Walk to the sink. Wash the mug.",
        "Walk to the sink\nWash the mug",
    ] {
        let server = MockServer::start().await;
        answer_whole(&server, PLANNER_MARK, text).await;
        let home = tempfile::tempdir().unwrap();
        let args = plan_args(
            home.path(),
            &base_url(&server, ProviderKind::Openai),
            "single-image",
            &[],
        );
        let out = run(args, home.path()).await;
        assert!(
            out.status.success(),
            "{text}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_plan_over_the_step_limit_keeps_the_first_1000_steps_and_says_so() {
    let text: String = (1..=1500).map(|n| format!("{n}. Step {n}.\n")).collect();
    let server = MockServer::start().await;
    answer_whole(&server, PLANNER_MARK, &text).await;
    let home = tempfile::tempdir().unwrap();
    let args = plan_args(
        home.path(),
        &base_url(&server, ProviderKind::Openai),
        "single-image",
        &["--json", "--max-tokens", "100000"],
    );
    let out = run(args, home.path()).await;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    let run: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        run["steps"].as_array().unwrap().len(),
        mapvlm::plan::MAX_STEPS
    );
    assert!(
        err.contains("1500 steps, only the first 1000 kept"),
        "{err}"
    );
}

/// Runs its arguments as a child forked from this small process and writes
/// the child's peak resident set (KiB, `wait4`'s `ru_maxrss`) to the file
/// `$RSS_FILE`, exiting as the child did. A child of the test process
/// itself would count the test process's pages: the kernel keeps the
/// high-water mark of the memory a process had before `exec`.
const MEASURE: &str = r#"import os, sys
pid = os.fork()
if pid == 0:
    os.execvp(sys.argv[1], sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
with open(os.environ["RSS_FILE"], "w") as out:
    out.write(str(usage.ru_maxrss))
sys.exit(os.waitstatus_to_exitcode(status) % 256)
"#;

/// The peak resident set of `command`, in KiB, measured by [`MEASURE`]
/// (python3 is needed); its exit status and stderr.
pub(crate) fn peak_rss(command: std::process::Command) -> (i64, std::process::ExitStatus, String) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rss");
    let mut measure = std::process::Command::new("python3");
    for (key, value) in command.get_envs() {
        match value {
            Some(value) => measure.env(key, value),
            None => measure.env_remove(key),
        };
    }
    let out = measure
        .args(["-c", MEASURE])
        .arg(command.get_program())
        .args(command.get_args())
        .env("RSS_FILE", &file)
        .stdout(std::process::Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("python3 is needed to measure memory: {e}"));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let peak = std::fs::read_to_string(&file)
        .unwrap_or_else(|e| panic!("no peak measured ({e}): {err}"))
        .trim()
        .parse()
        .unwrap();
    (peak, out.status, err)
}

#[test]
fn unbounded_inputs_cost_no_more_memory_than_their_limits() {
    let home = tempfile::tempdir().unwrap();
    let scene = scene(home.path());
    let unreachable = "http://127.0.0.1:1/v1";
    let plan = |image: &str| {
        let args = strings(&[
            "plan",
            "--task",
            "Wash the mug",
            "--image",
            image,
            "--approach",
            "single-image",
            "--base-url",
            unreachable,
            "--no-cache",
        ]);
        mapvlm_command(&args, home.path())
    };
    let (normal, _, _) = peak_rss(plan(scene.to_str().unwrap()));
    let image_limit = (mapvlm::limits::MAX_IMAGE_FILE_BYTES >> 10) as i64;
    for device in ["/dev/zero", "/dev/urandom"] {
        let (peak, status, err) = peak_rss(plan(device));
        assert!(!status.success(), "{err}");
        assert!(
            err.contains("longer than the limit of 64 MiB"),
            "{device}: {err}"
        );
        assert!(
            peak <= normal + 2 * image_limit,
            "{device}: {peak} KiB against {normal} KiB"
        );
    }
    // A table file is read within the same limit, before any request.
    let table = |path: &str| {
        let args = strings(&[
            "plan",
            "--task",
            "Wash the mug",
            "--table",
            path,
            "--approach",
            "single-table",
            "--base-url",
            unreachable,
            "--no-cache",
        ]);
        mapvlm_command(&args, home.path())
    };
    let (peak, status, err) = peak_rss(table("/dev/zero"));
    assert!(!status.success(), "{err}");
    assert!(
        err.contains("longer than the limit of 64 MiB") && err.contains("a table file"),
        "{err}"
    );
    assert!(
        peak <= normal + 2 * image_limit,
        "--table /dev/zero: {peak} KiB against {normal} KiB"
    );
    let gt = home.path().join("gt.txt");
    std::fs::write(&gt, "Walk to the sink.\n").unwrap();
    let score = |pred: &str| {
        let args = strings(&[
            "score",
            "--gt",
            gt.to_str().unwrap(),
            "--pred",
            pred,
            "--metrics",
            "kas",
        ]);
        mapvlm_command(&args, home.path())
    };
    let (normal, _, _) = peak_rss(score(gt.to_str().unwrap()));
    let step_limit = (mapvlm::limits::MAX_STEP_FILE_BYTES >> 10) as i64;
    let (peak, status, err) = peak_rss(score("/dev/zero"));
    assert!(!status.success(), "{err}");
    assert!(
        err.contains("longer than the limit of 16 MiB") && err.contains("a step file"),
        "{err}"
    );
    assert!(
        peak <= normal + 2 * step_limit,
        "--pred /dev/zero: {peak} KiB against {normal} KiB"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_truncated_jpeg_is_refused_before_any_request() {
    let server = MockServer::start().await;
    answer_whole(&server, PLANNER_MARK, "1. Go.").await;
    let home = tempfile::tempdir().unwrap();
    let photo = home.path().join("photo.jpg");
    image::RgbImage::from_fn(80, 60, |x, y| image::Rgb([x as u8 * 3, y as u8 * 4, 9]))
        .save(&photo)
        .unwrap();
    let bytes = std::fs::read(&photo).unwrap();
    std::fs::write(&photo, &bytes[..bytes.len() / 2]).unwrap();
    let args = strings(&[
        "plan",
        "--task",
        "Wash the mug",
        "--image",
        photo.to_str().unwrap(),
        "--approach",
        "single-image",
        "--base-url",
        &base_url(&server, ProviderKind::Openai),
        "--no-cache",
    ]);
    let out = run(args, home.path()).await;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("photo.jpg: the JPEG file is truncated"),
        "{err}"
    );
    assert_eq!(server.received_requests().await.unwrap().len(), 0);
}

/// `eval` of `data` through the single-image agent at `server`, into
/// `out`, with `extra` flags.
fn eval_args(data: &Path, out: &Path, server: &MockServer, extra: &[&str]) -> Vec<String> {
    let base = base_url(server, ProviderKind::Openai);
    let mut args = crate::faults_provider::eval_args(data, out, &base);
    args.extend(strings(extra));
    args
}

/// Writes `tasks` as the tasks of `data` and runs `eval` of them into
/// `home/eval` against a fresh planning server; the run must fail (some
/// task is refused). The server, the output folder and stderr.
async fn failing_eval(home: &Path, data: &Path, tasks: &[String]) -> (MockServer, PathBuf, String) {
    std::fs::write(data.join("tasks.jsonl"), tasks.join("\n")).unwrap();
    let server = crate::faults_provider::planning_server().await;
    let out = home.join("eval");
    let first = run(eval_args(data, &out, &server, &[]), home).await;
    let err = String::from_utf8_lossy(&first.stderr).into_owned();
    assert!(!first.status.success(), "{err}");
    (server, out, err)
}

fn task_line(id: &str, image: &str) -> String {
    serde_json::json!({
        "id": id, "task": "Wash the mug", "image": image,
        "ground_truth": ["Walk to the sink.", "Wash the mug."]
    })
    .to_string()
}

async fn asked(server: &MockServer) -> usize {
    server.received_requests().await.unwrap().len()
}

#[tokio::test(flavor = "multi_thread")]
async fn files_a_dataset_names_stay_in_the_dataset_unless_allowed() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    let shared = home.path().join("shared");
    std::fs::create_dir_all(data.join("sub")).unwrap();
    std::fs::create_dir_all(&shared).unwrap();
    scene(&data);
    scene(&shared);
    std::os::unix::fs::symlink(&shared, data.join("linked")).unwrap();
    let outside = shared.join("scene.png");
    let tasks = [
        task_line("inside", "scene.png"),
        task_line("up", "../shared/scene.png"),
        task_line("absolute", outside.to_str().unwrap()),
        task_line("normalised", "sub/../scene.png"),
        task_line("symlinked", "linked/scene.png"),
        task_line("deep", "sub/../../shared/scene.png"),
    ];
    let (server, out, err) = failing_eval(home.path(), &data, &tasks).await;
    assert!(
        err.contains("tasks.jsonl:2: image `../shared/scene.png` leads out of the dataset folder"),
        "{err}"
    );
    assert!(
        err.contains("tasks.jsonl:3: image") && err.contains("is an absolute path"),
        "{err}"
    );
    assert!(
        err.contains("tasks.jsonl:6: image `sub/../../shared/scene.png` leads out"),
        "{err}"
    );
    assert!(err.contains("--allow-outside-paths"), "{err}");
    assert_eq!(
        asked(&server).await,
        3,
        "only the tasks inside were asked: {err}"
    );
    for id in ["inside", "normalised", "symlinked"] {
        assert!(
            out.join(format!("tasks/{id}.single-image.json")).is_file(),
            "{id}"
        );
    }
    // Allowing them changes the tasks the run holds: the folder written
    // without them is not resumed (its provenance differs), a new one is.
    let mixed = run(
        eval_args(&data, &out, &server, &["--allow-outside-paths"]),
        home.path(),
    )
    .await;
    let err = String::from_utf8_lossy(&mixed.stderr).into_owned();
    assert!(
        !mixed.status.success() && err.contains("dataset_tasks"),
        "{err}"
    );
    assert_eq!(
        asked(&server).await,
        3,
        "nothing asked for a refused folder"
    );
    let allowed = home.path().join("allowed");
    let again = run(
        eval_args(&data, &allowed, &server, &["--allow-outside-paths"]),
        home.path(),
    )
    .await;
    let err = String::from_utf8_lossy(&again.stderr).into_owned();
    assert!(again.status.success(), "{err}");
    assert_eq!(asked(&server).await, 9, "all six, once allowed: {err}");
}

#[tokio::test(flavor = "multi_thread")]
async fn task_ids_are_unique_valid_and_injective_on_disk() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    scene(&data);
    let long = "x".repeat(300);
    let tasks = [
        task_line("a", "scene.png"),
        task_line("a", "scene.png"),
        task_line("task/1", "scene.png"),
        task_line("task_1", "scene.png"),
        task_line("task 1", "scene.png"),
        task_line("", "scene.png"),
        task_line(&long, "scene.png"),
        task_line(".hidden", "scene.png"),
    ];
    let (server, out, err) = failing_eval(home.path(), &data, &tasks).await;
    assert!(
        err.contains("tasks.jsonl:2: the id `a` is also the id of line 1"),
        "{err}"
    );
    assert!(err.contains("tasks.jsonl:6: the id is empty"), "{err}");
    assert!(
        err.contains("tasks.jsonl:7: the id is 300 bytes long, past the limit of 200"),
        "{err}"
    );
    assert!(!err.contains("File name too long"), "{err}");
    assert_eq!(
        asked(&server).await,
        5,
        "a, task/1, task_1, task 1 and .hidden: {err}"
    );
    let mut files: Vec<String> = std::fs::read_dir(out.join("tasks"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".json"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 5, "{files:?}");
    assert!(
        files.contains(&"task_1.single-image.json".to_string()),
        "{files:?}"
    );
    assert!(
        files.iter().all(|f| !f.starts_with('.')),
        "no hidden file: {files:?}"
    );
    let ids: std::collections::BTreeSet<String> = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(out.join("tasks").join(f)).unwrap();
            serde_json::from_str::<serde_json::Value>(&text).unwrap()["id"]
                .as_str()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(ids.len(), 5, "each file holds its own task: {ids:?}");

    // An output folder written before the hash suffix resumes unpaid.
    let new_name = files
        .iter()
        .find(|f| f.starts_with("task_1~"))
        .unwrap()
        .clone();
    let stem = new_name.split('~').next().unwrap().to_string();
    assert_eq!(stem, "task_1");
    let spaced = files
        .iter()
        .find(|f| {
            let text = std::fs::read_to_string(out.join("tasks").join(f)).unwrap();
            text.contains("\"id\": \"task 1\"")
        })
        .unwrap()
        .clone();
    let legacy = home.path().join("legacy");
    std::fs::create_dir_all(legacy.join("tasks")).unwrap();
    // Files of that age predate provenance too: the copy has none.
    let mut result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tasks").join(&spaced)).unwrap())
            .unwrap();
    result.as_object_mut().unwrap().remove("provenance");
    std::fs::write(
        legacy.join("tasks/task_1.single-image.json"),
        serde_json::to_string_pretty(&result).unwrap(),
    )
    .unwrap();
    std::fs::write(data.join("tasks.jsonl"), task_line("task 1", "scene.png")).unwrap();
    let before = asked(&server).await;
    let resumed = run(eval_args(&data, &legacy, &server, &[]), home.path()).await;
    let err = String::from_utf8_lossy(&resumed.stderr).into_owned();
    assert!(resumed.status.success(), "{err}");
    assert_eq!(
        asked(&server).await,
        before,
        "resumed from the old name: {err}"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_base_url_keeps_its_query_and_a_redirect_is_named_not_followed() {
    use wiremock::matchers::{method, path, query_param};
    let server = MockServer::start().await;
    wiremock::Mock::given(method("POST"))
        .and(path("/v1/chat/completions"))
        .and(query_param("api-version", "2024-06-01"))
        .respond_with(whole(
            ProviderKind::Openai,
            "1. Walk to the sink.\n2. Wash the mug.",
        ))
        .mount(&server)
        .await;
    let home = tempfile::tempdir().unwrap();
    let base = format!("{}/v1?api-version=2024-06-01", server.uri());
    let out = run(
        plan_args(home.path(), &base, "single-image", &[]),
        home.path(),
    )
    .await;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("2. Wash the mug."));

    let elsewhere = MockServer::start().await;
    for status in [302, 307] {
        let redirecting = MockServer::start().await;
        let to = format!("{}/v1/chat/completions", elsewhere.uri());
        let response =
            wiremock::ResponseTemplate::new(status).insert_header("location", to.as_str());
        answer(&redirecting, ProviderKind::Openai, PLANNER_MARK, response).await;
        let home = tempfile::tempdir().unwrap();
        let base = base_url(&redirecting, ProviderKind::Openai);
        let out = run(
            plan_args(home.path(), &base, "single-image", &[]),
            home.path(),
        )
        .await;
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "{status}: {err}");
        assert!(
            err.contains(&format!("answered HTTP {status}: a redirect to {to}")),
            "{err}"
        );
        assert!(err.contains("redirects are not followed"), "{err}");
    }
    assert_eq!(
        asked(&elsewhere).await,
        0,
        "nothing went to the other origin"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_cache_that_cannot_be_written_is_said_once_naming_its_path() {
    let server = MockServer::start().await;
    for mark in [SKM_MARK, GKM_MARK, PLANNER_MARK] {
        let text = hostile_answer(mark).replace(HOSTILE, "");
        answer_whole(&server, mark, &text).await;
    }
    let home = tempfile::tempdir().unwrap();
    let blocker = home.path().join("not-a-folder");
    std::fs::write(&blocker, b"x").unwrap();
    let base = base_url(&server, ProviderKind::Openai);
    let mut args = plan_args(home.path(), &base, "multi-image", &[]);
    args.retain(|a| a != "--no-cache");
    args.extend(strings(&["--cache-dir", blocker.to_str().unwrap()]));
    let out = run(args, home.path()).await;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "the run goes on: {err}");
    let said: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("cannot be written"))
        .collect();
    assert_eq!(said.len(), 1, "{err}");
    assert!(said[0].contains(blocker.to_str().unwrap()), "{err}");
}
