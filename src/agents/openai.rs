//! The OpenAI-compatible Chat Completions API: OpenAI itself and the servers
//! that copy it (vLLM, llama.cpp's server, Ollama's `/v1`, LM Studio,
//! OpenRouter…). Images go as base64 data URLs; answers may stream.

use serde_json::{json, Value};
use tokio_util::sync::CancellationToken;

use super::provider::{
    cut_reason, is_json, AnswerError, Assembler, BoxFuture, ChatRequest, Completion, HttpEndpoint,
    HttpSettings, Provider, SseEvent, StreamStep, TokenSink,
};
use super::{AgentError, Secret, Usage};

/// The default base URL.
pub const DEFAULT_BASE_URL: &str = "https://api.openai.com/v1";

/// Where a request goes under the base URL.
pub const REQUEST_PATH: &str = "chat/completions";

const NAME: &str = "openai";

/// A Chat Completions endpoint.
#[derive(Debug, Clone)]
pub struct OpenAi {
    endpoint: HttpEndpoint,
}

impl OpenAi {
    /// A provider for `base_url` (e.g. `http://localhost:8000/v1`).
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
        if request.json_schema.is_some() {
            match self.attempt(request, true, on_token, cancel).await {
                Err(AgentError::Http {
                    status: 400 | 422,
                    message,
                    ..
                }) => {
                    tracing::info!(%message, "JSON schema output refused; asking for text");
                }
                other => return other,
            }
        }
        self.attempt(request, false, on_token, cancel).await
    }

    async fn attempt(
        &self,
        request: &ChatRequest,
        with_schema: bool,
        on_token: TokenSink<'_>,
        cancel: &CancellationToken,
    ) -> Result<Completion, AgentError> {
        let body = request_body(request, with_schema);
        let url = self.endpoint.url(REQUEST_PATH);
        let build = || {
            let builder = self.endpoint.client.post(&url).json(&body);
            match &self.endpoint.key {
                Some(key) => builder.bearer_auth(key.expose()),
                None => builder,
            }
        };
        let mut answer = Assembler::new(on_token, self.endpoint.key.clone())
            .with_token_limit(request.max_tokens);
        let response = self.endpoint.send(build, cancel).await?;
        if request.stream && !is_json(&response) {
            let mut finished = false;
            let complete = self
                .endpoint
                .read_events(response, cancel, |event| {
                    let step = apply_event(&event, &mut answer)
                        .map_err(|err| self.endpoint.invalid(err.to_string()))?;
                    finished |= step == StreamStep::Finished;
                    Ok(step == StreamStep::Done)
                })
                .await?;
            if !complete && !finished {
                return Err(AgentError::TruncatedStream {
                    provider: NAME,
                    received: answer.received(),
                });
            }
        } else {
            let value = self.endpoint.read_json(response, cancel).await?;
            let (text, usage) = answer_of(&value).ok_or_else(|| {
                self.endpoint
                    .invalid("no choices[0].message in the answer".into())
            })?;
            answer.push(text);
            answer.usage = usage;
            answer.cut = cut_reason(&value, "/choices/0/finish_reason", "length");
            answer
                .check_limit()
                .map_err(|err| self.endpoint.invalid(err.to_string()))?;
        }
        answer.finish(NAME, &request.model)
    }
}

impl Provider for OpenAi {
    fn complete<'a>(
        &'a self,
        request: &'a ChatRequest,
        on_token: TokenSink<'a>,
        cancel: &'a CancellationToken,
    ) -> BoxFuture<'a, Result<Completion, AgentError>> {
        Box::pin(self.run(request, on_token, cancel))
    }
}

/// Adds one Chat Completions stream event to `answer`: its text piece and
/// usage. Says whether the answer goes on, was finished (a finish reason;
/// the usage may still follow) or is done (`[DONE]`); an event that is not
/// JSON or carries an error is the message to report.
pub fn apply_event(
    event: &SseEvent,
    answer: &mut Assembler<'_>,
) -> Result<StreamStep, AnswerError> {
    if event.data.trim() == "[DONE]" {
        return Ok(StreamStep::Done);
    }
    let value: Value = serde_json::from_str(&event.data)?;
    if let Some(message) = value.pointer("/error/message").and_then(Value::as_str) {
        return Err(AnswerError::InStream(message.to_string()));
    }
    if let Some(piece) = value
        .pointer("/choices/0/delta/content")
        .and_then(Value::as_str)
    {
        answer.push(piece);
    }
    if let Some(usage) = value.get("usage").and_then(usage_of) {
        answer.usage = usage;
    }
    answer.cut = answer
        .cut
        .or(cut_reason(&value, "/choices/0/finish_reason", "length"));
    answer.check_limit()?;
    let finished = value
        .pointer("/choices/0/finish_reason")
        .is_some_and(|reason| !reason.is_null());
    Ok(if finished {
        StreamStep::Finished
    } else {
        StreamStep::More
    })
}

/// The text and usage of a whole Chat Completions answer (also the body of
/// each line of a batch's output file); `None` without `choices[0].message`.
pub fn answer_of(value: &Value) -> Option<(&str, Usage)> {
    let message = value.pointer("/choices/0/message")?;
    let text = message.get("content").and_then(Value::as_str).unwrap_or("");
    let usage = value.get("usage").and_then(usage_of).unwrap_or_default();
    Some((text, usage))
}

fn usage_of(usage: &Value) -> Option<Usage> {
    Some(Usage {
        input_tokens: usage.get("prompt_tokens")?.as_u64()?,
        output_tokens: usage.get("completion_tokens")?.as_u64()?,
    })
}

/// The JSON body of a Chat Completions request.
pub fn request_body(request: &ChatRequest, with_schema: bool) -> Value {
    let mut messages = Vec::new();
    if !request.system.is_empty() {
        messages.push(json!({"role": "system", "content": request.system}));
    }
    let content = if request.images.is_empty() {
        json!(request.user)
    } else {
        let mut parts = vec![json!({"type": "text", "text": request.user})];
        parts.extend(request.images.iter().map(|image| {
            json!({
                "type": "image_url",
                "image_url": {"url": format!("data:{};base64,{}", image.media_type, image.data_base64)}
            })
        }));
        Value::Array(parts)
    };
    messages.push(json!({"role": "user", "content": content}));
    let mut body = json!({
        "model": request.model,
        "messages": messages,
        "temperature": request.temperature,
        "max_tokens": request.max_tokens,
        "stream": request.stream,
    });
    if request.stream {
        body["stream_options"] = json!({"include_usage": true});
    }
    if let (true, Some(schema)) = (with_schema, &request.json_schema) {
        body["response_format"] = json!({
            "type": "json_schema",
            "json_schema": {"name": "answer", "schema": schema, "strict": true}
        });
    }
    body
}
