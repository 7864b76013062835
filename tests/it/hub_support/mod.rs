//! A local server speaking the part of the Hugging Face Hub's download
//! protocol that clients use (`GET /ORG/NAME/resolve/REVISION/FILE` with
//! `Range`, answering `206` with `Content-Range`, `ETag` and
//! `X-Repo-Commit`), and helpers to lay out a Hugging Face cache as
//! `huggingface_hub` leaves it.
#![allow(dead_code)]

use std::collections::HashMap;
use std::fs;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use sha2::{Digest, Sha256};
use wiremock::matchers::{method, path_regex};
use wiremock::{Mock, MockServer, Request, Respond, ResponseTemplate};

/// Lowercase hex SHA-256 of `bytes`.
pub fn sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Where a served file's bytes are.
#[derive(Clone)]
pub enum Content {
    /// Held in memory.
    Bytes(Vec<u8>),
    /// Read from a file on each request (for large real files).
    File(PathBuf),
}

impl Content {
    fn len(&self) -> u64 {
        match self {
            Content::Bytes(b) => b.len() as u64,
            Content::File(p) => fs::metadata(p).unwrap().len(),
        }
    }

    fn range(&self, start: u64, end: u64) -> Vec<u8> {
        match self {
            Content::Bytes(b) => b[start as usize..=end as usize].to_vec(),
            Content::File(p) => {
                let mut f = fs::File::open(p).unwrap();
                f.seek(SeekFrom::Start(start)).unwrap();
                let mut buf = vec![0; (end - start + 1) as usize];
                f.read_exact(&mut buf).unwrap();
                buf
            }
        }
    }

    /// SHA-256 of the whole content (the ETag the Hub gives an LFS file).
    fn sha256(&self) -> String {
        match self {
            Content::Bytes(b) => sha256(b),
            Content::File(p) => mapvlm::models::sha256_file(p, |_| {}).unwrap(),
        }
    }
}

/// A repository the server holds at one commit.
#[derive(Clone)]
pub struct HubRepo {
    /// The commit the server reports in `X-Repo-Commit`.
    pub commit: String,
    files: HashMap<String, (Content, String)>,
    /// Every `Range` asked for, with the file, in order.
    pub ranges: Arc<Mutex<Vec<(String, String)>>>,
}

impl HubRepo {
    /// A repository at `commit` with `files` (path, content).
    pub fn new(commit: &str, files: Vec<(&str, Content)>) -> Self {
        let files = files
            .into_iter()
            .map(|(name, content)| {
                let etag = content.sha256();
                (name.to_string(), (content, etag))
            })
            .collect();
        Self {
            commit: commit.to_string(),
            files,
            ranges: Arc::default(),
        }
    }
}

impl Respond for HubRepo {
    fn respond(&self, request: &Request) -> ResponseTemplate {
        let path = request.url.path();
        let Some((_, rest)) = path.split_once("/resolve/") else {
            return ResponseTemplate::new(404);
        };
        let Some((_, file)) = rest.split_once('/') else {
            return ResponseTemplate::new(404);
        };
        let Some((content, etag)) = self.files.get(file) else {
            return ResponseTemplate::new(404).insert_header("x-error-code", "EntryNotFound");
        };
        let len = content.len();
        let range = request
            .headers
            .get("range")
            .and_then(|v| v.to_str().ok())
            .unwrap_or("bytes=0-")
            .to_string();
        self.ranges
            .lock()
            .unwrap()
            .push((file.to_string(), range.clone()));
        let (start, end) = parse_range(&range, len);
        ResponseTemplate::new(206)
            .insert_header("x-repo-commit", self.commit.as_str())
            .insert_header("etag", format!("\"{etag}\"").as_str())
            .insert_header(
                "content-range",
                format!("bytes {start}-{end}/{len}").as_str(),
            )
            .set_body_bytes(content.range(start, end))
    }
}

fn parse_range(range: &str, len: u64) -> (u64, u64) {
    let spec = range.trim_start_matches("bytes=");
    let (a, b) = spec.split_once('-').unwrap_or((spec, ""));
    let start: u64 = a.parse().unwrap_or(0);
    let end: u64 = b.parse().unwrap_or(len - 1).min(len - 1);
    (start, end)
}

/// Starts a server holding `repo` under every repository name.
pub async fn serve(repo: &HubRepo) -> MockServer {
    let server = MockServer::start().await;
    Mock::given(method("GET"))
        .and(path_regex("^/.+/resolve/.+"))
        .respond_with(repo.clone())
        .mount(&server)
        .await;
    server
}

/// Lays out repository `repo` (`ORG/NAME`) in the Hub cache `cache` with a
/// snapshot `revision` holding `files` (path, bytes), blobs named by their
/// SHA-256 and snapshot entries as relative symbolic links, and `refs/main`
/// naming the revision, as `huggingface_hub` does. Returns the snapshot folder.
pub fn cache_snapshot(
    cache: &Path,
    repo: &str,
    revision: &str,
    files: &[(&str, &[u8])],
) -> PathBuf {
    let repo_dir = cache.join(format!("models--{}", repo.replace('/', "--")));
    let blobs = repo_dir.join("blobs");
    let snapshot = repo_dir.join("snapshots").join(revision);
    fs::create_dir_all(&blobs).unwrap();
    fs::create_dir_all(repo_dir.join("refs")).unwrap();
    fs::write(repo_dir.join("refs/main"), revision).unwrap();
    for (name, bytes) in files {
        let blob = blobs.join(sha256(bytes));
        fs::write(&blob, bytes).unwrap();
        link_into_snapshot(&snapshot, name, &blob);
    }
    snapshot
}

/// Makes `snapshot/name` a relative symbolic link to `blob`.
pub fn link_into_snapshot(snapshot: &Path, name: &str, blob: &Path) {
    let dest = snapshot.join(name);
    fs::create_dir_all(dest.parent().unwrap()).unwrap();
    let depth = name.matches('/').count() + 2;
    let mut relative = PathBuf::new();
    for _ in 0..depth {
        relative.push("..");
    }
    relative.push("blobs");
    relative.push(blob.file_name().unwrap());
    std::os::unix::fs::symlink(relative, dest).unwrap();
}

/// Every file under `dir`, relative, sorted.
pub fn files_under(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() && !path.is_symlink() {
                pending.push(path);
            } else {
                out.push(path.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}
