//! Verifying a model folder: SHA-256 of its key files, and a stamp (size and
//! modification time of each key file) that makes "already verified" cheap.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;
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
/// hashes of its key files.
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
        Ok(Status::Ok)
    } else {
        Ok(Status::Corrupt(problems))
    }
}

/// What the stamp records of one key file.
#[derive(Debug, PartialEq, Eq, Serialize, Deserialize)]
struct StampEntry {
    path: String,
    sha256: String,
    size: u64,
    mtime_ns: u128,
}

fn stamp_entries(folder: &Path, key_files: &[KeyFile]) -> io::Result<Vec<StampEntry>> {
    key_files
        .iter()
        .map(|key| {
            let meta = std::fs::metadata(folder.join(&key.path))?;
            let mtime_ns = meta
                .modified()?
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos());
            Ok(StampEntry {
                path: key.path.clone(),
                sha256: key.sha256.clone(),
                size: meta.len(),
                mtime_ns,
            })
        })
        .collect()
}

/// Records that the key files of `folder` were verified as they are now.
pub(crate) fn write_stamp(folder: &Path, key_files: &[KeyFile]) -> Result<(), ModelsError> {
    let entries = stamp_entries(folder, key_files).map_err(ModelsError::io("stat", folder))?;
    let json = serde_json::to_vec_pretty(&entries).map_err(|e| ModelsError::Io {
        action: "encode the stamp for",
        path: folder.to_path_buf(),
        source: e.into(),
    })?;
    let tmp = folder.join(format!("{STAMP_FILE}.tmp"));
    std::fs::write(&tmp, json).map_err(ModelsError::io("write", &tmp))?;
    let stamp = folder.join(STAMP_FILE);
    std::fs::rename(&tmp, &stamp).map_err(ModelsError::io("rename", &stamp))
}

/// Whether `folder`'s stamp matches its key files' current size and mtime
/// and the expected hashes.
pub(crate) fn stamp_matches(folder: &Path, key_files: &[KeyFile]) -> bool {
    let Ok(bytes) = std::fs::read(folder.join(STAMP_FILE)) else {
        return false;
    };
    let Ok(recorded) = serde_json::from_slice::<Vec<StampEntry>>(&bytes) else {
        return false;
    };
    stamp_entries(folder, key_files).is_ok_and(|now| now == recorded)
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
