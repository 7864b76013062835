//! A content-addressed store of small entries on disk, one file each, shared
//! by every mapvlm process of a user (or of a cluster, on a shared volume).
//!
//! Why files: a write is a unique temporary file renamed over the entry, so
//! any number of processes may read and write at once and a reader never sees
//! half an entry; a pruned or lost entry is only a miss. The store stays under
//! a size bound by evicting the least recently used entries, "used" being the
//! modification time, which a hit refreshes (at most once a minute, to keep
//! hits read-only in the common case).

use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime};

use sha2::{Digest, Sha256};

use crate::fsutil::TEMP_PREFIX;

/// A hit older than this refreshes its entry's modification time.
const TOUCH_AFTER: Duration = Duration::from_secs(60);

/// Temporary files left this long by a crashed writer are removed by prune.
const STALE_TEMP: Duration = Duration::from_secs(3600);

/// The default size bound of a store: 2 GiB.
pub const DEFAULT_MAX_BYTES: u64 = 2 << 30;

/// The largest cache size bound a user may set, in MB (1 TiB): larger
/// bounds are surely typing mistakes, and would overflow in bytes.
pub const MAX_CACHE_MB: u64 = 1 << 20;

/// The user's cache folder for mapvlm: `$XDG_CACHE_HOME/mapvlm`, else
/// `$HOME/.cache/mapvlm`, else `.cache/mapvlm` in the current folder.
pub fn user_cache_root() -> PathBuf {
    let env_dir = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    env_dir("XDG_CACHE_HOME")
        .or_else(|| env_dir("HOME").map(|home| home.join(".cache")))
        .unwrap_or_else(|| PathBuf::from(".cache"))
        .join("mapvlm")
}

/// The address of an entry: the SHA-256 of everything that decides it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EntryKey([u8; 32]);

impl EntryKey {
    /// The key of the parts, each length-prefixed so that no two different
    /// lists of parts share a key.
    pub fn of(parts: &[&[u8]]) -> Self {
        let mut hasher = Sha256::new();
        for part in parts {
            hasher.update((part.len() as u64).to_le_bytes());
            hasher.update(part);
        }
        Self(hasher.finalize().into())
    }

    fn hex(&self) -> String {
        crate::models::hex(&self.0)
    }
}

/// How many entries a store holds and their total size.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct StoreStats {
    /// The number of entries.
    pub entries: u64,
    /// Their total size in bytes.
    pub bytes: u64,
}

/// One entry found while walking the store.
struct Found {
    path: PathBuf,
    bytes: u64,
    modified: SystemTime,
}

/// Entries under a folder, `DIR/ab/abcdef…` (the first two hex digits of the
/// key name a sub-folder, so no folder grows too large).
#[derive(Debug)]
pub struct DiskStore {
    dir: PathBuf,
    max_bytes: u64,
    written_since_check: AtomicU64,
}

impl DiskStore {
    /// A store in `dir` (created on first write) kept under `max_bytes`.
    pub fn new(dir: impl Into<PathBuf>, max_bytes: u64) -> Self {
        Self {
            dir: dir.into(),
            max_bytes,
            written_since_check: AtomicU64::new(0),
        }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path_of(&self, key: &EntryKey) -> PathBuf {
        let hex = key.hex();
        self.dir.join(&hex[..2]).join(hex)
    }

    /// The bytes stored under `key`; an absent or unreadable entry is a miss.
    pub fn get(&self, key: &EntryKey) -> Option<Vec<u8>> {
        let path = self.path_of(key);
        let bytes = std::fs::read(&path).ok()?;
        refresh(&path);
        Some(bytes)
    }

    /// Stores `bytes` under `key` atomically; after enough new bytes, evicts
    /// the least recently used entries beyond the size bound.
    pub fn put(&self, key: &EntryKey, bytes: &[u8]) -> io::Result<()> {
        crate::fsutil::write_atomic(&self.path_of(key), bytes)?;
        let written = self
            .written_since_check
            .fetch_add(bytes.len() as u64, Ordering::Relaxed)
            + bytes.len() as u64;
        if written > self.max_bytes / 16 {
            self.written_since_check.store(0, Ordering::Relaxed);
            self.prune(self.max_bytes)?;
        }
        Ok(())
    }

    /// The number and total size of the entries.
    pub fn stats(&self) -> io::Result<StoreStats> {
        let (found, _) = self.walk()?;
        Ok(StoreStats {
            entries: found.len() as u64,
            bytes: found.iter().map(|f| f.bytes).sum(),
        })
    }

    /// Removes the least recently used entries until the rest fit in
    /// `max_bytes`, and temporary files a crashed writer left; returns what
    /// was removed. An entry another process removes first is skipped.
    pub fn prune(&self, max_bytes: u64) -> io::Result<StoreStats> {
        let (mut found, stale) = self.walk()?;
        for path in stale {
            let _ = std::fs::remove_file(path);
        }
        let mut total: u64 = found.iter().map(|f| f.bytes).sum();
        found.sort_by_key(|f| f.modified);
        let mut removed = StoreStats::default();
        for entry in found {
            if total <= max_bytes {
                break;
            }
            total -= entry.bytes;
            if remove_if_present(&entry.path)? {
                removed.entries += 1;
                removed.bytes += entry.bytes;
            }
        }
        Ok(removed)
    }

    /// Removes every entry; returns what was removed.
    pub fn clear(&self) -> io::Result<StoreStats> {
        self.prune(0)
    }

    /// Every entry, and the stale temporary files.
    fn walk(&self) -> io::Result<(Vec<Found>, Vec<PathBuf>)> {
        let mut found = Vec::new();
        let mut stale = Vec::new();
        let shards = match std::fs::read_dir(&self.dir) {
            Ok(shards) => shards,
            Err(err) if err.kind() == io::ErrorKind::NotFound => return Ok((found, stale)),
            Err(err) => return Err(err),
        };
        let now = SystemTime::now();
        for shard in shards {
            let shard = shard?;
            let shard_name = shard.file_name().to_string_lossy().into_owned();
            if !shard.file_type()?.is_dir() || !is_shard_name(&shard_name) {
                continue;
            }
            for entry in std::fs::read_dir(shard.path())? {
                let entry = entry?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let temporary = name.starts_with(TEMP_PREFIX);
                if !temporary && !is_entry_name(&shard_name, &name) {
                    continue; // not ours: never counted, never removed
                }
                let Ok(meta) = entry.metadata() else {
                    continue; // removed by another process meanwhile
                };
                if !meta.is_file() {
                    continue;
                }
                let modified = meta.modified()?;
                if entry.file_name().to_string_lossy().starts_with(TEMP_PREFIX) {
                    if now.duration_since(modified).unwrap_or_default() > STALE_TEMP {
                        stale.push(entry.path());
                    }
                    continue;
                }
                found.push(Found {
                    path: entry.path(),
                    bytes: meta.len(),
                    modified,
                });
            }
        }
        Ok((found, stale))
    }
}

/// Whether `name` is a shard folder's: two lowercase hex digits.
fn is_shard_name(name: &str) -> bool {
    name.len() == 2 && name.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// Whether `name` in shard `shard` is an entry's: 64 lowercase hex digits
/// starting with the shard's two (the response cache adds `.json`).
fn is_entry_name(shard: &str, name: &str) -> bool {
    let stem = name.strip_suffix(".json").unwrap_or(name);
    stem.len() == 64
        && stem.starts_with(shard)
        && stem.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// Marks the entry at `path` as just used, unless it was used within
/// [`TOUCH_AFTER`]; best effort (a read-only store still serves hits).
fn refresh(path: &Path) {
    let now = SystemTime::now();
    let recent = std::fs::metadata(path)
        .and_then(|meta| meta.modified())
        .is_ok_and(|modified| now.duration_since(modified).unwrap_or_default() < TOUCH_AFTER);
    if !recent {
        if let Ok(file) = std::fs::OpenOptions::new().append(true).open(path) {
            let _ = file.set_modified(now);
        }
    }
}

/// Removes the file at `path`; `false` when it was already gone.
fn remove_if_present(path: &Path) -> io::Result<bool> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(true),
        Err(err) if err.kind() == io::ErrorKind::NotFound => Ok(false),
        Err(err) => Err(err),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(n: u32) -> EntryKey {
        EntryKey::of(&[&n.to_le_bytes()])
    }

    fn age(store: &DiskStore, key: &EntryKey, seconds: u64) {
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(store.path_of(key))
            .unwrap_or_else(|e| panic!("{e}"));
        file.set_modified(SystemTime::now() - Duration::from_secs(seconds))
            .unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn an_entry_reads_back_and_a_missing_one_is_a_miss() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path(), DEFAULT_MAX_BYTES);
        assert_eq!(store.get(&key(1)), None);
        store.put(&key(1), b"one").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(store.get(&key(1)).as_deref(), Some(&b"one"[..]));
        assert_eq!(
            store.stats().unwrap_or_else(|e| panic!("{e}")),
            StoreStats {
                entries: 1,
                bytes: 3
            }
        );
    }

    #[test]
    fn clear_removes_only_entries() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path(), DEFAULT_MAX_BYTES);
        store.put(&key(1), b"abc").unwrap_or_else(|e| panic!("{e}"));
        let entry = key(1).hex();
        let shard = dir.path().join(&entry[..2]);
        let theirs = [
            dir.path().join("sub/a.bin"),
            shard.join("notes.txt"),
            shard.join(format!("{}.bak", &entry)),
            dir.path().join("zz").join(&entry),
        ];
        for file in &theirs {
            let parent = file.parent().unwrap_or_else(|| panic!("a parent"));
            std::fs::create_dir_all(parent).unwrap_or_else(|e| panic!("{e}"));
            std::fs::write(file, b"keep").unwrap_or_else(|e| panic!("{e}"));
        }
        let removed = store.clear().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(removed.entries, 1);
        assert!(!shard.join(&entry).exists());
        for file in &theirs {
            assert!(file.exists(), "{} was kept", file.display());
        }
    }

    #[test]
    fn keys_separate_their_parts() {
        assert_ne!(EntryKey::of(&[b"ab", b"c"]), EntryKey::of(&[b"a", b"bc"]));
    }

    #[test]
    fn prune_evicts_the_least_recently_used_first() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path(), DEFAULT_MAX_BYTES);
        for n in 0..4 {
            store
                .put(&key(n), &[0u8; 10])
                .unwrap_or_else(|e| panic!("{e}"));
            age(&store, &key(n), 1000 - u64::from(n));
        }
        // Entry 0 is the oldest, but a hit makes it the most recent.
        assert!(store.get(&key(0)).is_some());
        let removed = store.prune(20).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(removed.entries, 2);
        assert!(store.get(&key(0)).is_some());
        assert!(store.get(&key(1)).is_none());
        assert!(store.get(&key(2)).is_none());
        assert!(store.get(&key(3)).is_some());
    }

    #[test]
    fn writes_beyond_the_bound_evict() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path(), 160);
        for n in 0..40 {
            store
                .put(&key(n), &[7u8; 16])
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let stats = store.stats().unwrap_or_else(|e| panic!("{e}"));
        assert!(stats.bytes <= 160 + 16, "{stats:?}");
        assert!(store.get(&key(39)).is_some(), "the newest entry stays");
    }

    #[test]
    fn concurrent_writers_and_readers_never_see_half_an_entry() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path(), DEFAULT_MAX_BYTES);
        let value: Vec<u8> = (0..=255u8).cycle().take(64 * 1024).collect();
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    for _ in 0..50 {
                        store.put(&key(9), &value).unwrap_or_else(|e| panic!("{e}"));
                        if let Some(read) = store.get(&key(9)) {
                            assert_eq!(read, value);
                        }
                    }
                });
            }
        });
        assert_eq!(store.stats().map(|s| s.entries).ok(), Some(1));
    }

    #[test]
    fn clear_removes_everything_and_is_idempotent() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let store = DiskStore::new(dir.path().join("never-made"), DEFAULT_MAX_BYTES);
        assert_eq!(store.clear().ok(), Some(StoreStats::default()));
        store.put(&key(1), b"x").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(store.clear().map(|s| s.entries).ok(), Some(1));
        assert_eq!(store.stats().ok(), Some(StoreStats::default()));
    }
}
