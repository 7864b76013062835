//! A local OpenAI-compatible server for the end-to-end tests (wiremock, run
//! by the test process): it answers each agent's chat request with a valid
//! answer for alfred30's first task ("Place a wet sponge inside the
//! bathtub"), streamed or whole as the request asks, can hold every answer
//! back for a while, and records every request with the moment it arrived.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mapvlm::agents::AgentRole;
use serde_json::{json, Value};
use wiremock::matchers::{method, path};
use wiremock::{Mock, MockServer, Request, Respond, ResponseTemplate};

/// The SKM's answer: triples about the bathroom of the task.
pub const SKM_ANSWER: &str =
    "(sponge, on, bathtub rim)\n(sink, beside, toilet)\n(faucet, above, sink)\n(rag, in, bathtub)";
/// The GKM's answer: a grounded description of the same room.
pub const GKM_ANSWER: &str = "A green sponge lies on the rim of the bathtub on the left. The sink is behind you, to the right of the toilet, with its faucet above it.";
/// The Planner's answer: a plan for the task, one step a line.
pub const PLAN_ANSWER: &str = "1. Walk to the bathtub.\n2. Pick up the green sponge from the bathtub.\n3. Turn around and walk to the sink.\n4. Wet the sponge under the faucet.\n5. Walk back to the bathtub.\n6. Place the sponge in the bathtub.";

/// What marks each agent's request: the first words of the shipped system
/// prompts (a request with neither miner's mark is a planner's; the
/// planner's prompt names the miners, never as "You are").
const SKM_MARK: &str = "You are the semantic-knowledge miner";
/// See [`SKM_MARK`].
const GKM_MARK: &str = "You are the grounded-knowledge miner";

/// One request the server received.
#[derive(Debug, Clone)]
pub struct Received {
    /// Whose request it was, by the marks of the shipped prompts
    /// ([`AgentRole::Planner`] for any planning request).
    pub role: AgentRole,
    /// The JSON body as sent.
    pub body: Value,
    /// When it arrived; its answer left `delay` later.
    pub at: Instant,
}

impl Received {
    /// The request's whole text (every message), for `contains` checks.
    pub fn text(&self) -> String {
        self.body.to_string()
    }
}

/// What the server answers: fixed per agent, the plan chosen by the first
/// rule whose needle the planner's request contains.
#[derive(Debug, Clone)]
struct Answers {
    delay: Duration,
    plans: Vec<(String, String)>,
    planner_fails: Option<Failure>,
    /// Failures for the next planner requests, one each, before
    /// `planner_fails` applies.
    planner_next: std::collections::VecDeque<Failure>,
}

/// How the server fails the planner's requests, when told to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// An HTTP error with this status and a JSON error body.
    Status(u16),
    /// The same with a `Retry-After` of this many seconds.
    RetryAfter(u16, u64),
    /// A streamed answer that stops after this many pieces, with no end
    /// of answer and no `[DONE]`: a connection dropped mid-stream.
    DropAfter(usize),
}

/// The server's state, shared with its responder.
#[derive(Debug)]
struct Shared {
    answers: Mutex<Answers>,
    log: Mutex<Vec<Received>>,
}

struct Responder(Arc<Shared>);

impl Respond for Responder {
    fn respond(&self, request: &Request) -> ResponseTemplate {
        let at = Instant::now();
        let body: Value = serde_json::from_slice(&request.body).unwrap_or(Value::Null);
        let text = body.to_string();
        let role = if text.contains(SKM_MARK) {
            AgentRole::Skm
        } else if text.contains(GKM_MARK) {
            AgentRole::Gkm
        } else {
            AgentRole::Planner
        };
        let (answers, next) = {
            let mut answers = self.0.answers.lock().unwrap();
            let next = if role == AgentRole::Planner {
                answers.planner_next.pop_front()
            } else {
                None
            };
            (answers.clone(), next)
        };
        let answer = match role {
            AgentRole::Skm => SKM_ANSWER.to_string(),
            AgentRole::Gkm => GKM_ANSWER.to_string(),
            _ => answers
                .plans
                .iter()
                .find(|(needle, _)| text.contains(needle.as_str()))
                .map_or_else(|| PLAN_ANSWER.to_string(), |(_, plan)| plan.clone()),
        };
        let stream = body["stream"].as_bool().unwrap_or(false);
        self.0.log.lock().unwrap().push(Received { role, body, at });
        let failure = next.or(answers.planner_fails.filter(|_| role == AgentRole::Planner));
        let refusal = |status| {
            ResponseTemplate::new(status).set_body_json(
                json!({"error": {"message": "the server was told to fail", "type": "server_error"}}),
            )
        };
        match failure {
            Some(Failure::Status(status)) => refusal(status),
            Some(Failure::RetryAfter(status, seconds)) => {
                refusal(status).insert_header("retry-after", seconds.to_string().as_str())
            }
            Some(Failure::DropAfter(pieces)) => {
                let mut events = String::new();
                for piece in answer.split_inclusive(' ').take(pieces) {
                    let delta = json!({"choices": [{"index": 0, "delta": {"content": piece}, "finish_reason": null}]});
                    events.push_str(&format!("data: {delta}\n\n"));
                }
                ResponseTemplate::new(200)
                    .insert_header("content-type", "text/event-stream")
                    .set_body_string(events)
            }
            None => openai_answer(&answer, stream),
        }
        .set_delay(answers.delay)
    }
}

/// An OpenAI chat-completions answer: server-sent events a few words at a
/// time when `stream`, else one JSON body; the usage counts four characters
/// a token.
fn openai_answer(text: &str, stream: bool) -> ResponseTemplate {
    let usage = json!({"prompt_tokens": 120, "completion_tokens": text.len().div_ceil(4)});
    if !stream {
        return ResponseTemplate::new(200).set_body_json(json!({
            "id": "local", "object": "chat.completion",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
            "usage": usage,
        }));
    }
    let mut events = String::new();
    let mut event = |value: Value| events.push_str(&format!("data: {value}\n\n"));
    for piece in text.split_inclusive(' ') {
        event(
            json!({"choices": [{"index": 0, "delta": {"content": piece}, "finish_reason": null}]}),
        );
    }
    event(json!({"choices": [{"index": 0, "delta": {}, "finish_reason": "stop"}]}));
    event(json!({"choices": [], "usage": usage}));
    events.push_str("data: [DONE]\n\n");
    ResponseTemplate::new(200)
        .insert_header("content-type", "text/event-stream")
        .set_body_string(events)
}

/// The local server, stopped when dropped.
pub struct LocalServer {
    server: MockServer,
    shared: Arc<Shared>,
    /// The runtime the server was started from (wiremock serves on a
    /// thread of its own; this keeps its handle valid).
    _runtime: tokio::runtime::Runtime,
}

impl LocalServer {
    /// A server answering every request at once.
    pub fn start() -> LocalServer {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let shared = Arc::new(Shared {
            answers: Mutex::new(Answers {
                delay: Duration::ZERO,
                plans: Vec::new(),
                planner_fails: None,
                planner_next: Default::default(),
            }),
            log: Mutex::new(Vec::new()),
        });
        let server = runtime.block_on(async {
            let server = MockServer::start().await;
            Mock::given(method("POST"))
                .and(path("/v1/chat/completions"))
                .respond_with(Responder(shared.clone()))
                .mount(&server)
                .await;
            server
        });
        LocalServer {
            server,
            shared,
            _runtime: runtime,
        }
    }

    /// Holds every later answer back for `delay` after its request arrived.
    pub fn delay_answers(&self, delay: Duration) -> &Self {
        self.shared.answers.lock().unwrap().delay = delay;
        self
    }

    /// From now on, answers a planner whose request contains `needle` with
    /// `plan` (the first rule that matches wins; else [`PLAN_ANSWER`]).
    pub fn plan_when(&self, needle: &str, plan: &str) -> &Self {
        self.shared
            .answers
            .lock()
            .unwrap()
            .plans
            .push((needle.to_string(), plan.to_string()));
        self
    }

    /// From now on, fails every planner request as `failure` says (`None`:
    /// answers again).
    pub fn fail_planner(&self, failure: Option<Failure>) -> &Self {
        self.shared.answers.lock().unwrap().planner_fails = failure;
        self
    }

    /// Fails the next planner requests as `failures` say, one each, then
    /// answers again.
    pub fn fail_planner_next(&self, failures: &[Failure]) -> &Self {
        self.shared
            .answers
            .lock()
            .unwrap()
            .planner_next
            .extend(failures.iter().copied());
        self
    }

    /// The base URL to give the agents (`http://127.0.0.1:PORT/v1`).
    pub fn base_url(&self) -> String {
        format!("{}/v1", self.server.uri())
    }

    /// Every request so far, in the order they arrived.
    pub fn requests(&self) -> Vec<Received> {
        self.shared.log.lock().unwrap().clone()
    }

    /// Waits until at least `n` requests arrived and returns them all;
    /// fails after 30 s naming how many came.
    pub fn wait_for_requests(&self, n: usize) -> Vec<Received> {
        super::tmux::wait(&format!("{n} requests at the local server"), || {
            let seen = self.requests();
            if seen.len() >= n {
                Ok(seen)
            } else {
                Err(format!("{} request(s): {:?}", seen.len(), roles(&seen)))
            }
        })
    }
}

/// The roles of `requests`, in order.
pub fn roles(requests: &[Received]) -> Vec<AgentRole> {
    requests.iter().map(|r| r.role).collect()
}

/// The request of `role` among `requests`; fails the test when there is
/// not exactly one.
pub fn only(requests: &[Received], role: AgentRole) -> Received {
    let found: Vec<&Received> = requests.iter().filter(|r| r.role == role).collect();
    assert_eq!(
        found.len(),
        1,
        "one {role:?} request expected: {:?}",
        roles(requests)
    );
    found[0].clone()
}

/// Whether `a` and `b` were both at the server before either was answered,
/// with answers held back `delay`: each arrived less than `delay` after
/// the other.
pub fn overlapped(a: &Received, b: &Received, delay: Duration) -> bool {
    let gap = if a.at > b.at {
        a.at - b.at
    } else {
        b.at - a.at
    };
    gap < delay
}
