//! The one writer of a run's output files (`eval`'s results, tables and
//! manifest, `--record`'s recording): the first write that fails (a full
//! disk, a lost mount, a permission) cancels the run, so that no provider
//! is asked for an answer that could not be kept.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use tokio_util::sync::CancellationToken;

use super::AgentError;
use crate::fsutil::write_atomic;

/// Writes a run's output files; on the first failure, cancels `cancel`.
#[derive(Debug)]
pub struct OutputSink {
    cancel: CancellationToken,
    failed: AtomicBool,
}

impl OutputSink {
    /// A sink that cancels `cancel` (the run's token) when a write fails.
    pub fn new(cancel: CancellationToken) -> Self {
        OutputSink {
            cancel,
            failed: AtomicBool::new(false),
        }
    }

    /// Writes `bytes` to `path` atomically; a failure cancels the run
    /// before it is returned.
    pub fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), AgentError> {
        let written = write_atomic(path, bytes).map_err(AgentError::from);
        if written.is_err() {
            self.failed.store(true, Ordering::SeqCst);
            self.cancel.cancel();
        }
        written
    }

    /// Whether a write failed (and so the run was cancelled).
    pub fn failed(&self) -> bool {
        self.failed.load(Ordering::SeqCst)
    }

    /// The run's token, cancelled by the first failed write.
    pub fn cancel(&self) -> &CancellationToken {
        &self.cancel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_failed_write_cancels_the_run() {
        let dir = tempfile::tempdir().unwrap();
        let sink = OutputSink::new(CancellationToken::new());
        sink.write(&dir.path().join("a.json"), b"{}").unwrap();
        assert!(!sink.failed() && !sink.cancel().is_cancelled());
        let blocked = dir.path().join("file");
        std::fs::write(&blocked, "").unwrap();
        assert!(sink.write(&blocked.join("b.json"), b"{}").is_err());
        assert!(sink.failed());
        assert!(sink.cancel().is_cancelled());
    }
}
