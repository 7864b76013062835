//! Verifying a model folder: SHA-256 of its key files, and a stamp that makes
//! "already verified" cheap enough to check at every start.
//!
//! The stamp is `MODEL_FOLDER/.mapvlm-verified.json`, a JSON array with one
//! object per key file verified:
//!
//! ```json
//! [{"path": "model.safetensors", "sha256": "78c0…", "size": 438011953,
//!   "mtime_ns": 1764590000123456789, "ctime_ns": 1764590000123456789,
//!   "inode": 1234567}]
//! ```
//!
//! `path` is relative to the model folder (`/`-separated); `sha256` is the
//! lowercase hex hash the file had when it was hashed; `size`, `mtime_ns`,
//! `ctime_ns` (nanoseconds since the Unix epoch) and `inode` are its
//! metadata then (`ctime_ns` and `inode` are 0 where the system has none).
//! A file whose metadata still equal its entry is taken as verified without
//! hashing; any difference, or no entry, means it is hashed again before use
//! ([`verified_spec_path`]). [`stamped_sha256`] reads a file's hash from
//! the stamp, for caches keyed by a model's identity.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::{KeyFile, ModelSpec, ModelsError};

/// Name of the stamp file written inside a model folder once it is verified.
pub(crate) const STAMP_FILE: &str = ".mapvlm-verified.json";

/// A key file that failed verification.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "problem", rename_all = "snake_case")]
pub enum Problem {
    /// The file is absent.
    Missing {
        /// The file, relative to the model folder.
        file: String,
    },
    /// The file's SHA-256 differs from the expected one.
    Mismatch {
        /// The file, relative to the model folder.
        file: String,
        /// The expected hash.
        expected: String,
        /// The hash found.
        actual: String,
    },
}

/// The state of one model after a full verification.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Status {
    /// Every key file matches.
    Ok,
    /// The model folder is absent.
    Missing,
    /// The folder is there but some key files are missing or differ.
    Corrupt(Vec<Problem>),
}

/// The state of one model from presence and stamp alone, without hashing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum QuickStatus {
    /// Present, and its key files are unchanged since they were verified.
    Verified,
    /// Present, but not verified since it last changed.
    Unverified,
    /// The model folder is absent.
    Missing,
}

/// The lowercase hex SHA-256 of the file at `path`; `on_bytes` is told of
/// every chunk read (for progress).
pub fn sha256_file(path: &Path, mut on_bytes: impl FnMut(u64)) -> io::Result<String> {
    let mut file = File::open(path)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        on_bytes(n as u64);
    }
    Ok(hex(&hasher.finalize()))
}

/// Lowercase hex of `bytes`.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Hashes every key file of the model folder `folder`; returns the problems
/// found (empty when all match).
pub(crate) fn check_key_files(
    folder: &Path,
    key_files: &[KeyFile],
    mut on_bytes: impl FnMut(u64),
) -> Result<Vec<Problem>, ModelsError> {
    let mut problems = Vec::new();
    for key in key_files {
        let path = folder.join(&key.path);
        match sha256_file(&path, &mut on_bytes) {
            Ok(actual) if actual == key.sha256 => {}
            Ok(actual) => problems.push(Problem::Mismatch {
                file: key.path.clone(),
                expected: key.sha256.clone(),
                actual,
            }),
            Err(err) if err.kind() == io::ErrorKind::NotFound => problems.push(Problem::Missing {
                file: key.path.clone(),
            }),
            Err(source) => {
                return Err(ModelsError::Io {
                    action: "read",
                    path,
                    source,
                })
            }
        }
    }
    Ok(problems)
}

/// Fully verifies model `spec` in the pack `models_dir` by recomputing the
/// hashes of its key files; a model found good is stamped.
pub fn verify_model(
    models_dir: &Path,
    spec: &ModelSpec,
    on_bytes: impl FnMut(u64),
) -> Result<Status, ModelsError> {
    let folder = models_dir.join(&spec.folder);
    if !folder.is_dir() {
        return Ok(Status::Missing);
    }
    let problems = check_key_files(&folder, &spec.key_files, on_bytes)?;
    if problems.is_empty() {
        if let Err(err) = write_stamp(&folder, &spec.key_files) {
            tracing::warn!(%err, "the verification stamp could not be saved");
        }
        Ok(Status::Ok)
    } else {
        Ok(Status::Corrupt(problems))
    }
}

/// What the stamp records of one key file (see the module documentation).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct StampEntry {
    path: String,
    sha256: String,
    size: u64,
    mtime_ns: u128,
    ctime_ns: u128,
    inode: u64,
}

/// The entry `path` would have now, with hash `sha256`.
fn stamp_entry(folder: &Path, path: &str, sha256: &str) -> io::Result<StampEntry> {
    let meta = std::fs::metadata(folder.join(path))?;
    let mtime_ns = meta
        .modified()?
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let (ctime_ns, inode) = change_time_and_inode(&meta);
    Ok(StampEntry {
        path: path.to_string(),
        sha256: sha256.to_string(),
        size: meta.len(),
        mtime_ns,
        ctime_ns,
        inode,
    })
}

/// The status-change time (ns since the epoch) and inode number of a file.
#[cfg(unix)]
fn change_time_and_inode(meta: &std::fs::Metadata) -> (u128, u64) {
    use std::os::unix::fs::MetadataExt;
    let ctime_ns = u128::try_from(meta.ctime()).unwrap_or(0) * 1_000_000_000
        + u128::try_from(meta.ctime_nsec()).unwrap_or(0);
    (ctime_ns, meta.ino())
}

/// Systems without status-change times or inodes record zeros.
#[cfg(not(unix))]
fn change_time_and_inode(_meta: &std::fs::Metadata) -> (u128, u64) {
    (0, 0)
}

fn stamp_entries(folder: &Path, key_files: &[KeyFile]) -> io::Result<Vec<StampEntry>> {
    key_files
        .iter()
        .map(|key| stamp_entry(folder, &key.path, &key.sha256))
        .collect()
}

/// The stamp of `folder`, or nothing when it is absent or unreadable.
fn read_stamp(folder: &Path) -> Vec<StampEntry> {
    std::fs::read(folder.join(STAMP_FILE))
        .ok()
        .and_then(|bytes| serde_json::from_slice(&bytes).ok())
        .unwrap_or_default()
}

/// Records that the key files of `folder` were verified as they are now.
pub(crate) fn write_stamp(folder: &Path, key_files: &[KeyFile]) -> Result<(), ModelsError> {
    let entries = stamp_entries(folder, key_files).map_err(ModelsError::io("stat", folder))?;
    save_stamp(folder, &entries)
}

fn save_stamp(folder: &Path, entries: &[StampEntry]) -> Result<(), ModelsError> {
    let json = serde_json::to_vec_pretty(entries).map_err(|e| ModelsError::Io {
        action: "encode the stamp for",
        path: folder.to_path_buf(),
        source: e.into(),
    })?;
    crate::fsutil::write_atomic(&folder.join(STAMP_FILE), &json).map_err(|e| ModelsError::Io {
        action: e.action,
        path: e.path,
        source: e.error,
    })
}

/// Whether `folder`'s stamp matches its key files' current size and mtime
/// and the expected hashes.
pub(crate) fn stamp_matches(folder: &Path, key_files: &[KeyFile]) -> bool {
    let recorded = read_stamp(folder);
    stamp_entries(folder, key_files).is_ok_and(|now| now == recorded)
}

/// The folder of model `spec` in `models_dir`, its key files verified: each
/// file whose stamp entry still matches its metadata is taken as is; any
/// other is hashed again, and refused when its hash differs from the one
/// expected (one error naming the file). The stamp is then brought up to
/// date (when the folder cannot be written, the check simply repeats next
/// time).
pub fn verified_spec_path(models_dir: &Path, spec: &ModelSpec) -> Result<PathBuf, ModelsError> {
    let folder = super::model_path(models_dir, &spec.folder)?;
    let mut stamp = read_stamp(&folder);
    let mut changed = false;
    for key in &spec.key_files {
        let now = stamp_entry(&folder, &key.path, &key.sha256);
        let recorded = stamp.iter().position(|e| e.path == key.path);
        if let (Ok(now), Some(i)) = (&now, recorded) {
            if stamp[i] == *now {
                continue;
            }
        }
        let path = folder.join(&key.path);
        let actual = sha256_file(&path, |_| {}).map_err(ModelsError::io("read", &path))?;
        if actual != key.sha256 {
            return Err(ModelsError::Damaged {
                path,
                expected: key.sha256.clone(),
                actual,
            });
        }
        let entry =
            stamp_entry(&folder, &key.path, &actual).map_err(ModelsError::io("stat", &path))?;
        match recorded {
            Some(i) => stamp[i] = entry,
            None => stamp.push(entry),
        }
        changed = true;
    }
    if changed {
        if let Err(err) = save_stamp(&folder, &stamp) {
            tracing::warn!(%err, "the verification stamp could not be saved");
        }
    }
    Ok(folder)
}

/// The SHA-256 of `file` (relative to `model_folder`, `/`-separated) as the
/// stamp records it, when the file's metadata still match its entry; `None`
/// when there is no entry or the file changed since (verify it first with
/// [`super::verified_model_path`]). Caches keyed by a model use this, so that they
/// never hash the model themselves.
pub fn stamped_sha256(model_folder: &Path, file: &str) -> Option<String> {
    let entry = read_stamp(model_folder)
        .into_iter()
        .find(|e| e.path == file)?;
    let now = stamp_entry(model_folder, file, &entry.sha256).ok()?;
    (now == entry).then_some(entry.sha256)
}

/// The state of model `spec` in `models_dir` from presence and stamp only.
pub fn quick_status(models_dir: &Path, spec: &ModelSpec) -> QuickStatus {
    let folder = models_dir.join(&spec.folder);
    if !folder.is_dir() {
        QuickStatus::Missing
    } else if stamp_matches(&folder, &spec.key_files) {
        QuickStatus::Verified
    } else {
        QuickStatus::Unverified
    }
}
