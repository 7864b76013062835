//! One lock mechanism for everything that must not run twice on one folder
//! (`eval --out`, a model pack being fetched, a workbench session): an
//! advisory `flock` on a lock file that names its holder (PID, host and
//! command). The kernel frees the lock when the holder exits in any way,
//! `kill -9` included, so a stale lock file never blocks anyone; only a
//! live holder does, and it is named.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use rustix::fs::{flock, FlockOperation};

/// Why a lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another live process holds it.
    #[error("{} is in use by {holder}; wait for it to finish (or stop it), or use another folder", path.display())]
    Held {
        /// The lock file.
        path: PathBuf,
        /// Who holds it, as its lock file says.
        holder: String,
    },
    /// The lock file could not be created or locked.
    #[error("{}: cannot be locked ({message})", path.display())]
    Io {
        /// The lock file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// A lock held until this value is dropped (or the process ends).
#[derive(Debug)]
pub struct Lock {
    /// The open lock file: closing it frees the lock.
    _file: File,
    /// The lock file.
    path: PathBuf,
}

/// Who this process is, as a lock file records it: `PID N on HOST (COMMAND)`.
fn holder_line(command: &str) -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "an unknown host".to_string());
    format!("PID {} on {host} ({command})", std::process::id())
}

impl Lock {
    /// Takes the lock at `path` for `command` (what the holder is doing, shown
    /// to whoever finds it taken), or fails at once naming the live holder.
    pub fn acquire(path: &Path, command: &str) -> Result<Lock, LockError> {
        let mut file = open(path)?;
        match flock(&file, FlockOperation::NonBlockingLockExclusive) {
            Ok(()) => Ok(Lock::held(file, path, command)),
            Err(rustix::io::Errno::WOULDBLOCK) => Err(LockError::Held {
                path: path.to_path_buf(),
                holder: read_holder(&mut file),
            }),
            Err(err) => Err(io_error(path, err.into())),
        }
    }

    /// Takes the lock at `path` for `command`, waiting while another process
    /// holds it; `waiting` is told who, once, when it has to wait.
    pub fn wait(path: &Path, command: &str, waiting: &dyn Fn(&str)) -> Result<Lock, LockError> {
        match Lock::acquire(path, command) {
            Err(LockError::Held { holder, .. }) => {
                waiting(&crate::sanitize::for_terminal(&holder));
                let file = open(path)?;
                flock(&file, FlockOperation::LockExclusive)
                    .map_err(|err| io_error(path, err.into()))?;
                Ok(Lock::held(file, path, command))
            }
            taken => taken,
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A lock just taken on `file`: its holder line written (best effort: a
    /// full disk leaves the line out, and the lock holds all the same).
    fn held(mut file: File, path: &Path, command: &str) -> Lock {
        let line = holder_line(command);
        let _ = file
            .set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| file.write_all(format!("{line}\n").as_bytes()))
            .and_then(|()| file.flush());
        Lock {
            _file: file,
            path: path.to_path_buf(),
        }
    }
}

/// Opens (creating when needed, with its folder) the lock file at `path`.
fn open(path: &Path) -> Result<File, LockError> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|err| io_error(path, err))?;
    }
    OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(|err| io_error(path, err))
}

/// The holder line of a taken lock's file, or a stand-in when it has none.
fn read_holder(file: &mut File) -> String {
    let mut text = String::new();
    let _ = file.take(4096).read_to_string(&mut text);
    let line = text.lines().next().unwrap_or("").trim().to_string();
    if line.is_empty() {
        "another process (it has not written its name yet)".to_string()
    } else {
        line
    }
}

fn io_error(path: &Path, err: std::io::Error) -> LockError {
    LockError::Io {
        path: path.to_path_buf(),
        message: err.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_taker_is_refused_naming_the_holder_until_it_lets_go() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out/eval.lock");
        let first = Lock::acquire(&path, "mapvlm eval").unwrap();
        assert_eq!(first.path(), path);
        let refused = Lock::acquire(&path, "mapvlm eval").unwrap_err();
        let message = refused.to_string();
        let pid = format!("PID {}", std::process::id());
        assert!(message.contains(&pid), "{message}");
        assert!(message.contains("(mapvlm eval)"), "{message}");
        drop(first);
        let again = Lock::acquire(&path, "mapvlm eval again");
        assert!(again.is_ok(), "{again:?}");
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 1, "{text}");
        assert!(text.contains("(mapvlm eval again)"), "{text}");
    }

    #[test]
    fn a_waiter_is_told_who_it_waits_for_and_gets_the_lock_when_freed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pack.lock");
        let first = Lock::acquire(&path, "mapvlm models fetch").unwrap();
        let told = std::sync::Mutex::new(Vec::new());
        std::thread::scope(|s| {
            let waiter = s.spawn(|| {
                Lock::wait(&path, "second", &|who| {
                    told.lock().unwrap().push(who.to_string())
                })
            });
            while told.lock().unwrap().is_empty() {
                std::thread::yield_now();
            }
            drop(first);
            assert!(waiter.join().unwrap().is_ok());
        });
        let told = told.into_inner().unwrap();
        assert_eq!(told.len(), 1);
        assert!(told[0].contains("(mapvlm models fetch)"), "{told:?}");
    }
}
