//! Writes the session's copies to its file in the order they were taken.
//!
//! The loop hands numbered copies to a saver task, which writes them on a
//! blocking thread; on quit the loop writes the final state itself. A write
//! already under way cannot be called back, so without an order an older
//! copy could land after the final one and undo the user's last edit. Every
//! write goes through one [`SessionFile`], which writes a copy only when no
//! later one is in the file and lets one write run at a time.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;

use super::message::Msg;
use super::session::{self, Session, SessionError};
use super::SAVE_EVERY;

/// A copy of the session and its number: copies are numbered as the loop
/// takes them, so a higher number is a later state.
pub type NumberedCopy = (u64, Session);

/// The number the final save on quit writes under: later than every copy.
pub const FINAL: u64 = u64::MAX;

/// The session file and the number of the copy it holds.
#[derive(Debug)]
pub struct SessionFile {
    path: PathBuf,
    written: Mutex<u64>,
}

impl SessionFile {
    /// A file no copy has been written to yet by this process.
    pub fn new(path: PathBuf) -> Self {
        Self {
            path,
            written: Mutex::new(0),
        }
    }

    /// Where the session is saved.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes copy `number` unless the file already holds it or a later one,
    /// after any write in progress has finished. Returns whether it wrote.
    pub fn write(&self, number: u64, session: &Session) -> Result<bool, SessionError> {
        let mut written = self.written.lock().unwrap_or_else(PoisonError::into_inner);
        if number <= *written {
            return Ok(false);
        }
        session::save(&self.path, session)?;
        *written = number;
        Ok(true)
    }
}

/// Writes the latest copy at most every [`SAVE_EVERY`], off the loop, and
/// reports each write's outcome to the loop.
pub fn spawn(
    file: Arc<SessionFile>,
    mut copies: watch::Receiver<Option<NumberedCopy>>,
    msgs: mpsc::UnboundedSender<Msg>,
) -> JoinHandle<()> {
    tokio::spawn(async move {
        while copies.changed().await.is_ok() {
            tokio::time::sleep(SAVE_EVERY).await;
            let Some((number, copy)) = copies.borrow_and_update().clone() else {
                continue;
            };
            let file = file.clone();
            let result = tokio::task::spawn_blocking(move || file.write(number, &copy))
                .await
                .map_err(SessionError::from)
                .and_then(|written| written.map(|_| ()));
            let _ = msgs.send(Msg::Saved(result));
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::workbench::app::{App, AppInit};

    /// The demo's session with `step` as its plan.
    fn with_plan(step: &str) -> Session {
        let (app, _) = App::new(AppInit::demo((80, 24), "no models in this test"));
        let mut session = app.to_session();
        session.current.plan = vec![step.to_string()];
        session
    }

    fn plan_in(path: &Path) -> String {
        let text = std::fs::read_to_string(path).unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        json["plan"][0].as_str().unwrap().to_string()
    }

    #[test]
    fn an_older_copy_never_overwrites_a_later_one() {
        let dir = tempfile::tempdir().unwrap();
        let file = SessionFile::new(dir.path().join("session.json"));
        assert!(file.write(2, &with_plan("second")).unwrap());
        assert!(!file.write(1, &with_plan("first")).unwrap());
        assert_eq!(plan_in(file.path()), "second");
        assert!(file.write(FINAL, &with_plan("final")).unwrap());
        assert!(!file.write(3, &with_plan("third")).unwrap());
        assert_eq!(plan_in(file.path()), "final");
    }

    #[test]
    fn the_final_write_waits_for_a_write_in_progress_and_lands_last() {
        let dir = tempfile::tempdir().unwrap();
        let file = Arc::new(SessionFile::new(dir.path().join("session.json")));
        // Hold the file as a write in progress would, then let an older copy
        // and the final one race for it from two threads.
        let held = file.written.lock().unwrap();
        let older = {
            let file = file.clone();
            std::thread::spawn(move || file.write(5, &with_plan("older")).unwrap())
        };
        let last = {
            let file = file.clone();
            std::thread::spawn(move || file.write(FINAL, &with_plan("final")).unwrap())
        };
        std::thread::sleep(std::time::Duration::from_millis(20));
        drop(held);
        older.join().unwrap();
        assert!(last.join().unwrap());
        assert_eq!(plan_in(file.path()), "final");
    }
}
