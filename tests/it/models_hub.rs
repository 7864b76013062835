//! Models from the Hugging Face cache and the Hub: a prepared cache used in
//! place (links, no copies, no pip), and downloads from a local server that
//! speaks the Hub's download protocol, including refusals, a revision the
//! Hub should not have served, a tampered file and an interrupted download.

use crate::hub_support;

use std::fs;
use std::path::{Path, PathBuf};

use hub_support::{cache_snapshot, files_under, serve, sha256, Content, HubRepo as ServedRepo};
use mapvlm::models::{
    obtain_model, verify_model, Assembly, FetchOutcome, HubRepo, HubSettings, KeyFile, ModelSpec,
    ModelsError, Package, Pip, Progress, Source, Sources, Status,
};

const REPO: &str = "org/tiny-encoder";
const PINNED: &str = "0123456789abcdef0123456789abcdef01234567";
const CONFIG: &[u8] = br#"{"hidden": 4}"#;

fn weights() -> Vec<u8> {
    (0..5000u32)
        .flat_map(|i| (i * 7919).to_le_bytes())
        .collect()
}

fn spec() -> ModelSpec {
    ModelSpec {
        folder: "tiny-encoder".into(),
        assembly: Assembly::WheelFolder {
            package: Package {
                name: "tiny-encoder".into(),
                version: "1.0".into(),
            },
            folder: "tiny/data".into(),
        },
        key_files: vec![KeyFile {
            path: "weights.bin".into(),
            sha256: sha256(&weights()),
        }],
        hub: Some(HubRepo {
            repo: REPO.into(),
            revision: PINNED.into(),
            files: vec![
                "config.json".into(),
                "sub/weights.bin".into(),
                "weights.bin".into(),
            ],
        }),
    }
}

fn tiny_files() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("config.json", CONFIG.to_vec()),
        ("sub/weights.bin", b"nested".to_vec()),
        ("weights.bin", weights()),
    ]
}

/// Sources that can reach no pip: a pip that always fails.
fn sources(source: Source, cache: &Path) -> Sources {
    Sources {
        source,
        from: None,
        pip: Pip::new("false"),
        hub: HubSettings::new(cache.to_path_buf()),
    }
}

fn offline(mut sources: Sources) -> Sources {
    sources.hub.offline = true;
    sources
}

fn quiet(_: String) {}

/// A temporary folder with the paths of a Hub cache and a pack inside it.
fn dirs() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let root = tempfile::tempdir().unwrap();
    let cache = root.path().join("hub");
    let pack = root.path().join("pack");
    (root, cache, pack)
}

fn obtain(pack: &Path, sources: &Sources) -> Result<FetchOutcome, ModelsError> {
    obtain_model(pack, &spec(), sources, &Progress::hidden(), &quiet)
}

fn no_staging_left(pack: &Path) {
    if let Ok(entries) = fs::read_dir(pack) {
        for entry in entries {
            let name = entry.unwrap().file_name();
            assert!(
                !name.to_string_lossy().starts_with(".staging"),
                "{name:?} left in the pack"
            );
        }
    }
}

#[test]
fn a_cached_snapshot_is_linked_offline_without_pip_or_copies() {
    let (_root, cache, pack) = dirs();
    let owned: Vec<(&str, &[u8])> = tiny_files()
        .iter()
        .map(|(n, b)| (*n, b.clone().leak() as &[u8]))
        .collect();
    // Another revision than the pinned one: accepted, since its files match.
    let snapshot = cache_snapshot(
        &cache,
        REPO,
        "feedface00000000000000000000000000000000",
        &owned,
    );
    let before = files_under(&cache);

    let outcome = obtain(&pack, &offline(sources(Source::Auto, &cache))).unwrap();
    let FetchOutcome::Linked { from, downloaded } = outcome else {
        panic!("expected a link, got {outcome:?}");
    };
    assert!(!downloaded);
    assert_eq!(from.path, snapshot);
    assert_eq!(
        from.revision.as_deref(),
        Some("feedface00000000000000000000000000000000")
    );

    let model = pack.join("tiny-encoder");
    let weights_link = model.join("weights.bin");
    assert!(weights_link.is_symlink(), "weights copied, not linked");
    let target = fs::read_link(&weights_link).unwrap();
    assert!(
        target.starts_with(cache.join("models--org--tiny-encoder/blobs")),
        "{target:?}"
    );
    assert_eq!(fs::read(model.join("sub/weights.bin")).unwrap(), b"nested");
    // The stamp is in the pack; the cache is exactly as it was.
    assert!(model.join(".mapvlm-verified.json").is_file());
    assert_eq!(files_under(&cache), before);
    assert_eq!(verify_model(&pack, &spec(), |_| {}).unwrap(), Status::Ok);
    no_staging_left(&pack);

    let again = obtain(&pack, &offline(sources(Source::Auto, &cache))).unwrap();
    assert_eq!(again, FetchOutcome::AlreadyVerified);
}

#[test]
fn a_snapshot_of_plain_files_is_accepted_too() {
    let root = tempfile::tempdir().unwrap();
    let cache = root.path().join("hub");
    let snapshot = cache
        .join("models--org--tiny-encoder/snapshots")
        .join(PINNED);
    for (name, bytes) in tiny_files() {
        fs::create_dir_all(snapshot.join(name).parent().unwrap()).unwrap();
        fs::write(snapshot.join(name), bytes).unwrap();
    }
    let pack = root.path().join("pack");
    let outcome = obtain(&pack, &offline(sources(Source::Hf, &cache))).unwrap();
    assert!(
        matches!(
            outcome,
            FetchOutcome::Linked {
                downloaded: false,
                ..
            }
        ),
        "{outcome:?}"
    );
    assert_eq!(
        fs::read_link(pack.join("tiny-encoder/weights.bin")).unwrap(),
        snapshot.join("weights.bin")
    );
}

#[test]
fn a_truncated_or_missing_cached_file_is_refused_and_nothing_is_installed() {
    let root = tempfile::tempdir().unwrap();
    let cache = root.path().join("hub");
    let mut files = tiny_files();
    files[2].1.truncate(100);
    let owned: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (*n, b.as_slice())).collect();
    cache_snapshot(&cache, REPO, PINNED, &owned);
    let lacking: Vec<(&str, &[u8])> = owned[..2].to_vec();
    cache_snapshot(
        &cache,
        REPO,
        "aaaa000000000000000000000000000000000000",
        &lacking,
    );
    let pack = root.path().join("pack");

    let reports = std::sync::Mutex::new(Vec::new());
    let report = |line: String| reports.lock().unwrap().push(line);
    let err = obtain_model(
        &pack,
        &spec(),
        &offline(sources(Source::Hf, &cache)),
        &Progress::hidden(),
        &report,
    )
    .unwrap_err();
    assert!(matches!(err, ModelsError::HubOffline { .. }), "{err}");
    let reports = reports.into_inner().unwrap();
    assert_eq!(reports.len(), 1, "{reports:?}");
    assert!(
        reports[0].contains("snapshot 0123456789ab: weights.bin is truncated"),
        "{}",
        reports[0]
    );
    assert!(
        reports[0].contains("snapshot aaaa00000000: weights.bin is missing"),
        "{}",
        reports[0]
    );
    assert!(!pack.join("tiny-encoder").exists());
    no_staging_left(&pack);

    // With auto, pip is tried next, and its failure is what is reported.
    let err = obtain(&pack, &offline(sources(Source::Auto, &cache))).unwrap_err();
    assert!(
        matches!(
            err,
            ModelsError::PipFailed { .. } | ModelsError::PipNotFound { .. }
        ),
        "{err}"
    );
    assert!(!pack.join("tiny-encoder").exists());
}

#[test]
fn a_model_without_a_hub_source_is_refused_by_source_hf() {
    let root = tempfile::tempdir().unwrap();
    let mut spec = spec();
    spec.hub = None;
    let err = obtain_model(
        &root.path().join("pack"),
        &spec,
        &sources(Source::Hf, root.path()),
        &Progress::hidden(),
        &quiet,
    )
    .unwrap_err();
    assert!(err.to_string().contains("--source pip"), "{err}");
}

#[test]
fn from_dir_links_a_folder_the_user_names() {
    let root = tempfile::tempdir().unwrap();
    let mine = root.path().join("mine/tiny-encoder");
    fs::create_dir_all(&mine).unwrap();
    fs::write(mine.join("weights.bin"), weights()).unwrap();
    fs::write(mine.join("config.json"), CONFIG).unwrap();
    let pack = root.path().join("pack");
    let mut srcs = offline(sources(Source::Pip, &root.path().join("no-cache")));
    srcs.from = Some(root.path().join("mine"));
    let outcome = obtain(&pack, &srcs).unwrap();
    assert!(
        matches!(outcome, FetchOutcome::Linked { .. }),
        "{outcome:?}"
    );
    assert_eq!(
        fs::read_link(pack.join("tiny-encoder/weights.bin")).unwrap(),
        mine.join("weights.bin")
    );
    assert_eq!(verify_model(&pack, &spec(), |_| {}).unwrap(), Status::Ok);
}

fn served() -> ServedRepo {
    ServedRepo::new(
        PINNED,
        tiny_files()
            .into_iter()
            .map(|(n, b)| (n, Content::Bytes(b)))
            .collect(),
    )
}

fn online(cache: &Path, server: &wiremock::MockServer) -> Sources {
    let mut srcs = sources(Source::Hf, cache);
    srcs.hub.endpoint = Some(server.uri());
    srcs.hub.chunk_size = 4096;
    srcs.hub.parallel = 1;
    srcs
}

/// Runs `obtain` off the async test's threads (it starts its own runtime).
async fn obtain_async(pack: &Path, sources: Sources) -> Result<FetchOutcome, ModelsError> {
    let pack = pack.to_path_buf();
    tokio::task::spawn_blocking(move || obtain(&pack, &sources))
        .await
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_hub_downloads_into_the_cache_layout_verified_and_linked() {
    let repo = served();
    let server = serve(&repo).await;
    let (_root, cache, pack) = dirs();

    let outcome = obtain_async(&pack, online(&cache, &server)).await.unwrap();
    assert!(
        matches!(
            outcome,
            FetchOutcome::Linked {
                downloaded: true,
                ..
            }
        ),
        "{outcome:?}"
    );
    let repo_dir = cache.join("models--org--tiny-encoder");
    let snapshot = repo_dir.join("snapshots").join(PINNED);
    for (name, bytes) in tiny_files() {
        let entry = snapshot.join(name);
        assert!(entry.is_symlink(), "{name} is not a link to a blob");
        let blob = fs::canonicalize(&entry).unwrap();
        assert_eq!(blob, repo_dir.join("blobs").join(sha256(&bytes)));
        assert_eq!(fs::read(&blob).unwrap(), bytes);
    }
    assert_eq!(
        fs::read_to_string(repo_dir.join("refs").join(PINNED)).unwrap(),
        PINNED
    );
    assert!(
        files_under(&repo_dir.join("blobs"))
            .iter()
            .all(|f| !f.ends_with(".sync.part")),
        "a partial download was left"
    );
    assert_eq!(verify_model(&pack, &spec(), |_| {}).unwrap(), Status::Ok);
    // 20 kB in 4 kB chunks, sequentially.
    assert_eq!(
        ranges_of(&repo, "weights.bin"),
        [
            "bytes=0-0",
            "bytes=0-4095",
            "bytes=12288-16383",
            "bytes=16384-20000",
            "bytes=4096-8191",
            "bytes=8192-12287"
        ]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refusals_of_the_hub_are_one_line_each_and_leave_nothing() {
    for (status, words) in [
        (401, "gated or private"),
        (404, "no such repository"),
        (429, "rate-limiting"),
    ] {
        let server = wiremock::MockServer::start().await;
        wiremock::Mock::given(wiremock::matchers::any())
            .respond_with(wiremock::ResponseTemplate::new(status))
            .mount(&server)
            .await;
        let (_root, cache, pack) = dirs();
        let err = obtain_async(&pack, online(&cache, &server))
            .await
            .unwrap_err();
        let line = err.to_string();
        assert!(
            line.contains(&format!("HTTP {status}")) && line.contains(words),
            "{line}"
        );
        assert!(!line.contains('\n'), "{line}");
        assert!(!pack.join("tiny-encoder").exists());
        no_staging_left(&pack);
        let blobs = cache.join("models--org--tiny-encoder/blobs");
        let left: Vec<_> = files_under_or_empty(&blobs)
            .into_iter()
            .filter(|f| !f.ends_with(".lock"))
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}

/// The ranges asked of `file`, sorted as text.
fn ranges_of(repo: &ServedRepo, file: &str) -> Vec<String> {
    let mut ranges: Vec<_> = repo
        .ranges
        .lock()
        .unwrap()
        .iter()
        .filter(|(f, _)| f == file)
        .map(|(_, r)| r.clone())
        .collect();
    ranges.sort();
    ranges
}

fn files_under_or_empty(dir: &Path) -> Vec<String> {
    if dir.is_dir() {
        files_under(dir)
    } else {
        Vec::new()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_revision_served_is_refused_and_removed() {
    let mut repo = served();
    repo.commit = "9999999999999999999999999999999999999999".into();
    let server = serve(&repo).await;
    let (_root, cache, pack) = dirs();
    let err = obtain_async(&pack, online(&cache, &server))
        .await
        .unwrap_err();
    assert!(matches!(err, ModelsError::RevisionMismatch { .. }), "{err}");
    assert!(
        err.to_string().contains("not the pinned 0123456789abcdef"),
        "{err}"
    );
    let snapshot =
        cache.join("models--org--tiny-encoder/snapshots/9999999999999999999999999999999999999999");
    assert!(files_under_or_empty(&snapshot).is_empty());
    assert!(!pack.join("tiny-encoder").exists());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tampered_file_from_the_hub_is_refused_and_removed_from_the_cache() {
    let mut files = tiny_files();
    files[2].1[10] ^= 1;
    let repo = ServedRepo::new(
        PINNED,
        files
            .into_iter()
            .map(|(n, b)| (n, Content::Bytes(b)))
            .collect(),
    );
    let server = serve(&repo).await;
    let (_root, cache, pack) = dirs();
    let err = obtain_async(&pack, online(&cache, &server))
        .await
        .unwrap_err();
    assert!(matches!(err, ModelsError::ChecksumMismatch { .. }), "{err}");
    let repo_dir = cache.join("models--org--tiny-encoder");
    assert!(!repo_dir
        .join("snapshots")
        .join(PINNED)
        .join("weights.bin")
        .exists());
    let blobs: Vec<_> = files_under(&repo_dir.join("blobs"))
        .into_iter()
        .filter(|f| !f.ends_with(".lock"))
        .collect();
    assert_eq!(blobs.len(), 2, "the tampered blob stayed: {blobs:?}");
    assert!(!pack.join("tiny-encoder").exists());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_interrupted_download_resumes_where_it_stopped() {
    let repo = served();
    let server = wiremock::MockServer::start().await;
    // The third chunk of the weights fails once, late: the download asks for
    // all five chunks at once, so the first two are in and committed before
    // the failure ends it, in whatever order the runtime starts the chunks.
    wiremock::Mock::given(wiremock::matchers::header("range", "bytes=8192-12287"))
        .respond_with(
            wiremock::ResponseTemplate::new(500).set_delay(std::time::Duration::from_secs(2)),
        )
        .up_to_n_times(1)
        .with_priority(1)
        .mount(&server)
        .await;
    wiremock::Mock::given(wiremock::matchers::path_regex("^/.+/resolve/.+"))
        .respond_with(repo.clone())
        .with_priority(5)
        .mount(&server)
        .await;
    let (_root, cache, pack) = dirs();
    let mut parallel = online(&cache, &server);
    parallel.hub.parallel = 5;

    let err = obtain_async(&pack, parallel).await.unwrap_err();
    assert!(matches!(err, ModelsError::HubFailed { .. }), "{err}");
    assert!(!pack.join("tiny-encoder").exists());
    let blobs = cache.join("models--org--tiny-encoder/blobs");
    let partial = files_under(&blobs);
    assert!(
        partial.iter().any(|f| f.ends_with(".sync.part")),
        "{partial:?}"
    );
    assert!(
        !partial.contains(&sha256(&weights())),
        "an incomplete blob was published"
    );

    repo.ranges.lock().unwrap().clear();
    obtain_async(&pack, online(&cache, &server)).await.unwrap();
    // The first two chunks were committed before the failure: not asked again.
    assert_eq!(
        ranges_of(&repo, "weights.bin"),
        [
            "bytes=0-0",
            "bytes=12288-16383",
            "bytes=16384-20000",
            "bytes=8192-12287"
        ]
    );
    assert_eq!(verify_model(&pack, &spec(), |_| {}).unwrap(), Status::Ok);
}
