//! Recorded sessions and the replay provider: every answer of a run saved in
//! one file, then served again with no network, streamed at the pace it was
//! received (or at once), for demos and tests.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use tokio_util::sync::CancellationToken;

use super::cache::{request_key, CachedAnswer};
use super::provider::{cancellable, BoxFuture, ChatRequest, Completion, Provider, TokenSink};
use super::sink::OutputSink;
use super::{AgentError, ProviderKind};

/// Bumped when the layout of a recording changes.
const FORMAT: u32 = 1;

/// The answers of one or more runs, by request key.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Recording {
    /// Layout version.
    pub format: u32,
    /// A free note, e.g. where the answers came from.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// The answers.
    pub answers: BTreeMap<String, CachedAnswer>,
}

impl Recording {
    /// An empty recording.
    pub fn new(note: impl Into<String>) -> Self {
        Self {
            format: FORMAT,
            note: note.into(),
            answers: BTreeMap::new(),
        }
    }

    /// Reads a recording file.
    pub fn load(path: &Path) -> Result<Self, AgentError> {
        let io = |message: String| AgentError::Io {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|err| io(err.to_string()))?;
        let recording: Self = serde_json::from_str(&text)
            .map_err(|err| io(format!("not a mapvlm recording ({err})")))?;
        if recording.format != FORMAT {
            return Err(io(format!(
                "recording format {} is not {FORMAT}: record it again",
                recording.format
            )));
        }
        Ok(recording)
    }

    /// Writes the recording atomically, pretty-printed.
    pub fn save(&self, path: &Path) -> Result<(), AgentError> {
        self.save_through(path, &OutputSink::new(CancellationToken::new()))
    }

    /// Writes the recording atomically, pretty-printed, through a run's
    /// output sink (a failure cancels the run).
    pub fn save_through(&self, path: &Path, sink: &OutputSink) -> Result<(), AgentError> {
        let text = serde_json::to_string_pretty(self).map_err(|err| AgentError::Io {
            path: path.to_path_buf(),
            message: err.to_string(),
        })?;
        sink.write(path, text.as_bytes())
    }
}

/// How fast a replay streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pace {
    /// Each piece at the time it was received.
    AsRecorded,
    /// Everything at once.
    Instant,
    /// Each piece this long after the one before.
    Every(Duration),
}

/// A provider that answers from a recording.
#[derive(Debug, Clone)]
pub struct ReplayProvider {
    recording: Arc<Recording>,
    provider: ProviderKind,
    pace: Pace,
}

impl ReplayProvider {
    /// Serves `recording` in place of `provider` (part of the request key).
    pub fn new(recording: Arc<Recording>, provider: ProviderKind, pace: Pace) -> Self {
        Self {
            recording,
            provider,
            pace,
        }
    }

    /// Serves the recorded answer keyed `key`: sample `sample` of `request`
    /// (see [`sample_key`](super::cache::sample_key)). A recording holds
    /// the samples it was made with (`--record --samples N`), and a sample
    /// it lacks fails: never a copy of another sample, which would show a
    /// spread of zero.
    pub async fn replay(
        &self,
        key: &str,
        sample: u32,
        request: &ChatRequest,
        on_token: TokenSink<'_>,
        cancel: &CancellationToken,
    ) -> Result<Completion, AgentError> {
        let answer = self
            .recording
            .answers
            .get(key)
            .ok_or_else(|| AgentError::NotRecorded {
                model: request.model.clone(),
                key: key.to_string(),
                sample,
            })?;
        let start = Instant::now();
        for chunk in &answer.completion.chunks {
            match self.pace {
                Pace::AsRecorded => {
                    let due = start + Duration::from_millis(chunk.at_ms);
                    cancellable(cancel, tokio::time::sleep_until(due.into())).await?;
                }
                Pace::Every(delay) => cancellable(cancel, tokio::time::sleep(delay)).await?,
                Pace::Instant => {}
            }
            on_token(&chunk.text);
        }
        Ok(answer.completion.clone())
    }
}

impl Provider for ReplayProvider {
    fn complete<'a>(
        &'a self,
        request: &'a ChatRequest,
        on_token: TokenSink<'a>,
        cancel: &'a CancellationToken,
    ) -> BoxFuture<'a, Result<Completion, AgentError>> {
        Box::pin(async move {
            let key = request_key(self.provider, request);
            self.replay(&key, 0, request, on_token, cancel).await
        })
    }
}
