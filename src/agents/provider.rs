//! What every provider shares: the request an agent makes, the answer it
//! gets, the `Provider` trait, and the HTTP plumbing (timeouts, retries with
//! backoff honouring `Retry-After`, cancellation, server-sent events).

use std::future::Future;
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::Arc;
use std::time::{Duration, Instant};

use reqwest::{RequestBuilder, Response, StatusCode};
use serde::{Deserialize, Serialize};
use tokio_util::sync::CancellationToken;

use super::{AgentError, Secret, Usage};

/// A boxed future, so that providers can be trait objects.
pub type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// Receives each piece of text as it arrives.
pub type TokenSink<'a> = &'a (dyn Fn(&str) + Send + Sync);

/// An image ready to send: validated, downscaled and encoded.
#[derive(Debug, Clone)]
pub struct ImageInput {
    /// The file it came from, for messages.
    pub path: PathBuf,
    /// Its MIME type (`image/jpeg`, `image/png`…).
    pub media_type: String,
    /// The bytes sent, base64-encoded; shared, since every request and
    /// sample of a run sends the same image (megabytes each).
    pub data_base64: Arc<str>,
    /// SHA-256 of the bytes sent: the image's part of the cache key.
    pub sha256: String,
}

/// One call to a model.
#[derive(Debug, Clone)]
pub struct ChatRequest {
    /// The model name.
    pub model: String,
    /// The system prompt (may be empty).
    pub system: String,
    /// The user message.
    pub user: String,
    /// Images sent with the user message.
    pub images: Vec<ImageInput>,
    /// Sampling temperature.
    pub temperature: f32,
    /// Most tokens to write.
    pub max_tokens: u32,
    /// Whether to ask for a streamed answer.
    pub stream: bool,
    /// A JSON schema the answer should follow, when the provider supports it.
    pub json_schema: Option<serde_json::Value>,
}

/// Characters counted as one token in an estimate (English prose averages
/// about four with the tokenisers of both providers).
pub const CHARS_PER_TOKEN: u64 = 4;

/// Tokens counted for one image in an estimate: an image downscaled to the
/// default longest edge of 1024 pixels costs between about 800 (OpenAI, high
/// detail) and 1,400 (Anthropic) tokens.
pub const TOKENS_PER_IMAGE: u64 = 1_000;

impl ChatRequest {
    /// A rough count of the tokens this request uses, for the estimate made
    /// before anything is sent: its text at [`CHARS_PER_TOKEN`] characters
    /// a token plus [`TOKENS_PER_IMAGE`] per image in, its `max_tokens` out
    /// (an upper bound).
    pub fn estimated_usage(&self) -> Usage {
        let chars = (self.system.chars().count() + self.user.chars().count()) as u64;
        Usage {
            input_tokens: chars.div_ceil(CHARS_PER_TOKEN)
                + TOKENS_PER_IMAGE * self.images.len() as u64,
            output_tokens: u64::from(self.max_tokens),
        }
    }
}

/// A piece of a streamed answer and when it arrived.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Chunk {
    /// Milliseconds since the request was first sent.
    pub at_ms: u64,
    /// The text.
    pub text: String,
}

/// A finished answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Completion {
    /// The whole text.
    pub text: String,
    /// Token counts, as the provider reported them.
    pub usage: Usage,
    /// The pieces as they were received (one piece for a non-streamed answer).
    pub chunks: Vec<Chunk>,
}

/// A model behind an API.
pub trait Provider: Send + Sync {
    /// Sends `request`, passing each piece of text to `on_token` as it
    /// arrives, and returns the whole answer.
    fn complete<'a>(
        &'a self,
        request: &'a ChatRequest,
        on_token: TokenSink<'a>,
        cancel: &'a CancellationToken,
    ) -> BoxFuture<'a, Result<Completion, AgentError>>;
}

/// A shared provider.
pub type SharedProvider = Arc<dyn Provider>;

/// Timeouts and retry policy of the HTTP providers.
#[derive(Debug, Clone)]
pub struct HttpSettings {
    /// Longest wait for a connection.
    pub connect_timeout: Duration,
    /// Longest wait for one whole answer.
    pub total_timeout: Duration,
    /// Retries after a 429 or 5xx answer.
    pub max_retries: u32,
    /// The first backoff delay; it doubles each retry.
    pub backoff: Duration,
    /// The longest `Retry-After` honoured.
    pub max_retry_after: Duration,
    /// Where waits before a retry are announced (none: silent).
    pub notify: Option<Notifier>,
}

/// Tells the user what the HTTP layer waits for (a retry after a 429 or
/// 5xx): the command line prints it on stderr, the workbench shows it in
/// the agent's pane, a test collects it.
#[derive(Clone)]
pub struct Notifier(pub Arc<dyn Fn(&RetryNotice) + Send + Sync>);

/// A wait before a retry, as the user is told of it: without it, retries
/// and a long `Retry-After` look like a hang.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RetryNotice {
    /// The provider's name.
    pub provider: String,
    /// The HTTP status that is retried.
    pub status: u16,
    /// How long it waits, in milliseconds.
    pub wait_ms: u64,
    /// Whether the server asked for the wait (`Retry-After`).
    pub asked: bool,
    /// The retry this wait is before (1-based).
    pub retry: u32,
    /// The retries allowed.
    pub of: u32,
}

impl std::fmt::Display for RetryNotice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} answered HTTP {}; waiting {:.1} s{} before retry {} of {}",
            self.provider,
            self.status,
            Duration::from_millis(self.wait_ms).as_secs_f64(),
            if self.asked { " (Retry-After)" } else { "" },
            self.retry,
            self.of
        )
    }
}

impl std::fmt::Debug for Notifier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Notifier")
    }
}

impl Default for HttpSettings {
    fn default() -> Self {
        Self {
            connect_timeout: Duration::from_secs(10),
            total_timeout: Duration::from_secs(180),
            max_retries: 4,
            backoff: Duration::from_millis(500),
            max_retry_after: Duration::from_secs(60),
            notify: None,
        }
    }
}

/// The full URL of `path` under `base_url`, as a request goes: one slash
/// between them, and a query string of the base URL (`?api-version=…`)
/// kept after the path.
pub fn endpoint_url(base_url: &str, path: &str) -> String {
    let (base, query) = match base_url.split_once('?') {
        Some((base, query)) => (base, Some(query)),
        None => (base_url, None),
    };
    let mut url = format!(
        "{}/{}",
        base.trim_end_matches('/'),
        path.trim_start_matches('/')
    );
    if let Some(query) = query {
        url.push('?');
        url.push_str(query);
    }
    url
}

/// The HTTP side of a provider: a client, its endpoint, key and policy.
#[derive(Debug, Clone)]
pub struct HttpEndpoint {
    /// The provider's name for messages.
    pub provider: &'static str,
    /// The client (rustls with the bundled web roots and the system's,
    /// `SSL_CERT_FILE`/`SSL_CERT_DIR` included; gzip bodies decoded;
    /// timeouts set).
    pub client: reqwest::Client,
    /// The base URL, without a trailing slash.
    pub base_url: String,
    /// The API key, if any.
    pub key: Option<Secret>,
    /// Timeouts and retries.
    pub settings: HttpSettings,
}

impl HttpEndpoint {
    /// Builds the client for `base_url`.
    pub fn new(
        provider: &'static str,
        base_url: &str,
        key: Option<Secret>,
        settings: HttpSettings,
    ) -> Result<Self, AgentError> {
        let client = reqwest::Client::builder()
            // A redirect would send the prompt and image to another origin
            // (a POST may even become a GET): it is named, never followed.
            .redirect(reqwest::redirect::Policy::none())
            .connect_timeout(settings.connect_timeout)
            .timeout(settings.total_timeout)
            .build()
            .map_err(|err| AgentError::Connect {
                provider,
                url: crate::sanitize::redact_url_credentials(base_url),
                message: crate::sanitize::redact_url_credentials(&err.to_string()),
            })?;
        Ok(Self {
            provider,
            client,
            base_url: base_url.trim_end_matches('/').to_string(),
            key,
            settings,
        })
    }

    /// The full URL of `path` under the base URL ([`endpoint_url`]).
    pub fn url(&self, path: &str) -> String {
        endpoint_url(&self.base_url, path)
    }

    /// An unreadable-answer error for this provider, the key removed.
    pub fn invalid(&self, message: String) -> AgentError {
        AgentError::InvalidResponse {
            provider: self.provider,
            message: self.redact(&message),
        }
    }

    /// The base URL as messages show it: credentials in it replaced by `***`.
    pub fn shown_url(&self) -> String {
        crate::sanitize::redact_url_credentials(&self.base_url)
    }

    /// Removes the key, and any credentials of a URL, from a message.
    pub fn redact(&self, text: &str) -> String {
        let text = crate::sanitize::redact_url_credentials(text);
        match &self.key {
            Some(key) => key.redact(&text),
            None => text,
        }
    }

    /// Sends the request `build` makes, retrying 429 and 5xx answers with
    /// exponential backoff (or the server's `Retry-After`), and returns the
    /// first successful response. 401 and 403 end at once. Waits are
    /// announced and never run past the total timeout: a server asking for
    /// a longer wait gets an error saying so instead.
    pub async fn send(
        &self,
        build: impl Fn() -> RequestBuilder,
        cancel: &CancellationToken,
    ) -> Result<Response, AgentError> {
        let started = Instant::now();
        let mut attempt = 0;
        loop {
            let response = cancellable(cancel, build().send())
                .await?
                .map_err(|err| self.transport_error(&err))?;
            let status = response.status();
            if status.is_success() {
                return self.not_a_web_page(response);
            }
            if status.is_redirection() {
                let to = response
                    .headers()
                    .get(reqwest::header::LOCATION)
                    .map(|v| String::from_utf8_lossy(v.as_bytes()).into_owned())
                    .unwrap_or_else(|| "nowhere said".into());
                return Err(AgentError::Http {
                    provider: self.provider,
                    status: status.as_u16(),
                    message: format!(
                        "a redirect to {}: redirects are not followed, so the prompt and image go nowhere else; set the base URL to where the API is",
                        shorten(&crate::sanitize::for_terminal(&self.redact(&to)), 200)
                    ),
                });
            }
            if status == StatusCode::UNAUTHORIZED || status == StatusCode::FORBIDDEN {
                return Err(AgentError::KeyRefused {
                    provider: self.provider,
                    status: status.as_u16(),
                });
            }
            let retryable = status == StatusCode::TOO_MANY_REQUESTS || status.is_server_error();
            if !retryable || attempt >= self.settings.max_retries {
                return Err(self.status_error(response).await);
            }
            let asked = retry_after(&response);
            let wait = asked
                .map(|wait| wait.min(self.settings.max_retry_after))
                .unwrap_or_else(|| {
                    self.settings
                        .backoff
                        .saturating_mul(2u32.saturating_pow(attempt))
                });
            let limit = self.settings.total_timeout;
            if started.elapsed() + wait > limit {
                let why = match asked {
                    Some(asked) => format!(
                        "the server asks to wait {:.0} s (Retry-After)",
                        asked.as_secs_f64()
                    ),
                    None => format!("the next retry would wait {:.1} s", wait.as_secs_f64()),
                };
                return Err(AgentError::Http {
                    provider: self.provider,
                    status: status.as_u16(),
                    message: format!(
                        "{why}, past the limit of {:.1} s (--timeout); try again later or raise --timeout",
                        limit.as_secs_f64()
                    ),
                });
            }
            tracing::warn!(
                provider = self.provider,
                status = status.as_u16(),
                wait_ms = wait.as_millis() as u64,
                "retrying"
            );
            if let Some(notify) = &self.settings.notify {
                (notify.0)(&RetryNotice {
                    provider: self.provider.to_string(),
                    status: status.as_u16(),
                    wait_ms: u64::try_from(wait.as_millis()).unwrap_or(u64::MAX),
                    asked: asked.is_some(),
                    retry: attempt + 1,
                    of: self.settings.max_retries,
                });
            }
            cancellable(cancel, tokio::time::sleep(wait)).await?;
            attempt += 1;
        }
    }

    /// A successful response, unless it is a web page: a wrong base URL
    /// often leads to a site's HTML page with status 200, which is neither
    /// an answer nor an event stream.
    fn not_a_web_page(&self, response: Response) -> Result<Response, AgentError> {
        let html = response
            .headers()
            .get(reqwest::header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .is_some_and(|v| v.trim_start().starts_with("text/html"));
        if html {
            return Err(AgentError::InvalidResponse {
                provider: self.provider,
                message: format!(
                    "{} sent a web page (text/html), not an API answer: check the base URL (an OpenAI-compatible one usually ends in /v1)",
                    self.shown_url()
                ),
            });
        }
        Ok(response)
    }

    /// Turns an unsuccessful response into an error carrying the server's
    /// message (at most [`crate::limits::MAX_ERROR_BODY_BYTES`] of the body are read),
    /// shortened, made printable and with the key removed; a body that is
    /// not text is named by its size.
    pub async fn status_error(&self, mut response: Response) -> AgentError {
        let status = response.status().as_u16();
        let limit = crate::limits::MAX_ERROR_BODY_BYTES;
        let mut body = Vec::new();
        while body.len() < limit {
            match response.chunk().await {
                Ok(Some(piece)) => body.extend_from_slice(&piece),
                _ => break,
            }
        }
        body.truncate(limit);
        let message = serde_json::from_slice::<serde_json::Value>(&body)
            .ok()
            .and_then(|v| {
                v.pointer("/error/message")
                    .and_then(|m| m.as_str())
                    .map(crate::sanitize::for_terminal)
            })
            .unwrap_or_else(|| crate::sanitize::body_text(&body));
        AgentError::Http {
            provider: self.provider,
            status,
            message: shorten(&self.redact(message.trim()), 300),
        }
    }

    /// Maps a reqwest error to the agent error a user understands.
    pub fn transport_error(&self, err: &reqwest::Error) -> AgentError {
        if err.is_timeout() {
            AgentError::Timeout {
                provider: self.provider,
                seconds: self.settings.total_timeout.as_secs_f64(),
            }
        } else if err.is_connect() {
            AgentError::Connect {
                provider: self.provider,
                url: self.shown_url(),
                message: self.redact(&connection_failure(err)),
            }
        } else {
            AgentError::InvalidResponse {
                provider: self.provider,
                message: self.redact(&root_cause(err)),
            }
        }
    }

    /// Reads a whole JSON body of at most [`crate::limits::MAX_BODY_BYTES`].
    pub async fn read_json(
        &self,
        mut response: Response,
        cancel: &CancellationToken,
    ) -> Result<serde_json::Value, AgentError> {
        let limit = crate::limits::MAX_BODY_BYTES;
        let too_long = || {
            self.invalid(format!(
                "a body longer than the limit of {} MiB ({limit} bytes): not a model's answer; check the base URL",
                limit >> 20
            ))
        };
        if response.content_length().is_some_and(|n| n > limit as u64) {
            return Err(too_long());
        }
        let streamed = response
            .headers()
            .get(reqwest::header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .is_some_and(|v| v.starts_with("text/event-stream"));
        let mut body = Vec::new();
        while let Some(piece) = cancellable(cancel, response.chunk())
            .await?
            .map_err(|err| self.transport_error(&err))?
        {
            if body.len() + piece.len() > limit {
                return Err(too_long());
            }
            body.extend_from_slice(&piece);
        }
        serde_json::from_slice(&body).map_err(|err| {
            let excerpt = shorten(&self.redact(&crate::sanitize::body_text(&body)), 120);
            let message = if streamed || body.starts_with(b"data:") {
                format!(
                    "an event stream (text/event-stream) instead of the whole answer asked for (--no-stream): the server does not honour `\"stream\": false`; leave out --no-stream. It began: {}",
                    crate::sanitize::one_line(&excerpt)
                )
            } else {
                format!("invalid JSON ({err}): {}", crate::sanitize::one_line(&excerpt))
            };
            AgentError::InvalidResponse {
                provider: self.provider,
                message,
            }
        })
    }

    /// Reads a server-sent-event stream, handing each event to `on_event`
    /// until it returns `Ok(true)` (the answer is complete) or the stream
    /// ends; returns whether the answer was complete.
    pub async fn read_events(
        &self,
        mut response: Response,
        cancel: &CancellationToken,
        mut on_event: impl FnMut(SseEvent) -> Result<bool, AgentError>,
    ) -> Result<bool, AgentError> {
        let mut parser = SseParser::default();
        let mut events = Vec::new();
        loop {
            let chunk = cancellable(cancel, response.chunk())
                .await?
                .map_err(|err| self.transport_error(&err))?;
            let fed = match &chunk {
                Some(bytes) => parser.feed(bytes, &mut events),
                None => {
                    events.extend(parser.finish());
                    Ok(())
                }
            };
            for event in events.drain(..) {
                if on_event(event)? {
                    return Ok(true);
                }
            }
            fed.map_err(|err| AgentError::InvalidResponse {
                provider: self.provider,
                message: err.to_string(),
            })?;
            if chunk.is_none() {
                return Ok(false);
            }
        }
    }
}

/// The most timed pieces an answer keeps (a real answer has a few thousand;
/// a replay plays them back as they came).
const MAX_CHUNKS: usize = 65_536;

/// Gathers a streamed answer: its pieces with their arrival times (the text
/// is joined from them once, at the end, so a long answer is held once while
/// it streams), and the usage once reported. The API key is removed from the text
/// before anything is passed on or kept, even when it arrives split across
/// pieces: the end of the text that could be the start of the key is held
/// back until the next piece tells.
pub struct Assembler<'a> {
    start: Instant,
    on_token: TokenSink<'a>,
    key: Option<Secret>,
    held: String,
    chunks: Vec<Chunk>,
    /// The bytes and characters passed on so far.
    bytes: usize,
    chars: usize,
    /// The usage reported so far.
    pub usage: Usage,
    /// The stop reason, when the provider said it cut the answer at the
    /// token limit (`finish_reason "length"`, `stop_reason "max_tokens"`).
    pub cut: Option<&'static str>,
    /// The request's token limit, when the answer is held to it.
    max_tokens: Option<u32>,
}

impl<'a> Assembler<'a> {
    /// Starts gathering, removing `key` from the text; times count from now.
    pub fn new(on_token: TokenSink<'a>, key: Option<Secret>) -> Self {
        Self {
            start: Instant::now(),
            on_token,
            // A placeholder key is not looked for (see `Secret::redact`).
            key: key.filter(|k| !k.is_placeholder()),
            held: String::new(),
            chunks: Vec::new(),
            bytes: 0,
            chars: 0,
            usage: Usage::default(),
            cut: None,
            max_tokens: None,
        }
    }

    /// Holds the answer to the request's token limit: more output tokens
    /// reported than `max_tokens`, or more than
    /// [`crate::limits::ANSWER_BYTES_PER_TOKEN`] bytes a token, ends it
    /// (see [`Self::check_limit`]).
    pub fn with_token_limit(mut self, max_tokens: u32) -> Self {
        self.max_tokens = Some(max_tokens);
        self
    }

    /// Refuses an answer past its token limit: what a decoder reports, so
    /// that reading stops there and memory stays bounded.
    pub fn check_limit(&self) -> Result<(), AnswerError> {
        let Some(max_tokens) = self.max_tokens else {
            return Ok(());
        };
        let bytes = self.bytes + self.held.len();
        let limit = crate::limits::answer_bytes(max_tokens);
        if bytes > limit {
            return Err(AnswerError::PastByteLimit { limit, max_tokens });
        }
        if self.usage.output_tokens > u64::from(max_tokens) {
            return Err(AnswerError::PastTokenLimit {
                reported: self.usage.output_tokens,
                max_tokens,
            });
        }
        Ok(())
    }

    /// Adds a piece of text and passes on what of it is known to hold no key.
    pub fn push(&mut self, piece: &str) {
        if piece.is_empty() {
            return;
        }
        self.held.push_str(piece);
        let Some(key) = &self.key else {
            let ready = std::mem::take(&mut self.held);
            return self.pass_on(ready);
        };
        if self.held.contains(key.expose()) {
            self.held = key.redact(&self.held);
        }
        let keep = (0..self.held.len())
            .rev()
            .filter(|&cut| self.held.is_char_boundary(cut))
            .find(|&cut| key.expose().starts_with(&self.held[cut..]))
            .unwrap_or(self.held.len());
        let rest = self.held.split_off(keep);
        let ready = std::mem::replace(&mut self.held, rest);
        self.pass_on(ready);
    }

    fn pass_on(&mut self, ready: String) {
        if ready.is_empty() {
            return;
        }
        (self.on_token)(&ready);
        self.bytes += ready.len();
        self.chars += ready.chars().count();
        let full = self.chunks.len() >= MAX_CHUNKS;
        match self.chunks.last_mut() {
            // Past this many pieces the rest join the last one: a stream of
            // tiny events would otherwise cost far more to keep than its text.
            Some(last) if full => last.text.push_str(&ready),
            _ => self.chunks.push(Chunk {
                at_ms: elapsed_ms(self.start),
                text: ready,
            }),
        }
    }

    /// How many characters have arrived.
    pub fn received(&self) -> usize {
        self.chars + self.held.chars().count()
    }

    /// The finished answer; an empty or blank one is an error, and so is
    /// one the provider cut at the token limit (never kept as complete).
    pub fn finish(mut self, provider: &'static str, model: &str) -> Result<Completion, AgentError> {
        let rest = std::mem::take(&mut self.held);
        self.pass_on(rest);
        if let Some(reason) = self.cut {
            return Err(AgentError::CutAnswer {
                provider,
                model: model.to_string(),
                reason,
                received: self.chars,
            });
        }
        let text: String = self.chunks.iter().map(|c| c.text.as_str()).collect();
        if text.trim().is_empty() {
            return Err(AgentError::EmptyAnswer {
                provider,
                model: model.to_string(),
            });
        }
        Ok(Completion {
            text,
            usage: self.usage,
            chunks: self.chunks,
        })
    }
}

/// `Some(cut)` when the stop reason at `pointer` of an answer or stream
/// event is `cut`, the provider's word for an answer cut at the token limit
/// (`length` for Chat Completions, `max_tokens` for Messages).
pub fn cut_reason(
    value: &serde_json::Value,
    pointer: &str,
    cut: &'static str,
) -> Option<&'static str> {
    (value.pointer(pointer).and_then(serde_json::Value::as_str) == Some(cut)).then_some(cut)
}

/// Whether a response is a whole JSON document (some servers answer so
/// even when a stream was asked for).
pub fn is_json(response: &Response) -> bool {
    response
        .headers()
        .get(reqwest::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"))
}

/// Runs `future` unless `cancel` fires first.
pub async fn cancellable<T>(
    cancel: &CancellationToken,
    future: impl Future<Output = T>,
) -> Result<T, AgentError> {
    tokio::select! {
        biased;
        _ = cancel.cancelled() => Err(AgentError::Cancelled),
        value = future => Ok(value),
    }
}

/// The `Retry-After` header as a delay (seconds; an HTTP date is ignored).
fn retry_after(response: &Response) -> Option<Duration> {
    let value = response.headers().get(reqwest::header::RETRY_AFTER)?;
    let seconds: f64 = value.to_str().ok()?.trim().parse().ok()?;
    (seconds.is_finite() && seconds >= 0.0).then(|| Duration::from_secs_f64(seconds))
}

fn root_cause(err: &(dyn std::error::Error + 'static)) -> String {
    let mut cause = err;
    while let Some(next) = cause.source() {
        cause = next;
    }
    cause.to_string()
}

/// What a failed connection says: its deepest cause, with where trusted
/// certificates come from when it is a TLS failure; the one wording of the
/// providers' clients and of `models fetch`'s Hub downloads.
pub fn connection_failure(err: &(dyn std::error::Error + 'static)) -> String {
    with_certificate_hint(root_cause(err))
}

/// A TLS failure's cause with where trusted certificates come from: the
/// system's roots, `SSL_CERT_FILE` and `SSL_CERT_DIR` (read by
/// rustls-native-certs), so a server behind a private CA can be reached;
/// also said of `models fetch`'s downloads (the Hub, and pip, which is
/// given `SSL_CERT_FILE`). Other causes are returned as they are.
pub fn with_certificate_hint(cause: String) -> String {
    if cause.to_ascii_lowercase().contains("certificate") {
        format!(
            "{cause} (the system's certificates and the bundled web roots are trusted; for a private CA put its PEM file in SSL_CERT_FILE or its folder in SSL_CERT_DIR)"
        )
    } else {
        cause
    }
}

/// At most `limit` characters of `text`, with `…` when cut.
pub fn shorten(text: &str, limit: usize) -> String {
    match text.char_indices().nth(limit) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_string(),
    }
}

/// Milliseconds since `start`.
pub fn elapsed_ms(start: Instant) -> u64 {
    start.elapsed().as_millis() as u64
}

/// Where a stream stands after one event, as a provider's decoder reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamStep {
    /// More is to come.
    More,
    /// The answer's text is finished, though the stream may still carry
    /// its usage before it ends.
    Finished,
    /// The answer is complete: stop reading.
    Done,
}

/// A provider's stream decoder: adds one event to the answer and says where
/// the stream stands, or why it cannot take the event
/// (`openai::apply_event`, `anthropic::apply_event`).
pub type EventDecoder = fn(&SseEvent, &mut Assembler<'_>) -> Result<StreamStep, AnswerError>;

/// Why an answer cannot be taken as it arrives; the provider reports it as
/// an [`AgentError::InvalidResponse`] with the key removed.
#[derive(Debug, thiserror::Error)]
pub enum AnswerError {
    /// An event's data is not JSON.
    #[error("invalid JSON in stream event ({0})")]
    Json(#[from] serde_json::Error),
    /// The server put an error into the stream.
    #[error("error in stream: {0}")]
    InStream(String),
    /// More text than the token limit allows: the server ignores it.
    #[error("an answer longer than the limit of {limit} bytes ({} bytes a token of max_tokens {max_tokens}): the server does not hold to the token limit; check the base URL", crate::limits::ANSWER_BYTES_PER_TOKEN)]
    PastByteLimit {
        /// The bytes allowed.
        limit: usize,
        /// The request's limit.
        max_tokens: u32,
    },
    /// The server's own count is past the token limit.
    #[error("the server reports {reported} output tokens, past max_tokens {max_tokens}: it does not hold to the token limit")]
    PastTokenLimit {
        /// The output tokens reported.
        reported: u64,
        /// The request's limit.
        max_tokens: u32,
    },
}

/// One server-sent event.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SseEvent {
    /// The `event:` field, if any.
    pub event: Option<String>,
    /// The `data:` lines, joined with newlines.
    pub data: String,
}

/// The most bytes one server-sent event may take, counting a line while it
/// waits for its end and the event's gathered `data:` lines. A model's
/// stream event carries one piece of text and a few fields (a few hundred
/// bytes, a few kilobytes at most); 1 MiB leaves room for any of them while
/// keeping a server that sends a line with no end from filling memory.
pub const MAX_EVENT_BYTES: usize = 1 << 20;

/// A stream line or event grew past [`MAX_EVENT_BYTES`]: whatever sends it
/// is not streaming a model's answer, and reading on would only fill memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "a stream line or event longer than the limit of 1 MiB ({} bytes): not a model's answer; check the base URL",
    MAX_EVENT_BYTES
)]
pub struct EventTooLong;

/// An incremental parser of `text/event-stream` bodies. Each byte is looked
/// at once however the body is cut into pieces, and an event is bounded by
/// [`MAX_EVENT_BYTES`].
#[derive(Debug, Default)]
pub struct SseParser {
    /// Bytes after the last line end seen.
    pending: Vec<u8>,
    event: Option<String>,
    data: Option<String>,
    /// Bytes looked at while searching for line ends, for the test that
    /// feeding is linear.
    #[cfg(test)]
    scanned: usize,
}

impl SseParser {
    /// Feeds bytes, adding the events they complete to `events`; gives
    /// [`EventTooLong`] once a line or an event outgrows the limit (the
    /// parser is then done). The events and the error do not depend on how
    /// the body is cut into pieces.
    pub fn feed(&mut self, bytes: &[u8], events: &mut Vec<SseEvent>) -> Result<(), EventTooLong> {
        // `pending` holds no line end, so only the new bytes are searched.
        let searched = self.pending.len();
        self.pending.extend_from_slice(bytes);
        let pending = std::mem::take(&mut self.pending);
        let mut start = 0;
        let mut from = searched;
        while let Some(offset) = pending[from..].iter().position(|&b| b == b'\n') {
            #[cfg(test)]
            {
                self.scanned += offset + 1;
            }
            let end = from + offset;
            let line = &pending[start..end];
            self.check(line.len())?;
            self.line(line, events);
            self.check(0)?;
            start = end + 1;
            from = start;
        }
        #[cfg(test)]
        {
            self.scanned += pending.len() - from;
        }
        self.pending = pending;
        self.pending.drain(..start);
        self.check(self.pending.len())
    }

    /// Ends the stream; returns the last event if it lacked a blank line.
    pub fn finish(&mut self) -> Vec<SseEvent> {
        let mut events = Vec::new();
        let pending = std::mem::take(&mut self.pending);
        if !pending.is_empty() {
            self.line(&pending, &mut events);
        }
        self.line(b"", &mut events);
        events
    }

    /// Refuses a `line` of that many bytes, or an event whose gathered
    /// fields pass the limit.
    fn check(&self, line: usize) -> Result<(), EventTooLong> {
        let held = |field: &Option<String>| field.as_ref().map_or(0, String::len);
        if line > MAX_EVENT_BYTES || held(&self.event) + held(&self.data) > MAX_EVENT_BYTES {
            return Err(EventTooLong);
        }
        Ok(())
    }

    /// Takes one line, without its line end.
    fn line(&mut self, line: &[u8], events: &mut Vec<SseEvent>) {
        let line = String::from_utf8_lossy(line);
        let line = line.trim_end_matches('\r');
        if line.is_empty() {
            if let Some(data) = self.data.take() {
                events.push(SseEvent {
                    event: self.event.take(),
                    data,
                });
            }
            self.event = None;
            return;
        }
        if line.starts_with(':') {
            return;
        }
        let (field, value) = line.split_once(':').unwrap_or((line, ""));
        let value = value.strip_prefix(' ').unwrap_or(value);
        match field {
            "event" => self.event = Some(value.to_string()),
            "data" => match &mut self.data {
                Some(data) => {
                    data.push('\n');
                    data.push_str(value);
                }
                None => self.data = Some(value.to_string()),
            },
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sse_events_split_across_chunks_and_crlf() {
        let mut parser = SseParser::default();
        let mut events = Vec::new();
        assert_eq!(
            parser.feed(b"event: a\r\ndata: {\"x\":", &mut events),
            Ok(())
        );
        assert!(events.is_empty());
        let rest = b"1}\r\n\r\n: comment\ndata: two\ndata: lines\n\ndata: [DONE]";
        assert_eq!(parser.feed(rest, &mut events), Ok(()));
        events.extend(parser.finish());
        assert_eq!(
            events,
            vec![
                SseEvent {
                    event: Some("a".into()),
                    data: "{\"x\":1}".into()
                },
                SseEvent {
                    event: None,
                    data: "two\nlines".into()
                },
                SseEvent {
                    event: None,
                    data: "[DONE]".into()
                },
            ]
        );
    }

    #[test]
    fn a_stream_of_tiny_pieces_keeps_at_most_max_chunks_and_all_its_text() {
        let sink = |_: &str| {};
        let mut answer = Assembler::new(&sink, None);
        let pieces = MAX_CHUNKS + 1000;
        for _ in 0..pieces {
            answer.push("a");
        }
        let done = answer.finish("openai", "m").unwrap();
        assert_eq!(done.chunks.len(), MAX_CHUNKS);
        assert_eq!(done.text.len(), pieces);
        let joined: String = done.chunks.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(joined, done.text);
    }

    #[test]
    fn the_key_is_removed_from_an_answer_even_split_across_pieces() {
        let key = Secret::new("sk-abcdef").unwrap_or_else(|| panic!("a key"));
        let passed = std::sync::Mutex::new(String::new());
        let sink = |piece: &str| {
            if let Ok(mut all) = passed.lock() {
                all.push_str(piece);
            }
        };
        let mut answer = Assembler::new(&sink, Some(key));
        for piece in [
            "Your key is sk",
            "-abc",
            "def and ",
            "s",
            "k-",
            "abcdef",
            "; sk-ab",
        ] {
            answer.push(piece);
        }
        let done = answer
            .finish("openai", "m")
            .unwrap_or_else(|e| panic!("{e}"));
        let want = "Your key is [redacted] and [redacted]; sk-ab";
        assert_eq!(done.text, want);
        let chunks: String = done.chunks.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(chunks, want);
        assert_eq!(passed.lock().map(|p| p.clone()).unwrap_or_default(), want);
    }

    /// Feeds `body` in pieces of `size` bytes: the events, whether it was
    /// refused, and the bytes the parser looked at.
    fn feed_in_pieces(body: &[u8], size: usize) -> (Vec<SseEvent>, Option<EventTooLong>, usize) {
        let mut parser = SseParser::default();
        let mut events = Vec::new();
        for piece in body.chunks(size) {
            if let Err(err) = parser.feed(piece, &mut events) {
                return (events, Some(err), parser.scanned);
            }
        }
        events.extend(parser.finish());
        (events, None, parser.scanned)
    }

    #[test]
    fn feeding_one_byte_at_a_time_looks_at_each_byte_once() {
        let mut body = String::new();
        for i in 0..2_000 {
            body.push_str(&format!(
                "data: {{\"choices\":[{{\"delta\":{{\"content\":\"word {i} \"}}}}]}}\r\n\r\n"
            ));
        }
        // One long event line too: a rescan from its start on every byte
        // would look at it a hundred thousand times over.
        body.push_str(&format!(
            "data: {}\n\ndata: [DONE]\n\n",
            "x".repeat(100_000)
        ));
        let (whole, refused, _) = feed_in_pieces(body.as_bytes(), body.len());
        assert_eq!(refused, None);
        assert_eq!(whole.len(), 2_002);
        assert_eq!(
            whole[7].data,
            r#"{"choices":[{"delta":{"content":"word 7 "}}]}"#
        );
        let (bytewise, refused, scanned) = feed_in_pieces(body.as_bytes(), 1);
        assert_eq!(refused, None);
        assert_eq!(bytewise, whole);
        assert_eq!(scanned, body.len(), "each byte looked at once");
    }

    #[test]
    fn a_line_or_event_past_the_limit_is_refused_in_any_pieces() {
        let at_limit = format!("data: {}\n\n", "y".repeat(MAX_EVENT_BYTES - 6));
        let over = format!("data: {}\n\n", "y".repeat(MAX_EVENT_BYTES - 5));
        let no_end = "z".repeat(3 * MAX_EVENT_BYTES);
        let many_lines = "data: 0123456789abcdef\n".repeat(MAX_EVENT_BYTES / 16);
        let before = "data: first\n\n";
        for size in [1, 7, 4096, usize::MAX] {
            let (events, refused, _) = feed_in_pieces(at_limit.as_bytes(), size);
            assert_eq!((events.len(), refused), (1, None), "pieces of {size}");
            for bad in [&over, &no_end, &many_lines] {
                let body = format!("{before}{bad}data: never\n\n");
                let (events, refused, scanned) = feed_in_pieces(body.as_bytes(), size);
                assert_eq!(refused, Some(EventTooLong), "pieces of {size}");
                assert_eq!(events.len(), 1, "the event before is kept");
                if size < body.len() {
                    // Reading stops near the limit (the data of an event
                    // counts without its `data: ` prefixes).
                    assert!(scanned <= 2 * MAX_EVENT_BYTES + size, "{scanned}");
                }
            }
        }
        assert!(EventTooLong
            .to_string()
            .contains("limit of 1 MiB (1048576 bytes)"));
    }

    #[test]
    fn shorten_cuts_on_characters() {
        assert_eq!(shorten("héllo", 2), "hé…");
        assert_eq!(shorten("hi", 5), "hi");
    }

    mod properties {
        use super::super::*;
        use proptest::prelude::*;

        /// A key with no border (no proper prefix that is also a suffix),
        /// so that its occurrences in a text never overlap.
        const KEY: &str = "sk-abc123";

        /// The events of a body cut into `pieces`, and whether it was
        /// refused as too long.
        fn events(pieces: &[&[u8]]) -> (Vec<SseEvent>, bool) {
            let mut parser = SseParser::default();
            let mut events = Vec::new();
            for piece in pieces {
                if parser.feed(piece, &mut events).is_err() {
                    return (events, true);
                }
            }
            events.extend(parser.finish());
            (events, false)
        }

        fn key() -> Option<Secret> {
            Secret::new(KEY)
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]

            /// Events written as a stream read back as written, however the
            /// stream is cut into network pieces.
            #[test]
            fn a_stream_reads_back_as_its_events_in_any_pieces(
                written in prop::collection::vec(
                    (prop::option::of("[a-z_]{1,8}"), prop::collection::vec("[ -~é]{0,12}", 1..3)),
                    0..6,
                ),
                cut in 1usize..9,
                crlf in any::<bool>(),
            ) {
                let end = if crlf { "\r\n" } else { "\n" };
                let mut body = String::new();
                let mut want = Vec::new();
                for (event, data) in &written {
                    if let Some(name) = event {
                        body.push_str(&format!("event: {name}{end}"));
                    }
                    for line in data {
                        body.push_str(&format!("data: {line}{end}"));
                    }
                    body.push_str(end);
                    want.push(SseEvent { event: event.clone(), data: data.join("\n") });
                }
                let pieces: Vec<&[u8]> = body.as_bytes().chunks(cut).collect();
                prop_assert_eq!(events(&pieces), (want, false));
            }

            /// Any bytes: no panic, and the same events in any pieces.
            #[test]
            fn any_bytes_give_the_same_events_in_any_pieces(
                bytes in prop::collection::vec(prop::sample::select(b"data: {}\"[]\r\n:event\xff".to_vec()), 0..120),
                cut in 1usize..9,
            ) {
                let pieces: Vec<&[u8]> = bytes.chunks(cut).collect();
                prop_assert_eq!(events(&pieces), events(&[&bytes]));
            }

            /// However an answer is cut into pieces, what is passed on and
            /// kept is the whole answer with every key replaced.
            #[test]
            fn the_key_is_redacted_in_any_pieces(
                pieces in prop::collection::vec("(sk-abc123|sk-ab|c123|sk|[sk\\-abc123 é])*", 0..12),
            ) {
                let shown = std::sync::Mutex::new(String::new());
                let sink = |piece: &str| {
                    if let Ok(mut all) = shown.lock() {
                        all.push_str(piece);
                    }
                };
                let mut answer = Assembler::new(&sink, key());
                for piece in &pieces {
                    answer.push(piece);
                }
                let whole: String = pieces.concat();
                let want = whole.replace(KEY, "[redacted]");
                match answer.finish("p", "m") {
                    Ok(done) => {
                        prop_assert_eq!(&done.text, &want);
                        let joined: String = done.chunks.iter().map(|c| c.text.as_str()).collect();
                        prop_assert_eq!(&joined, &want);
                    }
                    Err(_) => prop_assert!(want.trim().is_empty()),
                }
                prop_assert_eq!(shown.lock().map(|s| s.clone()).unwrap_or_default(), want);
            }
        }
    }
}
