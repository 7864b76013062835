//! The response cache: answers stored on disk under a hash of everything
//! that decides them (provider, model, settings, prompt, image
//! hashes), so that re-running an unchanged agent costs nothing. The API key
//! is never part of the key nor of an entry.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::json;

use super::provider::{ChatRequest, Completion};
use super::{sha256_hex, AgentError, ProviderKind};

/// Bumped when the layout of the key or of an entry changes.
const FORMAT: u32 = 1;

/// One stored answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CachedAnswer {
    /// The request's key (see [`request_key`]).
    pub key: String,
    /// The provider that answered.
    pub provider: ProviderKind,
    /// The model that answered.
    pub model: String,
    /// The answer as it was received.
    pub completion: Completion,
}

/// The content address of a request: a SHA-256 over the provider, model,
/// temperature, token limit, schema, prompts and image hashes. The endpoint
/// is left out, so that a recording replays whichever server it came from;
/// the provider is the one it is keyed as ([`ProviderKind::keyed_as`]).
pub fn request_key(provider: ProviderKind, request: &ChatRequest) -> String {
    let images: Vec<&str> = request.images.iter().map(|i| i.sha256.as_str()).collect();
    let canonical = json!({
        "format": FORMAT,
        "provider": provider.keyed_as().name(),
        "model": request.model,
        "temperature": request.temperature,
        "max_tokens": request.max_tokens,
        "json_schema": request.json_schema,
        "system": request.system,
        "user": request.user,
        "images": images,
    });
    sha256_hex(canonical.to_string().as_bytes())
}

/// The key of sample `sample` of the request keyed `key`: sample 0 is the
/// request's own key (so caches, recordings and tests made before samples
/// existed keep hitting); sample k > 0 a SHA-256 of the key and k, so each
/// sample is stored, reused and asked for on its own.
pub fn sample_key(key: String, sample: u32) -> String {
    if sample == 0 {
        key
    } else {
        sha256_hex(format!("{key}/sample/{sample}").as_bytes())
    }
}

/// Answers stored one file each under a folder.
#[derive(Debug, Clone)]
pub struct ResponseCache {
    dir: PathBuf,
}

impl ResponseCache {
    /// A cache in `dir` (created on first write).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// The default folder: `$XDG_CACHE_HOME/mapvlm/responses`, else
    /// `$HOME/.cache/mapvlm/responses`.
    pub fn default_dir() -> Option<PathBuf> {
        std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
            .map(|base| base.join("mapvlm").join("responses"))
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path_of(&self, key: &str) -> PathBuf {
        let shard = key.get(..2).unwrap_or("00");
        self.dir.join(shard).join(format!("{key}.json"))
    }

    /// The stored answer for `key`; a missing or unreadable entry is a miss.
    pub fn get(&self, key: &str) -> Option<CachedAnswer> {
        let text = std::fs::read_to_string(self.path_of(key)).ok()?;
        match serde_json::from_str::<CachedAnswer>(&text) {
            Ok(answer) if answer.key == key => Some(answer),
            _ => {
                tracing::warn!(key, "ignoring an unreadable cache entry");
                None
            }
        }
    }

    /// Stores `answer` atomically.
    pub fn put(&self, answer: &CachedAnswer) -> Result<(), AgentError> {
        let path = self.path_of(&answer.key);
        let text = serde_json::to_string(answer).map_err(|err| AgentError::Io {
            path: path.clone(),
            message: err.to_string(),
        })?;
        write_atomic(&path, text.as_bytes())
    }
}

/// A builder of temporary files created with mode 0666 less the umask (as
/// any file a program creates), not tempfile's private 0600: a cache or an
/// output folder a group shares (umask 002) stays readable by the group.
pub fn shared_temp_file() -> tempfile::Builder<'static, 'static> {
    use std::os::unix::fs::PermissionsExt;
    let mut builder = tempfile::Builder::new();
    builder.permissions(std::fs::Permissions::from_mode(0o666));
    builder
}

/// Writes `bytes` to a uniquely named temporary file beside `path`, then
/// renames it over `path`, so that a reader never sees half a file and
/// concurrent writers never share a temporary file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), AgentError> {
    let io = |err: std::io::Error| AgentError::Io {
        path: path.to_path_buf(),
        message: err.to_string(),
    };
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(io)?;
    let mut temp = shared_temp_file().tempfile_in(parent).map_err(io)?;
    temp.write_all(bytes).map_err(io)?;
    temp.persist(path).map_err(|err| io(err.error))?;
    Ok(())
}

/// Checks, before any work is spent, that a file could be written at `path`
/// by [`write_atomic`]: its folder exists or can be made, a file can be
/// created there, and `path` is not a folder. Nothing is left behind but
/// the folder.
pub fn check_writable(path: &Path) -> Result<(), AgentError> {
    let io = |message: String| AgentError::Io {
        path: path.to_path_buf(),
        message,
    };
    if path.is_dir() {
        return Err(io("is a folder; give a file name".into()));
    }
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .map_err(|err| io(format!("cannot create its folder ({err})")))?;
    tempfile::NamedTempFile::new_in(parent)
        .map(drop)
        .map_err(|err| io(format!("cannot write in its folder ({err})")))
}
