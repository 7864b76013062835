//! The session file: where it lives, its atomic save, and its restore
//! (decoded, migrated to this version and repaired; a file that cannot be
//! read is set aside, not fatal).

use std::path::{Path, PathBuf};

use super::{migrate, repair, DecodeError, Session};

/// Why a session file could not be saved or restored.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// Reading, writing or renaming failed.
    #[error("session file {path}: {error}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// The session could not be turned into JSON.
    #[error("session could not be encoded: {0}")]
    Encode(#[from] serde_json::Error),
    /// The saving task ended abnormally.
    #[error("{0}")]
    Stopped(#[from] tokio::task::JoinError),
}

/// The outcome of restoring a session.
#[derive(Debug)]
pub enum Restored {
    /// No session file yet.
    Fresh,
    /// The session was read.
    Loaded {
        /// The session.
        session: Box<Session>,
        /// The values that were out of range and put back to their
        /// defaults, one notice each (see [`decode`]).
        repaired: Vec<String>,
    },
    /// The file could not be read as a session; it was moved aside.
    SetAside {
        /// Where the bad file now is.
        moved_to: PathBuf,
        /// What was wrong with it.
        reason: DecodeError,
    },
}

/// The default session file: `$XDG_STATE_HOME/mapvlm/session.json`, else
/// `$HOME/.local/state/mapvlm/session.json`.
pub fn default_path() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_STATE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .filter(|v| !v.is_empty())
                .map(|h| PathBuf::from(h).join(".local/state"))
        })?;
    Some(base.join("mapvlm").join("session.json"))
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> SessionError + '_ {
    move |error| SessionError::Io {
        path: path.to_path_buf(),
        error,
    }
}

/// Writes `session` to `path` atomically and readable by the owner only
/// (it holds the user's work and settings): see
/// [`crate::fsutil::write_atomic_private`].
pub fn save(path: &Path, session: &Session) -> Result<(), SessionError> {
    let json = serde_json::to_vec_pretty(session)?;
    crate::fsutil::write_atomic_private(path, &json).map_err(|e| SessionError::Io {
        path: e.path,
        error: e.error,
    })
}

/// The session in the bytes of a session file, brought up to this version
/// ([`super::migrate::migrate`]), with a notice for each number that was out of range and
/// put back to its default (the rest of the session, its run history
/// included, is kept); or why the bytes are not a session. The part of
/// [`restore`] that reads, kept apart from the file so that it can be
/// checked on any bytes.
pub fn decode(bytes: &[u8]) -> Result<(Session, Vec<String>), DecodeError> {
    let not_session = |e: serde_json::Error| DecodeError::NotSession(e.to_string());
    let value = serde_json::from_slice::<serde_json::Value>(bytes).map_err(not_session)?;
    let mut value = migrate::migrate(value)?;
    let repaired = repair::repair_numbers(&mut value);
    let session = serde_json::from_value::<Session>(value).map_err(not_session)?;
    Ok((session, repaired))
}

/// Reads the session at `path`. A file that is not a session of this
/// version (after [`super::migrate::migrate`]) is renamed to `<name>.corrupt-<unix seconds>` and reported.
pub fn restore(path: &Path) -> Result<Restored, SessionError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Restored::Fresh),
        Err(e) => return Err(io_error(path)(e)),
    };
    let reason = match decode(&bytes) {
        Ok((session, repaired)) => {
            return Ok(Restored::Loaded {
                session: Box::new(session),
                repaired,
            })
        }
        Err(reason) => reason,
    };
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut moved_to = path.as_os_str().to_owned();
    moved_to.push(format!(".corrupt-{stamp}"));
    let moved_to = PathBuf::from(moved_to);
    std::fs::rename(path, &moved_to).map_err(io_error(path))?;
    Ok(Restored::SetAside { moved_to, reason })
}
