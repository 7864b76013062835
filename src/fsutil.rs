//! Files written whole or not at all: the one atomic write every result,
//! table, figure, recording, cache entry and the session go through.
//!
//! A write makes a uniquely named temporary file beside its target, writes
//! it, flushes it to disk, renames it over the target and flushes the
//! folder, so that a reader (or a crash, or a power cut) never leaves half a
//! file, and concurrent writers never share a temporary file. Who may read
//! the result is decided by [`Access`]: the user's umask for ordinary files,
//! the owner only for anything that may hold a secret.

use std::fs::{self, File};
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

/// The prefix of the temporary file a write makes beside its target. A
/// folder of entries (see [`crate::store`]) knows such files are not
/// entries, and removes the ones a crashed writer left.
pub const TEMP_PREFIX: &str = ".tmp";

/// Who may read a file written by [`write_atomic_as`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// A new file gets the mode the user's umask allows (`0666 & !umask`);
    /// a replaced file keeps its mode. For results, tables, figures, items
    /// files, CSVs and cache entries, which a group may need to share.
    Shared,
    /// The owner only (mode 0600), whatever the umask or the replaced file
    /// was: for the session file and anything that may hold a secret.
    Private,
}

/// Why a file could not be written: what was being done, to which path,
/// and the operating system's reason.
#[derive(Debug, thiserror::Error)]
#[error("cannot {action} {}: {error}", path.display())]
pub struct FsError {
    /// What was being done, e.g. `write` or `create the folder of`.
    pub action: &'static str,
    /// The file (or folder) concerned.
    pub path: PathBuf,
    /// The operating system's error.
    pub error: io::Error,
}

impl FsError {
    /// A constructor for `map_err`: `action` failed on `path`.
    fn at(action: &'static str, path: &Path) -> impl FnOnce(io::Error) -> Self {
        let path = path.to_path_buf();
        move |error| Self {
            action,
            path,
            error,
        }
    }
}

impl From<FsError> for io::Error {
    /// For callers whose errors are plain `io::Error`s (the disk store): the
    /// kind is kept, the message names the action and the path.
    fn from(e: FsError) -> Self {
        io::Error::new(e.error.kind(), e.to_string())
    }
}

/// A path that is not UTF-8 text where mapvlm keeps paths as text (`plan
/// --json`, records, `eval`'s results): it would fail to be written after
/// the models were paid, so it is refused before anything is asked.
#[derive(Debug, thiserror::Error)]
#[error("{what} {}: the path is not UTF-8 text, and mapvlm keeps the paths it is given as text (in --json, records and results); rename it, or link it under a UTF-8 name and give that", path.to_string_lossy())]
pub struct NotUtf8Path {
    /// Where the path came from (a flag, e.g. `--image`).
    pub what: String,
    /// The path.
    pub path: PathBuf,
}

/// `path` as UTF-8 text, or a [`NotUtf8Path`] naming it (lossily) as
/// `what`: the check of every path a command will write as text, made
/// before any work is spent.
pub fn utf8_path<'a>(what: &str, path: &'a Path) -> Result<&'a str, NotUtf8Path> {
    path.to_str().ok_or_else(|| NotUtf8Path {
        what: what.to_string(),
        path: path.to_path_buf(),
    })
}

/// The folder a file at `path` lives in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Writes `bytes` to `path` atomically and durably, with [`Access::Shared`]
/// permissions: what every result, table, figure and cache entry uses.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FsError> {
    write_atomic_as(path, bytes, Access::Shared)
}

/// Writes `bytes` to `path` atomically and durably, readable by the owner
/// only ([`Access::Private`]): for the session file and anything that may
/// hold a secret.
pub fn write_atomic_private(path: &Path, bytes: &[u8]) -> Result<(), FsError> {
    write_atomic_as(path, bytes, Access::Private)
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder
/// (made if missing) is written, flushed to disk, given the permissions of
/// `access`, renamed over `path`, and the folder is flushed so the rename
/// survives a crash.
pub fn write_atomic_as(path: &Path, bytes: &[u8], access: Access) -> Result<(), FsError> {
    let folder = folder_of(path);
    fs::create_dir_all(folder).map_err(FsError::at("create the folder", folder))?;
    let kept_mode = match access {
        Access::Shared => replaced_mode(path).map_err(FsError::at("read the mode of", path))?,
        Access::Private => Some(PRIVATE_MODE),
    };
    let mut temp = temp_builder()
        .tempfile_in(folder)
        .map_err(FsError::at("create a temporary file in", folder))?;
    if let Some(mode) = kept_mode {
        set_mode(temp.as_file(), mode).map_err(FsError::at("set the mode of", temp.path()))?;
    }
    temp.write_all(bytes)
        .map_err(FsError::at("write", temp.path()))?;
    temp.as_file()
        .sync_all()
        .map_err(FsError::at("flush", temp.path()))?;
    temp.persist(path)
        .map_err(|e| FsError::at("rename a temporary file to", path)(e.error))?;
    sync_folder(folder).map_err(FsError::at("flush the folder", folder))
}

/// Checks, before any work is spent, that [`write_atomic`] could write
/// `path`: it is not a folder, its folder exists or can be made, and a
/// file can be created there. Nothing is left behind but the folder.
pub fn check_writable(path: &Path) -> Result<(), FsError> {
    if path.is_dir() {
        return Err(FsError {
            action: "write (it is a folder; give a file name)",
            path: path.to_path_buf(),
            error: io::Error::from(io::ErrorKind::IsADirectory),
        });
    }
    let folder = folder_of(path);
    fs::create_dir_all(folder).map_err(FsError::at("create the folder", folder))?;
    temp_builder()
        .tempfile_in(folder)
        .map(drop)
        .map_err(FsError::at("write in the folder", folder))
}

/// The mode of the owner-only files.
const PRIVATE_MODE: u32 = 0o600;

/// How temporary files are made: with [`TEMP_PREFIX`] and, on Unix, the
/// creation mode 0666, which the kernel narrows by the umask.
fn temp_builder() -> tempfile::Builder<'static, 'static> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(TEMP_PREFIX);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        builder.permissions(fs::Permissions::from_mode(0o666));
    }
    builder
}

/// The permission bits of the file at `path` that a write replaces, or
/// nothing when there is none yet.
#[cfg(unix)]
fn replaced_mode(path: &Path) -> io::Result<Option<u32>> {
    use std::os::unix::fs::PermissionsExt as _;
    match fs::metadata(path) {
        Ok(meta) if meta.is_file() => Ok(Some(meta.permissions().mode() & 0o777)),
        Ok(_) => Ok(None),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e),
    }
}

/// Permission bits are a Unix matter; elsewhere the platform decides.
#[cfg(not(unix))]
fn replaced_mode(_path: &Path) -> io::Result<Option<u32>> {
    Ok(None)
}

/// Sets the permission bits of an open file (not narrowed by the umask).
#[cfg(unix)]
fn set_mode(file: &File, mode: u32) -> io::Result<()> {
    use std::os::unix::fs::PermissionsExt as _;
    file.set_permissions(fs::Permissions::from_mode(mode))
}

/// Permission bits are a Unix matter; elsewhere the platform decides.
#[cfg(not(unix))]
fn set_mode(_file: &File, _mode: u32) -> io::Result<()> {
    Ok(())
}

/// Flushes a folder's entries to disk, so that a rename in it survives a
/// crash. File systems that cannot flush a folder (they answer "invalid
/// input" or "unsupported") make renames durable by themselves.
#[cfg(unix)]
fn sync_folder(folder: &Path) -> io::Result<()> {
    match File::open(folder).and_then(|dir| dir.sync_all()) {
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::InvalidInput | io::ErrorKind::Unsupported
            ) =>
        {
            Ok(())
        }
        other => other,
    }
}

/// Folders cannot be opened for flushing off Unix; the rename is all.
#[cfg(not(unix))]
fn sync_folder(_folder: &Path) -> io::Result<()> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt as _;

    use super::*;

    fn mode(path: &Path) -> u32 {
        fs::metadata(path).unwrap().permissions().mode() & 0o777
    }

    /// The umask of this process, as Linux reports it (setting and
    /// restoring it would race with the other tests' files).
    fn umask() -> u32 {
        let status = fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with("Umask:")).unwrap();
        u32::from_str_radix(line["Umask:".len()..].trim(), 8).unwrap()
    }

    #[test]
    fn writes_the_bytes_and_makes_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a").join("b").join("out.json");
        write_atomic(&path, b"{}").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"{}");
        write_atomic(&path, b"[1]").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"[1]");
    }

    #[test]
    fn leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        write_atomic(&dir.path().join("x"), b"1").unwrap();
        write_atomic_private(&dir.path().join("y"), b"2").unwrap();
        check_writable(&dir.path().join("z")).unwrap();
        let mut names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["x", "y"]);
    }

    #[test]
    fn a_new_shared_file_gets_the_umask_mode() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("items.jsonl");
        write_atomic(&path, b"x").unwrap();
        assert_eq!(mode(&path), 0o666 & !umask());
    }

    #[test]
    fn a_replaced_file_keeps_its_mode_unless_private() {
        let dir = tempfile::tempdir().unwrap();
        for (access, before, after) in [
            (Access::Shared, 0o640, 0o640),
            (Access::Private, 0o644, 0o600),
        ] {
            let path = dir.path().join(format!("{access:?}"));
            fs::write(&path, "old").unwrap();
            fs::set_permissions(&path, fs::Permissions::from_mode(before)).unwrap();
            write_atomic_as(&path, b"new", access).unwrap();
            assert_eq!(mode(&path), after, "{access:?}");
            assert_eq!(fs::read(&path).unwrap(), b"new");
        }
        let fresh = dir.path().join("fresh.json");
        write_atomic_private(&fresh, b"x").unwrap();
        assert_eq!(mode(&fresh), 0o600);
    }

    #[test]
    fn a_folder_is_refused_with_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let err = write_atomic(dir.path(), b"x").unwrap_err();
        assert_eq!(err.path, dir.path());
        let err = check_writable(dir.path()).unwrap_err();
        assert!(err.to_string().contains("it is a folder"), "{err}");
    }
}
