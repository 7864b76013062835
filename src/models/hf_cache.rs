//! The Hugging Face cache as other tools leave it (`huggingface_hub`,
//! sentence-transformers, hf-hub): where it is (`HF_HUB_CACHE`, `HF_HOME`),
//! how a repository is laid out in it (`models--ORG--NAME/{blobs,refs,
//! snapshots}`), and finding a snapshot whose files match the pack's pinned
//! SHA-256, whatever its revision, so a model already on the machine is used
//! in place.

use std::fs;
use std::path::{Path, PathBuf};

use super::verify::{check_key_files, sha256_file, Problem};
use super::{env_dir, HubRepo, ModelSpec, ModelsError};

/// The Hub cache folder, as `huggingface_hub` finds it: `$HF_HUB_CACHE`, else
/// `$HF_HOME/hub`, else `$XDG_CACHE_HOME/huggingface/hub`, else
/// `~/.cache/huggingface/hub`.
pub fn hub_cache_dir() -> PathBuf {
    if let Some(dir) = env_dir("HF_HUB_CACHE") {
        return dir;
    }
    let home = env_dir("HF_HOME").unwrap_or_else(|| {
        env_dir("XDG_CACHE_HOME")
            .or_else(|| env_dir("HOME").map(|home| home.join(".cache")))
            .unwrap_or_else(|| PathBuf::from(".cache"))
            .join("huggingface")
    });
    home.join("hub")
}

/// The folder of model repository `repo` (`ORG/NAME`) in the cache `cache`:
/// `models--ORG--NAME`.
pub fn repo_dir(cache: &Path, repo: &str) -> PathBuf {
    cache.join(format!("models--{}", repo.replace('/', "--")))
}

/// A snapshot of the cache whose files all match.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CachedSnapshot {
    /// The snapshot folder (`.../snapshots/REVISION`).
    pub path: PathBuf,
    /// Its revision (the commit hash the folder is named after).
    pub revision: String,
}

/// The outcome of looking for a model in the cache.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CacheLookup {
    /// A snapshot holds every file and its key files match.
    Found(CachedSnapshot),
    /// The repository has no snapshot at all.
    Absent,
    /// Snapshots are there but none is usable; one reason each, e.g.
    /// `snapshot 1234abc: model.safetensors is truncated or altered`.
    Unusable(Vec<String>),
}

/// Looks in `cache` for a snapshot of `spec`'s Hub repository holding every
/// file of `hub.files` with key files matching their pinned SHA-256. The
/// snapshots named by `refs/` come first, then the pinned revision, then the
/// others; the first that matches wins.
pub fn find_snapshot(
    cache: &Path,
    spec: &ModelSpec,
    hub: &HubRepo,
    mut on_bytes: impl FnMut(u64),
) -> Result<CacheLookup, ModelsError> {
    let repo = repo_dir(cache, &hub.repo);
    let snapshots = repo.join("snapshots");
    let mut revisions = match fs::read_dir(&snapshots) {
        Ok(entries) => entries
            .filter_map(Result::ok)
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect::<Vec<_>>(),
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => return Ok(CacheLookup::Absent),
        Err(source) => {
            return Err(ModelsError::Io {
                action: "list",
                path: snapshots,
                source,
            })
        }
    };
    if revisions.is_empty() {
        return Ok(CacheLookup::Absent);
    }
    let referenced = referenced_revisions(&repo.join("refs"));
    revisions.sort_by_key(|r| (!referenced.contains(r), *r != hub.revision, r.clone()));
    let mut reasons = Vec::new();
    for revision in revisions {
        let path = snapshots.join(&revision);
        let short = &revision[..revision.len().min(12)];
        if let Some(missing) = hub.files.iter().find(|f| !path.join(f).is_file()) {
            reasons.push(format!("snapshot {short}: {missing} is missing"));
            continue;
        }
        if let Some(problem) = check_key_files(&path, &spec.key_files, &mut on_bytes)?.first() {
            reasons.push(format!("snapshot {short}: {}", problem_line(problem)));
            continue;
        }
        match check_lfs_files(&path, spec, hub, &mut on_bytes)? {
            None => return Ok(CacheLookup::Found(CachedSnapshot { path, revision })),
            Some(bad) => reasons.push(format!(
                "snapshot {short}: {} is truncated or altered (its SHA-256 differs from its blob's name)",
                bad.file
            )),
        }
    }
    Ok(CacheLookup::Unusable(reasons))
}

/// A file of a snapshot whose content differs from the SHA-256 its blob is
/// named after.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct LfsMismatch {
    /// The file, relative to the snapshot.
    pub(crate) file: String,
    /// The SHA-256 the blob is named after.
    pub(crate) expected: String,
    /// The SHA-256 of its content.
    pub(crate) actual: String,
}

/// Checks the files of `hub` that are not key files against the SHA-256
/// their blobs are named after (the Hub's LFS ETag); the first that
/// differs, if any. Files stored without LFS (blobs named by a git hash)
/// and plain files are left to the key files and the loaders.
pub(crate) fn check_lfs_files(
    snapshot: &Path,
    spec: &ModelSpec,
    hub: &HubRepo,
    mut on_bytes: impl FnMut(u64),
) -> Result<Option<LfsMismatch>, ModelsError> {
    let others = hub
        .files
        .iter()
        .filter(|f| !spec.key_files.iter().any(|k| &k.path == *f));
    for file in others {
        let link = snapshot.join(file);
        let Some(expected) = lfs_sha256(&link) else {
            continue;
        };
        let actual = sha256_file(&link, &mut on_bytes).map_err(ModelsError::io("read", &link))?;
        if actual != expected {
            return Ok(Some(LfsMismatch {
                file: file.clone(),
                expected,
                actual,
            }));
        }
    }
    Ok(None)
}

/// The SHA-256 a snapshot file's blob is named after, when the Hub stored
/// it with LFS (its ETag is then the content's SHA-256).
pub(super) fn lfs_sha256(link: &Path) -> Option<String> {
    let blob = fs::canonicalize(link).ok()?;
    let name = blob.file_name()?.to_str()?;
    (name.len() == 64 && name.bytes().all(|b| b.is_ascii_hexdigit())).then(|| name.to_string())
}

/// A key file's problem in a few words, for a line saying why a copy was
/// passed over.
pub(crate) fn problem_line(problem: &Problem) -> String {
    match problem {
        Problem::Missing { file } => format!("{file} is missing"),
        Problem::Mismatch { file, .. } => {
            format!("{file} is truncated or not the pinned file (its SHA-256 differs)")
        }
    }
}

/// The commit hashes the files under `refs/` name (branches and tags).
fn referenced_revisions(refs: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut pending = vec![refs.to_path_buf()];
    while let Some(dir) = pending.pop() {
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.filter_map(Result::ok) {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
            } else if let Ok(text) = fs::read_to_string(&path) {
                found.push(text.trim().to_string());
            }
        }
    }
    found
}
