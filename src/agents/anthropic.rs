//! Anthropic's Messages API, images and streaming included.

use serde_json::{json, Value};
use tokio_util::sync::CancellationToken;

use super::provider::{
    cut_reason, is_json, AnswerError, Assembler, BoxFuture, ChatRequest, Completion, HttpEndpoint,
    HttpSettings, Provider, SseEvent, StreamStep, TokenSink,
};
use super::{AgentError, Secret, Usage};

/// The default base URL.
pub const DEFAULT_BASE_URL: &str = "https://api.anthropic.com";

/// Where a request goes under the base URL.
pub const REQUEST_PATH: &str = "v1/messages";

/// The API version sent in `anthropic-version`.
pub const API_VERSION: &str = "2023-06-01";

const NAME: &str = "anthropic";

/// A Messages API endpoint.
#[derive(Debug, Clone)]
pub struct Anthropic {
    endpoint: HttpEndpoint,
}

impl Anthropic {
    /// A provider for `base_url` (the part before `/v1/messages`).
    pub fn new(
        base_url: &str,
        key: Option<Secret>,
        settings: HttpSettings,
    ) -> Result<Self, AgentError> {
        Ok(Self {
            endpoint: HttpEndpoint::new(NAME, base_url, key, settings)?,
        })
    }

    async fn run(
        &self,
        request: &ChatRequest,
        on_token: TokenSink<'_>,
        cancel: &CancellationToken,
    ) -> Result<Completion, AgentError> {
        let body = request_body(request);
        let url = self.endpoint.url(REQUEST_PATH);
        let build = || {
            let builder = self
                .endpoint
                .client
                .post(&url)
                .header("anthropic-version", API_VERSION)
                .json(&body);
            match &self.endpoint.key {
                Some(key) => builder.header("x-api-key", key.expose()),
                None => builder,
            }
        };
        let mut answer = Assembler::new(on_token, self.endpoint.key.clone())
            .with_token_limit(request.max_tokens);
        let response = self.endpoint.send(build, cancel).await?;
        if request.stream && !is_json(&response) {
            let complete = self
                .endpoint
                .read_events(response, cancel, |event| {
                    let step = apply_event(&event, &mut answer)
                        .map_err(|err| self.endpoint.invalid(err.to_string()))?;
                    Ok(step == StreamStep::Done)
                })
                .await?;
            if !complete {
                return Err(AgentError::TruncatedStream {
                    provider: NAME,
                    received: answer.received(),
                });
            }
        } else {
            let value = self.endpoint.read_json(response, cancel).await?;
            let (text, usage) = answer_of(&value)
                .ok_or_else(|| self.endpoint.invalid("no `content` in the answer".into()))?;
            answer.push(&text);
            answer.usage = usage;
            answer.cut = cut_reason(&value, "/stop_reason", "max_tokens");
            answer
                .check_limit()
                .map_err(|err| self.endpoint.invalid(err.to_string()))?;
        }
        answer.finish(NAME, &request.model)
    }
}

impl Provider for Anthropic {
    fn complete<'a>(
        &'a self,
        request: &'a ChatRequest,
        on_token: TokenSink<'a>,
        cancel: &'a CancellationToken,
    ) -> BoxFuture<'a, Result<Completion, AgentError>> {
        Box::pin(self.run(request, on_token, cancel))
    }
}

/// Adds one Messages stream event to `answer`: its text and usage. Says
/// whether the answer goes on or is done (`message_stop`); an event that is
/// not JSON or is an `error` event is the message to report.
pub fn apply_event(
    event: &SseEvent,
    answer: &mut Assembler<'_>,
) -> Result<StreamStep, AnswerError> {
    let value: Value = serde_json::from_str(&event.data)?;
    match value.get("type").and_then(Value::as_str).unwrap_or("") {
        "message_start" => {
            let usage = value.pointer("/message/usage");
            answer.usage.input_tokens = count(usage, "input_tokens");
            answer.usage.output_tokens = count(usage, "output_tokens");
        }
        "content_block_delta" => {
            if let Some(text) = value.pointer("/delta/text").and_then(Value::as_str) {
                answer.push(text);
            }
            answer.check_limit()?;
        }
        "message_delta" => {
            let output = count(value.get("usage"), "output_tokens");
            answer.usage.output_tokens = answer.usage.output_tokens.max(output);
            answer.cut = answer
                .cut
                .or(cut_reason(&value, "/delta/stop_reason", "max_tokens"));
            answer.check_limit()?;
        }
        "message_stop" => return Ok(StreamStep::Done),
        "error" => {
            let message = value
                .pointer("/error/message")
                .and_then(Value::as_str)
                .unwrap_or("unknown error");
            return Err(AnswerError::InStream(message.to_string()));
        }
        _ => {}
    }
    Ok(StreamStep::More)
}

/// The text and usage of a whole Messages answer (also the `message` of
/// each succeeded line of a batch's results); `None` without `content`.
pub fn answer_of(value: &Value) -> Option<(String, Usage)> {
    let blocks = value.get("content").and_then(Value::as_array)?;
    let text = blocks
        .iter()
        .filter_map(|block| block.get("text").and_then(Value::as_str))
        .collect();
    let usage = Usage {
        input_tokens: count(value.get("usage"), "input_tokens"),
        output_tokens: count(value.get("usage"), "output_tokens"),
    };
    Some((text, usage))
}

fn count(usage: Option<&Value>, field: &str) -> u64 {
    usage
        .and_then(|usage| usage.get(field))
        .and_then(Value::as_u64)
        .unwrap_or(0)
}

/// The JSON body of a Messages request.
pub fn request_body(request: &ChatRequest) -> Value {
    let mut content: Vec<Value> = request
        .images
        .iter()
        .map(|image| {
            json!({
                "type": "image",
                "source": {"type": "base64", "media_type": image.media_type, "data": &*image.data_base64}
            })
        })
        .collect();
    content.push(json!({"type": "text", "text": request.user}));
    let mut body = json!({
        "model": request.model,
        "max_tokens": request.max_tokens,
        "temperature": request.temperature,
        "messages": [{"role": "user", "content": content}],
        "stream": request.stream,
    });
    if !request.system.is_empty() {
        body["system"] = json!(request.system);
    }
    body
}
