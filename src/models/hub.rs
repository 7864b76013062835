//! The Hugging Face Hub as a source of models, through `hf-hub` (kept by
//! Hugging Face): files of a pinned revision are downloaded into the shared
//! Hugging Face cache layout, so other tools reuse them, then checked by
//! SHA-256 before the pack links to them.
//!
//! Honours `HF_HUB_CACHE`/`HF_HOME` (the cache), `HF_ENDPOINT` (a mirror),
//! `HF_TOKEN` (else the token file `huggingface-cli login` leaves) and
//! `HF_HUB_OFFLINE`. hf-hub writes each file to `blobs/ETAG.sync.part` with
//! a trailing count of committed bytes, so a download interrupted between
//! chunks resumes where it stopped; only a complete file is renamed to its
//! blob. A file that fails its check is removed from the cache again, blob
//! and snapshot link both.

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

use hf_hub::api::tokio::{ApiBuilder, ApiError};
use hf_hub::{Cache, Repo, RepoType};
use indicatif::ProgressBar;

use super::fetch::Progress;
use super::hf_cache::{check_lfs_files, hub_cache_dir, repo_dir};
use super::verify::{check_key_files, Problem};
use super::{HubRepo, ModelSpec, ModelsError};

/// How to reach the Hub and where its cache is, from the environment.
#[derive(Clone)]
pub struct HubSettings {
    /// The Hub cache folder (`HF_HUB_CACHE`, else `HF_HOME/hub`, ...).
    pub cache: PathBuf,
    /// The Hub or mirror to download from (`HF_ENDPOINT`); the Hub itself when unset.
    pub endpoint: Option<String>,
    /// The access token for gated or private repositories; never printed.
    token: Option<String>,
    /// `HF_HUB_OFFLINE` is set: use the cache only.
    pub offline: bool,
    /// Bytes per ranged request; a download resumes at a chunk boundary.
    pub chunk_size: usize,
    /// Ranged requests in flight at once.
    pub parallel: usize,
}

impl HubSettings {
    /// The Hub itself, online, without a token, with its cache at `cache`.
    pub fn new(cache: PathBuf) -> Self {
        Self {
            cache,
            endpoint: None,
            token: None,
            offline: false,
            chunk_size: 10_000_000,
            parallel: 4,
        }
    }

    /// The settings `huggingface_hub` would use in this environment.
    pub fn from_env() -> Self {
        let var = |name: &str| std::env::var(name).ok().filter(|v| !v.trim().is_empty());
        let cache = hub_cache_dir();
        let token = var("HF_TOKEN").or_else(|| {
            let file = cache.parent().map(|home| home.join("token"))?;
            let text = fs::read_to_string(file).ok()?;
            Some(text.trim().to_string()).filter(|t| !t.is_empty())
        });
        let offline = var("HF_HUB_OFFLINE").is_some_and(|v| {
            matches!(
                v.trim().to_ascii_lowercase().as_str(),
                "1" | "true" | "yes" | "on"
            )
        });
        Self {
            endpoint: var("HF_ENDPOINT").map(|e| e.trim_end_matches('/').to_string()),
            token,
            offline,
            ..Self::new(cache)
        }
    }

    /// The same settings with `token` (for tests and callers that hold one).
    pub fn with_token(mut self, token: Option<String>) -> Self {
        self.token = token;
        self
    }
}

impl fmt::Debug for HubSettings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("HubSettings")
            .field("cache", &self.cache)
            .field("endpoint", &self.endpoint)
            .field("token", &self.token.as_ref().map(|_| "<set>"))
            .field("offline", &self.offline)
            .field("chunk_size", &self.chunk_size)
            .field("parallel", &self.parallel)
            .finish()
    }
}

/// Downloads every file of `hub` at its pinned revision into the cache of
/// `settings`, checks them (the pack's SHA-256 for key files, the Hub's own
/// SHA-256, its LFS ETag, for the others stored as LFS blobs) and returns
/// the snapshot folder.
pub(crate) fn download_snapshot(
    settings: &HubSettings,
    spec: &ModelSpec,
    hub: &HubRepo,
    progress: &Progress,
) -> Result<PathBuf, ModelsError> {
    if settings.offline {
        return Err(ModelsError::HubOffline {
            model: spec.folder.clone(),
        });
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(ModelsError::io(
            "start the download runtime for",
            &settings.cache,
        ))?;
    // A thread of its own, so that a caller already inside a runtime is fine.
    let snapshot = std::thread::scope(|s| {
        s.spawn(|| runtime.block_on(download_files(settings, spec, hub, progress)))
            .join()
            .unwrap_or_else(|_| {
                Err(ModelsError::HubFailed {
                    repo: hub.repo.clone(),
                    detail: "the download thread crashed".into(),
                })
            })
    })?;
    runtime.shutdown_background();
    check_snapshot(&snapshot, spec, hub, progress)?;
    Ok(snapshot)
}

async fn download_files(
    settings: &HubSettings,
    spec: &ModelSpec,
    hub: &HubRepo,
    progress: &Progress,
) -> Result<PathBuf, ModelsError> {
    let mut builder = ApiBuilder::from_cache(Cache::new(settings.cache.clone()))
        .with_progress(false)
        .with_token(settings.token.clone())
        .with_chunk_size(Some(settings.chunk_size.max(1)))
        .with_max_files(settings.parallel.max(1))
        .with_user_agent("mapvlm", env!("CARGO_PKG_VERSION"));
    if let Some(endpoint) = &settings.endpoint {
        builder = builder.with_endpoint(endpoint.clone());
    }
    let api = builder.build().map_err(|e| hub_error(hub, "", e))?;
    let repo = api.repo(Repo::with_revision(
        hub.repo.clone(),
        RepoType::Model,
        hub.revision.clone(),
    ));
    let snapshot = repo_dir(&settings.cache, &hub.repo)
        .join("snapshots")
        .join(&hub.revision);
    for file in &hub.files {
        if snapshot.join(file).is_file() {
            continue;
        }
        let bar = Bar(progress.bytes(format!("{}: {file}", spec.folder), 0));
        let got = repo
            .download_with_progress(file, bar.clone())
            .await
            .map_err(|e| hub_error(hub, file, e));
        bar.0.finish_and_clear();
        let got = got?;
        if !got.starts_with(&snapshot) {
            let served = got
                .parent()
                .and_then(Path::file_name)
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            remove_cached(&got);
            return Err(ModelsError::RevisionMismatch {
                repo: hub.repo.clone(),
                pinned: hub.revision.clone(),
                served,
            });
        }
    }
    Ok(snapshot)
}

/// Checks the downloaded snapshot; a file that fails is removed from the
/// cache (blob and link) and reported.
fn check_snapshot(
    snapshot: &Path,
    spec: &ModelSpec,
    hub: &HubRepo,
    progress: &Progress,
) -> Result<(), ModelsError> {
    let bar = progress.bytes(format!("{}: verifying", spec.folder), 0);
    let problems = check_key_files(snapshot, &spec.key_files, |n| bar.inc(n));
    let mut failure = problems?.into_iter().next().map(|problem| match problem {
        Problem::Mismatch {
            file,
            expected,
            actual,
        } => (file.clone(), expected, actual),
        Problem::Missing { file } => (file, "a file".into(), "none".into()),
    });
    if failure.is_none() {
        failure = check_lfs_files(snapshot, spec, hub, |n| bar.inc(n))?
            .map(|bad| (bad.file, bad.expected, bad.actual));
    }
    bar.finish_and_clear();
    match failure {
        None => Ok(()),
        Some((file, expected, actual)) => {
            remove_cached(&snapshot.join(&file));
            Err(ModelsError::ChecksumMismatch {
                file: format!("{file} of {} from the Hub", hub.repo),
                expected,
                actual,
            })
        }
    }
}

/// Removes a snapshot file and the blob it points to (best effort: the
/// caller is already reporting a failure).
fn remove_cached(link: &Path) {
    if let Ok(blob) = fs::canonicalize(link) {
        let _ = fs::remove_file(blob);
    }
    let _ = fs::remove_file(link);
}

/// One line for a failure of the Hub: refusals by status code, with what to do.
fn hub_error(hub: &HubRepo, file: &str, err: ApiError) -> ModelsError {
    let status = match &err {
        ApiError::RequestError(e) => e.status().map(|s| s.as_u16()),
        _ => None,
    };
    let what = if file.is_empty() {
        hub.repo.clone()
    } else {
        format!("{}/{file} at revision {}", hub.repo, hub.revision)
    };
    match status {
        Some(401 | 403) => ModelsError::HubRefused {
            what,
            status: status.unwrap_or_default(),
            hint: "the repository is gated or private: accept its terms on the Hub, then set HF_TOKEN to a token with access",
        },
        Some(404) => ModelsError::HubRefused {
            what,
            status: 404,
            hint: "no such repository, revision or file on this endpoint (check HF_ENDPOINT)",
        },
        Some(429) => ModelsError::HubRefused {
            what,
            status: 429,
            hint: "the Hub is rate-limiting this machine: wait a few minutes and rerun (a partial download resumes)",
        },
        _ => ModelsError::HubFailed {
            repo: what,
            detail: match &err {
                ApiError::RequestError(e) => format!(
                    "{err}: {}",
                    crate::agents::provider::connection_failure(e)
                ),
                _ => err.to_string(),
            },
        },
    }
}

/// hf-hub's progress hooks drawing one of our bars.
#[derive(Clone)]
struct Bar(ProgressBar);

impl hf_hub::api::tokio::Progress for Bar {
    async fn init(&mut self, size: usize, _filename: &str) {
        self.0.set_length(size as u64);
    }

    async fn update(&mut self, size: usize) {
        self.0.inc(size as u64);
    }

    async fn finish(&mut self) {}
}
