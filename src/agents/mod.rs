//! The planning half: providers that speak to language models, the agents
//! (SKM, GKM, Planner and the single-agent baselines) and the pipelines that
//! run them, with prompts, a knowledge graph, a response cache and replay.

pub mod anthropic;
pub mod batch;
pub mod cache;
pub mod config;
pub mod cost;
pub mod graph;
pub mod images;
pub mod openai;
pub mod pipeline;
pub mod prompt_sets;
pub mod prompts;
pub mod provider;
pub mod replay;
pub mod sink;

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// An API key: kept out of `Debug`, `Display` and serialisation so that it
/// cannot leak into a log line, an error message, a record or a cache file.
#[derive(Clone, PartialEq, Eq)]
pub struct Secret(String);

/// The shortest key that text is searched for, to remove it. A shorter one
/// is a placeholder for a server that checks none (`EMPTY`, `x`, `none`
/// for a local OpenAI-compatible server), not a secret: removing every `x`
/// from a model's plan would change the plan and its score.
pub const MIN_SECRET_CHARS: usize = 8;

impl Secret {
    /// Wraps a key; an empty string is no key.
    pub fn new(key: impl Into<String>) -> Option<Self> {
        let key = key.into();
        let key = key.trim();
        (!key.is_empty()).then(|| Self(key.to_string()))
    }

    /// The key itself, for the one place that sends it: a request header.
    pub fn expose(&self) -> &str {
        &self.0
    }

    /// Whether the key is shorter than [`MIN_SECRET_CHARS`]: a placeholder,
    /// sent as given but not searched for in text.
    pub fn is_placeholder(&self) -> bool {
        self.0.chars().count() < MIN_SECRET_CHARS
    }

    /// Removes every occurrence of the key from `text` (a placeholder key
    /// leaves it as it is).
    pub fn redact(&self, text: &str) -> String {
        if self.is_placeholder() {
            return text.to_string();
        }
        text.replace(&self.0, "[redacted]")
    }
}

impl fmt::Debug for Secret {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Secret([redacted])")
    }
}

/// Where an agent's answers come from: a provider's wire protocol, or the
/// demo's recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProviderKind {
    /// The OpenAI-compatible Chat Completions API (OpenAI, vLLM, llama.cpp,
    /// Ollama, LM Studio, OpenRouter…).
    Openai,
    /// Anthropic's Messages API.
    Anthropic,
    /// The demo's recorded answers: no key, no network. A request it has no
    /// answer for fails, naming what to set instead.
    Replay,
}

impl ProviderKind {
    /// The name used in flags, config files and records.
    pub fn name(self) -> &'static str {
        match self {
            Self::Openai => "openai",
            Self::Anthropic => "anthropic",
            Self::Replay => "replay",
        }
    }

    /// The environment variable holding this provider's API key: the one
    /// place its name is written, for the configuration and for messages
    /// that tell the user what to set. The recording needs none.
    pub fn key_variable(self) -> Option<&'static str> {
        match self {
            Self::Openai => Some("OPENAI_API_KEY"),
            Self::Anthropic => Some("ANTHROPIC_API_KEY"),
            Self::Replay => None,
        }
    }

    /// The environment variable holding this provider's base URL (none for
    /// the recording).
    pub fn base_url_variable(self) -> Option<&'static str> {
        match self {
            Self::Openai => Some("OPENAI_BASE_URL"),
            Self::Anthropic => Some("ANTHROPIC_BASE_URL"),
            Self::Replay => None,
        }
    }

    /// The endpoint used when none is configured. The recording's is a host
    /// that never resolves: nothing is ever sent there.
    pub fn default_base_url(self) -> &'static str {
        match self {
            Self::Openai => openai::DEFAULT_BASE_URL,
            Self::Anthropic => anthropic::DEFAULT_BASE_URL,
            Self::Replay => "http://replay.invalid/v1",
        }
    }

    /// The path of a request under the base URL (none for the recording,
    /// which sends nothing).
    pub fn request_path(self) -> Option<&'static str> {
        match self {
            Self::Openai => Some(openai::REQUEST_PATH),
            Self::Anthropic => Some(anthropic::REQUEST_PATH),
            Self::Replay => None,
        }
    }

    /// The model used when none is configured.
    pub fn default_model(self) -> &'static str {
        match self {
            Self::Openai => "gpt-4o",
            Self::Anthropic => "claude-sonnet-4-5",
            Self::Replay => DEMO_MODEL,
        }
    }

    /// The provider whose request keys this one's requests get: the demo's
    /// recording was made over the OpenAI-compatible API, so its answers
    /// are keyed as that API's requests (see [`cache::request_key`]).
    pub fn keyed_as(self) -> ProviderKind {
        match self {
            Self::Replay => Self::Openai,
            other => other,
        }
    }
}

impl fmt::Display for ProviderKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The model name the demo's answers are recorded under.
pub const DEMO_MODEL: &str = "demo-recording";

impl FromStr for ProviderKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "openai" => Ok(Self::Openai),
            "anthropic" => Ok(Self::Anthropic),
            "replay" => Ok(Self::Replay),
            other => Err(format!(
                "unknown provider `{other}`: use `openai`, `anthropic` or `replay` (the demo's recording)"
            )),
        }
    }
}

/// One of the agents of the method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AgentRole {
    /// The semantic-knowledge miner: objects and relations as triples.
    Skm,
    /// The grounded-knowledge miner: a grounded description of the scene.
    Gkm,
    /// The planner: steps from the task and the miners' outputs.
    Planner,
    /// The single agent of the baselines: steps straight from image or table.
    Single,
}

impl AgentRole {
    /// Every role, in the order a view lists them.
    pub const ALL: [AgentRole; 4] = [Self::Skm, Self::Gkm, Self::Planner, Self::Single];

    /// The name used in flags, config sections, prompts and records.
    pub fn name(self) -> &'static str {
        match self {
            Self::Skm => "skm",
            Self::Gkm => "gkm",
            Self::Planner => "planner",
            Self::Single => "single",
        }
    }

    /// The name a view shows for the agent.
    pub fn label(self) -> &'static str {
        match self {
            Self::Skm => "SKM",
            Self::Gkm => "GKM",
            Self::Planner => "Planner",
            Self::Single => "Single",
        }
    }
}

impl fmt::Display for AgentRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AgentRole {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|role| role.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| format!("unknown agent `{s}`: use skm, gkm, planner or single"))
    }
}

/// The four ways of making a plan compared in the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Approach {
    /// SKM and GKM on the image, then the Planner.
    MultiImage,
    /// One agent from the image.
    SingleImage,
    /// SKM and GKM on the G-PlanET table, then the Planner.
    MultiTable,
    /// One agent from the G-PlanET table.
    SingleTable,
}

impl Approach {
    /// Every approach, in the column order of the paper's Table 3.
    pub const ALL: [Approach; 4] = [
        Self::SingleTable,
        Self::MultiTable,
        Self::SingleImage,
        Self::MultiImage,
    ];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::MultiImage => "multi-image",
            Self::SingleImage => "single-image",
            Self::MultiTable => "multi-table",
            Self::SingleTable => "single-table",
        }
    }

    /// The dataset field holding the published plan of this approach.
    pub fn dataset_field(self) -> &'static str {
        match self {
            Self::MultiImage => "multi_agent_image",
            Self::SingleImage => "single_agent_image",
            Self::MultiTable => "multi_agent_table",
            Self::SingleTable => "single_agent_table",
        }
    }

    /// Whether the approach runs the two miners and the Planner.
    pub fn is_multi_agent(self) -> bool {
        matches!(self, Self::MultiImage | Self::MultiTable)
    }

    /// The agents the approach runs, in pipeline order.
    pub fn roles(self) -> &'static [AgentRole] {
        if self.is_multi_agent() {
            &[AgentRole::Skm, AgentRole::Gkm, AgentRole::Planner]
        } else {
            &[AgentRole::Single]
        }
    }

    /// The agent that writes the plan.
    pub fn planning_role(self) -> AgentRole {
        if self.is_multi_agent() {
            AgentRole::Planner
        } else {
            AgentRole::Single
        }
    }

    /// Whether the approach reads the scene image (else the table).
    pub fn uses_image(self) -> bool {
        matches!(self, Self::MultiImage | Self::SingleImage)
    }
}

impl fmt::Display for Approach {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Approach {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let wanted = s.trim().to_ascii_lowercase().replace('_', "-");
        Self::ALL
            .into_iter()
            .find(|a| a.name() == wanted || a.dataset_field().replace('_', "-") == wanted)
            .ok_or_else(|| {
                format!(
                    "unknown approach `{s}`: use multi-image, single-image, multi-table or single-table"
                )
            })
    }
}

/// Token counts a provider reported for one answer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Usage {
    /// Tokens read (prompt and images).
    pub input_tokens: u64,
    /// Tokens written.
    pub output_tokens: u64,
}

/// The token counts of several answers added up: a plan's over its agents,
/// a run's over every call.
impl<'a> std::iter::Sum<&'a Usage> for Usage {
    fn sum<I: Iterator<Item = &'a Usage>>(iter: I) -> Usage {
        iter.fold(Usage::default(), |sum, u| Usage {
            input_tokens: sum.input_tokens + u.input_tokens,
            output_tokens: sum.output_tokens + u.output_tokens,
        })
    }
}

/// Everything that can end an agent's run.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// The provider refused the API key (401 or 403).
    #[error("{provider} refused the API key (HTTP {status}): set {} (or api_key in the config file) to a valid key", key_variable(provider))]
    KeyRefused {
        /// The provider's name.
        provider: &'static str,
        /// The HTTP status.
        status: u16,
    },
    /// A non-retryable or exhausted HTTP error.
    #[error("{provider} answered HTTP {status}: {message}")]
    Http {
        /// The provider's name.
        provider: &'static str,
        /// The HTTP status.
        status: u16,
        /// What the server said, shortened and with the key removed.
        message: String,
    },
    /// No answer in time.
    #[error("{provider} timed out after {seconds:.1} s: raise --timeout or try again")]
    Timeout {
        /// The provider's name.
        provider: &'static str,
        /// The limit that ran out.
        seconds: f64,
    },
    /// The connection failed.
    #[error("{provider} could not be reached at {url}: {message}")]
    Connect {
        /// The provider's name.
        provider: &'static str,
        /// The endpoint.
        url: String,
        /// Why.
        message: String,
    },
    /// The answer could not be read.
    #[error("{provider} sent an answer that could not be read: {message}")]
    InvalidResponse {
        /// The provider's name.
        provider: &'static str,
        /// What was wrong.
        message: String,
    },
    /// The stream ended before the answer was complete.
    #[error(
        "{provider} stream ended before the answer was complete ({received} characters received)"
    )]
    TruncatedStream {
        /// The provider's name.
        provider: &'static str,
        /// How much text had arrived.
        received: usize,
    },
    /// The provider cut the answer at the token limit: the last step is
    /// likely cut too, so the answer is neither kept nor scored.
    #[error("{provider} cut the answer of {model} at the token limit (stop reason `{reason}`, {received} characters received): the plan is incomplete; raise --max-tokens (or max_tokens in the config file) and run again")]
    CutAnswer {
        /// The provider's name.
        provider: &'static str,
        /// The model asked.
        model: String,
        /// The stop reason as the provider gave it.
        reason: &'static str,
        /// How much text had arrived.
        received: usize,
    },
    /// The model answered nothing.
    #[error("{provider} returned an empty answer (model {model})")]
    EmptyAnswer {
        /// The provider's name.
        provider: &'static str,
        /// The model asked.
        model: String,
    },
    /// The run was cancelled.
    #[error("cancelled")]
    Cancelled,
    /// An image could not be used.
    #[error("image {path}: {reason}")]
    Image {
        /// The file.
        path: PathBuf,
        /// What was wrong and what to do.
        reason: String,
    },
    /// A table could not be read.
    #[error("table {path}: {reason}")]
    Table {
        /// The file.
        path: PathBuf,
        /// What was wrong, with the line.
        reason: String,
    },
    /// A prompt template is wrong.
    #[error("prompt {name}: {reason}")]
    Prompt {
        /// The template's name.
        name: String,
        /// What was wrong.
        reason: String,
    },
    /// A recorded session has no answer for this request.
    #[error("{}", not_recorded(model, key, *sample))]
    NotRecorded {
        /// The model asked.
        model: String,
        /// The request's cache key.
        key: String,
        /// Which sample of the request was asked for.
        sample: u32,
    },
    /// A miner failed, so the agent that needs it did not run.
    #[error("not run: {0} failed")]
    Upstream(AgentRole),
    /// The approach lacks an input it needs.
    #[error("{approach} needs {what}")]
    MissingInput {
        /// The approach.
        approach: Approach,
        /// What to give it.
        what: &'static str,
    },
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A file could not be written whole (see [`crate::fsutil`]).
    #[error(transparent)]
    Write(#[from] crate::fsutil::FsError),
}

/// The message of [`AgentError::NotRecorded`]: for a later sample, that the
/// recording was made with fewer samples and how to get them.
fn not_recorded(model: &str, key: &str, sample: u32) -> String {
    if sample == 0 {
        format!(
            "the recording has no answer for this request to {model} (key {key}): record it again"
        )
    } else {
        format!(
            "the recording has no sample {} of this request to {model} (key {key}): it was recorded with fewer samples; record it again with --samples {} or more, or ask for fewer",
            sample + 1,
            sample + 1
        )
    }
}

/// The environment variable holding the API key of the provider named
/// `provider`, for messages that tell the user what to set.
pub fn key_variable(provider: &str) -> &'static str {
    provider
        .parse::<ProviderKind>()
        .unwrap_or(ProviderKind::Openai)
        .key_variable()
        .unwrap_or("the provider's API key variable")
}

/// The SHA-256 of `bytes`, as lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod secret_tests {
    use super::provider::Assembler;
    use super::Secret;

    #[test]
    fn a_placeholder_key_leaves_text_whole_and_a_real_one_is_removed() {
        let text = "Walk to the box, then pick up the next box.";
        for placeholder in ["x", "EMPTY", "none", "sk-1234"] {
            let key = Secret::new(placeholder).unwrap();
            assert!(key.is_placeholder(), "{placeholder}");
            assert_eq!(key.redact(text), text);
            let seen = std::sync::Mutex::new(String::new());
            let sink = |piece: &str| seen.lock().unwrap().push_str(piece);
            let mut answer = Assembler::new(&sink, Some(key));
            for piece in ["Walk to the bo", "x, then pick up the ne", "xt box."] {
                answer.push(piece);
            }
            let done = answer.finish("openai", "m").unwrap();
            assert_eq!(done.text, text);
            assert_eq!(*seen.lock().unwrap(), text);
        }
        let key = Secret::new("sk-abcdefgh").unwrap();
        assert!(!key.is_placeholder());
        assert_eq!(key.redact("key sk-abcdefgh here"), "key [redacted] here");
    }
}

/// Properties both providers' stream decoders share (here, where both
/// providers are in reach, rather than in `provider`, which they build on).
#[cfg(test)]
mod decoder_properties {
    use proptest::prelude::*;

    use super::provider::{Assembler, EventDecoder, SseEvent};
    use super::{anthropic, openai, Secret};

    /// A key with no border, as in `provider`'s properties.
    const KEY: &str = "sk-abc123";

    fn key() -> Option<Secret> {
        Secret::new(KEY)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Either provider's decoder on any event: no panic, and a key
        /// inside the event's text never reaches the answer.
        #[test]
        fn decoders_never_panic_nor_pass_the_key(
            kind in prop::sample::select(vec!["content_block_delta", "message_start", "message_delta", "error", "message_stop", "x"]),
            text in "(sk-abc123|[a-z \"\\\\{}])*",
            raw in "[ -~]{0,30}",
        ) {
            let text_json = serde_json::to_string(&text).unwrap_or_default();
            let datas = [
                format!(r#"{{"choices":[{{"delta":{{"content":{text_json}}},"finish_reason":null}}]}}"#),
                format!(r#"{{"type":"{kind}","delta":{{"text":{text_json}}},"usage":{{"output_tokens":3}}}}"#),
                format!(r#"{{"error":{{"message":{text_json}}}}}"#),
                raw,
            ];
            for data in datas {
                let event = SseEvent { event: None, data };
                let decoders: [EventDecoder; 2] = [openai::apply_event, anthropic::apply_event];
                for decode in decoders {
                    let sink = |piece: &str| assert!(!piece.contains(KEY));
                    let mut answer = Assembler::new(&sink, key());
                    let _ = decode(&event, &mut answer);
                    if let Ok(done) = answer.finish("p", "m") {
                        prop_assert!(!done.text.contains(KEY));
                    }
                }
            }
        }
    }
}
