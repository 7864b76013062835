//! Helpers for the agent tests: a local server that speaks the OpenAI and
//! Anthropic APIs (wiremock), answers in both shapes, settings pointing at it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use mapvlm::agents::config::{ConfigFile, FlagLayers, Settings};
use mapvlm::agents::pipeline::{AgentEvent, PlanInput, PlanRecord, Runner, Source};
use mapvlm::agents::prompts::PromptSet;
use mapvlm::agents::{Approach, ProviderKind};
use serde_json::json;
use tokio_util::sync::CancellationToken;
use wiremock::matchers::{body_string_contains, method, path};
use wiremock::{Mock, MockServer, ResponseTemplate};

/// The key every test sends; it must never show up anywhere.
pub const KEY: &str = "sk-test-Very-Secret-Key-0123456789";

/// What marks each agent's request (from the shipped system prompts).
pub const SKM_MARK: &str = "You are the semantic-knowledge miner";
/// See [`SKM_MARK`].
pub const GKM_MARK: &str = "You are the grounded-knowledge miner";
/// See [`SKM_MARK`].
pub const PLANNER_MARK: &str = "You are the planner";

/// The endpoint path of a provider.
pub fn endpoint(provider: ProviderKind) -> &'static str {
    match provider {
        ProviderKind::Openai => "/v1/chat/completions",
        ProviderKind::Anthropic => "/v1/messages",
        ProviderKind::Replay => panic!("the recording is not served over HTTP"),
    }
}

/// The base URL of the mock server for a provider.
pub fn base_url(server: &MockServer, provider: ProviderKind) -> String {
    match provider {
        ProviderKind::Openai => format!("{}/v1", server.uri()),
        ProviderKind::Anthropic => server.uri(),
        ProviderKind::Replay => panic!("the recording is not served over HTTP"),
    }
}

/// Settings for every agent pointing at `server`, with the test key from
/// the environment layer.
pub fn settings(server: &MockServer, provider: ProviderKind, stream: bool) -> Settings {
    let env = move |name: &str| match (name, provider) {
        ("OPENAI_API_KEY", ProviderKind::Openai)
        | ("ANTHROPIC_API_KEY", ProviderKind::Anthropic) => Some(KEY.to_string()),
        _ => None,
    };
    let mut flags = FlagLayers::default();
    flags.all.provider = Some(provider);
    flags.all.base_url = Some(base_url(server, provider));
    flags.all.model = Some("test-model".into());
    flags.all.stream = Some(stream);
    flags.all.max_tokens = Some(321);
    flags.all.temperature = Some(0.25);
    flags.max_image_edge = Some(64);
    let mut settings = Settings::resolve(&ConfigFile::default(), &env, &flags).unwrap();
    settings.http.backoff = Duration::from_millis(50);
    settings
}

/// A runner with the shipped prompts, answering live.
pub fn runner(settings: Settings) -> Runner {
    Runner::new(settings, PromptSet::load(None).unwrap(), Source::Live)
}

/// A 60×40 PNG scene in `dir`.
pub fn scene(dir: &Path) -> PathBuf {
    let file = dir.join("scene.png");
    image::RgbImage::from_fn(60, 40, |x, y| image::Rgb([x as u8, y as u8, 128]))
        .save(&file)
        .unwrap();
    file
}

/// A whole (non-streamed) answer.
pub fn whole(provider: ProviderKind, text: &str) -> ResponseTemplate {
    let body = match provider {
        ProviderKind::Openai => json!({
            "id": "cmpl-1", "object": "chat.completion",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
            "usage": {"prompt_tokens": 100, "completion_tokens": 20, "total_tokens": 120}
        }),
        ProviderKind::Anthropic => json!({
            "id": "msg_1", "type": "message", "role": "assistant",
            "content": [{"type": "text", "text": text}],
            "stop_reason": "end_turn",
            "usage": {"input_tokens": 100, "output_tokens": 20}
        }),
        ProviderKind::Replay => panic!("the recording is not served over HTTP"),
    };
    ResponseTemplate::new(200).set_body_json(body)
}

/// The server-sent events of a streamed answer cut into `pieces`; without
/// the end marker when `complete` is false.
pub fn stream_body(provider: ProviderKind, pieces: &[&str], complete: bool) -> String {
    let mut body = String::new();
    match provider {
        ProviderKind::Openai => {
            for piece in pieces {
                let event = json!({"choices": [{"index": 0, "delta": {"content": piece}, "finish_reason": null}]});
                body.push_str(&format!("data: {event}\n\n"));
            }
            if complete {
                let stop = json!({"choices": [{"index": 0, "delta": {}, "finish_reason": "stop"}]});
                let usage = json!({"choices": [], "usage": {"prompt_tokens": 100, "completion_tokens": 20}});
                body.push_str(&format!(
                    "data: {stop}\n\ndata: {usage}\n\ndata: [DONE]\n\n"
                ));
            }
        }
        ProviderKind::Anthropic => {
            let start = json!({"type": "message_start", "message": {"usage": {"input_tokens": 100, "output_tokens": 1}}});
            body.push_str(&format!("event: message_start\ndata: {start}\n\n"));
            body.push_str("event: ping\ndata: {\"type\": \"ping\"}\n\n");
            for piece in pieces {
                let event = json!({"type": "content_block_delta", "index": 0, "delta": {"type": "text_delta", "text": piece}});
                body.push_str(&format!("event: content_block_delta\ndata: {event}\n\n"));
            }
            if complete {
                let delta = json!({"type": "message_delta", "delta": {"stop_reason": "end_turn"}, "usage": {"output_tokens": 20}});
                body.push_str(&format!("event: message_delta\ndata: {delta}\n\n"));
                body.push_str("event: message_stop\ndata: {\"type\": \"message_stop\"}\n\n");
            }
        }
        ProviderKind::Replay => panic!("the recording is not served over HTTP"),
    }
    body
}

/// A streamed answer.
pub fn streamed(provider: ProviderKind, pieces: &[&str], complete: bool) -> ResponseTemplate {
    ResponseTemplate::new(200)
        .insert_header("content-type", "text/event-stream")
        .set_body_string(stream_body(provider, pieces, complete))
}

/// Cuts `text` into pieces of at most `size` bytes (on character boundaries).
pub fn pieces(text: &str, size: usize) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        let mut cut = size.min(rest.len());
        while !rest.is_char_boundary(cut) {
            cut += 1;
        }
        out.push(&rest[..cut]);
        rest = &rest[cut..];
    }
    out
}

/// Mounts `response` for the requests that contain `mark`.
pub async fn answer(
    server: &MockServer,
    provider: ProviderKind,
    mark: &str,
    response: ResponseTemplate,
) {
    Mock::given(method("POST"))
        .and(path(endpoint(provider)))
        .and(body_string_contains(mark))
        .respond_with(response)
        .mount(server)
        .await;
}

/// The outputs hand-written for these tests (no real model was asked).
pub const SKM_TEXT: &str =
    "(sponge, on, bathtub)\n(towel, hangs on, rack)\n(sink, next to, toilet)";
/// See [`SKM_TEXT`].
pub const GKM_TEXT: &str = "The green sponge lies on the rim of the bathtub, ahead on the left. The sink is to the right of the toilet.";
/// See [`SKM_TEXT`].
pub const PLAN_TEXT: &str = "1. Walk to the bathtub.\n2. Pick up the green sponge from the bathtub.\n3. Turn right and walk to the sink.\n4. Wet the sponge in the sink.\n5. Walk back to the bathtub.\n6. Place the sponge in the bathtub.";

/// Mounts the three multi-image answers, each after `delay`.
pub async fn multi_agent_server(
    provider: ProviderKind,
    stream: bool,
    delay: Duration,
) -> MockServer {
    let server = MockServer::start().await;
    for (mark, text) in [
        (SKM_MARK, SKM_TEXT),
        (GKM_MARK, GKM_TEXT),
        (PLANNER_MARK, PLAN_TEXT),
    ] {
        let response = if stream {
            streamed(provider, &pieces(text, 7), true)
        } else {
            whole(provider, text)
        };
        answer(&server, provider, mark, response.set_delay(delay)).await;
    }
    server
}

/// Runs a plan, collecting its events.
pub async fn plan_with_events(
    runner: &Runner,
    approach: Approach,
    input: &PlanInput,
) -> (PlanRecord, Vec<AgentEvent>) {
    let (sender, mut receiver) = tokio::sync::mpsc::unbounded_channel();
    let record = runner
        .plan(approach, input, &sender, &CancellationToken::new())
        .await
        .unwrap();
    drop(sender);
    let mut events = Vec::new();
    while let Some(event) = receiver.recv().await {
        events.push(event);
    }
    (record, events)
}

/// The image input for a plan.
pub fn image_input(image: PathBuf) -> PlanInput {
    PlanInput {
        task: "Place a wet sponge inside the bathtub".into(),
        image: Some(image),
        table: None,
    }
}

/// The mapvlm binary with `args`, its config and cache folders under `home`,
/// the test key in the environment and no base URL from the environment.
pub fn mapvlm_command<S: AsRef<std::ffi::OsStr>>(args: &[S], home: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_mapvlm"));
    command
        .args(args)
        .env("XDG_CONFIG_HOME", home.join("config"))
        .env("XDG_CACHE_HOME", home.join("cache"))
        .env("OPENAI_API_KEY", KEY)
        .env_remove("OPENAI_BASE_URL");
    command
}

/// Answers each request with its agent's text and a number of its own, so
/// that every sample's answer differs and a Planner's request shows which
/// miners' answers it read; streamed when the request asks for a stream.
#[derive(Default)]
pub struct Numbered {
    count: std::sync::atomic::AtomicUsize,
}

impl wiremock::Respond for Numbered {
    fn respond(&self, request: &wiremock::Request) -> ResponseTemplate {
        let n = self.count.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let body = String::from_utf8_lossy(&request.body);
        let text = if body.contains(SKM_MARK) {
            format!("(sponge, on, bathtub)\n(mark, is, skm-answer-{n})")
        } else if body.contains(GKM_MARK) {
            format!("The sponge is on the bathtub. gkm-answer-{n}")
        } else {
            format!("1. Walk to the bathtub.\n2. Say planner-answer-{n}.")
        };
        let body: serde_json::Value = serde_json::from_slice(&request.body).unwrap_or_default();
        if body["stream"] == true {
            streamed(ProviderKind::Openai, &pieces(&text, 7), true)
        } else {
            whole(ProviderKind::Openai, &text)
        }
    }
}
