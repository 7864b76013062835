//! The acceptance of reuse before download, as a user runs it: with pip
//! unavailable and `HF_HUB_OFFLINE=1`, a Hugging Face cache holding
//! all-mpnet-base-v2 (snapshot, refs) and the other two models in the pack,
//! `models fetch` installs without downloading, `models verify` passes and
//! `score` works; then `models fetch --source hf` from a local server that
//! speaks the Hub's download protocol lands the real files in the cache
//! layout, verified. The shared pack is only read.

use crate::hub_support;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use hub_support::{link_into_snapshot, serve, Content, HubRepo};
use mapvlm::models;

fn shared_pack() -> PathBuf {
    let dir = models::models_dir(None);
    assert!(
        dir.join(models::MPNET).is_dir(),
        "no model pack in {}: run ./scripts/test (it fetches the pack)",
        dir.display()
    );
    dir
}

fn mpnet_spec() -> models::ModelSpec {
    models::default_pack()
        .into_iter()
        .find(|s| s.folder == models::MPNET)
        .unwrap()
}

/// Recreates `source` under `dest` as real folders of symbolic links, so
/// that nothing written in `dest` (stamps) reaches the shared pack.
fn mirror_as_links(source: &Path, dest: &Path) {
    fs::create_dir_all(dest).unwrap();
    for entry in fs::read_dir(source).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap();
        if name.to_string_lossy().starts_with(".mapvlm-") {
            continue;
        }
        if path.is_dir() {
            mirror_as_links(&path, &dest.join(name));
        } else {
            std::os::unix::fs::symlink(&path, dest.join(name)).unwrap();
        }
    }
}

/// A pack holding the spaCy pipeline and GloVe (as links to the shared pack).
fn pack_with_the_other_two(root: &Path) -> PathBuf {
    let shared = shared_pack();
    let pack = root.join("pack");
    for folder in [models::EN_CORE_WEB_SM, models::GLOVE_6B_50D] {
        mirror_as_links(&shared.join(folder), &pack.join(folder));
    }
    pack
}

/// A Hugging Face home whose cache holds all-mpnet-base-v2 as
/// sentence-transformers leaves it: blobs named by SHA-256 (here links to
/// the shared pack's files), snapshot entries linking to them, refs/main.
fn hf_home_with_mpnet(root: &Path) -> PathBuf {
    let shared = shared_pack().join(models::MPNET);
    let home = root.join("hf");
    let repo = home.join("hub/models--sentence-transformers--all-mpnet-base-v2");
    let revision = "e8c3b32edf5434bc2275fc9bab85f82640a19130";
    let snapshot = repo.join("snapshots").join(revision);
    fs::create_dir_all(repo.join("blobs")).unwrap();
    fs::create_dir_all(repo.join("refs")).unwrap();
    fs::write(repo.join("refs/main"), revision).unwrap();
    for file in &mpnet_spec().hub.unwrap().files {
        let real = shared.join(file);
        let blob = repo
            .join("blobs")
            .join(models::sha256_file(&real, |_| {}).unwrap());
        if !blob.exists() {
            std::os::unix::fs::symlink(&real, &blob).unwrap();
        }
        link_into_snapshot(&snapshot, file, &blob);
    }
    home
}

fn mapvlm(args: &[&str], pack: &Path, hf_home: &Path, extra: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_mapvlm"));
    command
        .args(args)
        .env("MAPVLM_MODELS", pack)
        .env("HF_HOME", hf_home)
        // The embedding cache and anything else of the user's stays apart.
        .env("XDG_CACHE_HOME", hf_home.join("xdg-cache"))
        .env_remove("HF_HUB_CACHE")
        .env_remove("HF_TOKEN")
        .env_remove("HF_HUB_OFFLINE")
        // No pip: a command that always fails.
        .env("MAPVLM_PIP", "false");
    for (key, value) in extra {
        command.env(key, value);
    }
    command.output().unwrap()
}

fn text(out: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

#[test]
fn offline_without_pip_a_cached_mpnet_is_used_in_place() {
    let root = tempfile::tempdir().unwrap();
    let pack = pack_with_the_other_two(root.path());
    let home = hf_home_with_mpnet(root.path());
    // Any download attempt would go here and fail.
    let env = [
        ("HF_HUB_OFFLINE", "1"),
        ("HF_ENDPOINT", "http://127.0.0.1:9"),
    ];

    let fetch = mapvlm(&["models", "fetch"], &pack, &home, &env);
    assert!(fetch.status.success(), "{}", text(&fetch));
    let stdout = String::from_utf8_lossy(&fetch.stdout);
    assert!(
        stdout.contains("all-mpnet-base-v2: verified and linked from")
            && stdout.contains("models--sentence-transformers--all-mpnet-base-v2/snapshots/"),
        "{stdout}"
    );
    let weights = pack.join(models::MPNET).join("model.safetensors");
    assert!(weights.is_symlink(), "the weights were copied");

    let verify = mapvlm(&["models", "verify"], &pack, &home, &env);
    assert!(verify.status.success(), "{}", text(&verify));
    assert_eq!(
        String::from_utf8_lossy(&verify.stdout)
            .matches(": ok")
            .count(),
        3
    );

    let score = mapvlm(&["score", "--json"], &pack, &home, &env);
    assert!(score.status.success(), "{}", text(&score));
    let report: serde_json::Value = serde_json::from_slice(&score.stdout).unwrap();
    let pg2s = report["pg2s"]
        .as_f64()
        .unwrap_or_else(|| panic!("{report}"));
    assert!(
        (0.0..=1.0).contains(&pg2s) && report["s_plan"].is_number(),
        "{report}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn source_hf_downloads_the_real_files_into_the_cache_layout() {
    let shared = shared_pack().join(models::MPNET);
    let spec = mpnet_spec();
    let hub = spec.hub.clone().unwrap();
    let served = HubRepo::new(
        &hub.revision,
        hub.files
            .iter()
            .map(|f| (f.as_str(), Content::File(shared.join(f))))
            .collect(),
    );
    let server = serve(&served).await;
    let root = tempfile::tempdir().unwrap();
    let pack = pack_with_the_other_two(root.path());
    let home = root.path().join("hf");
    let endpoint = server.uri();
    let (pack2, home2) = (pack.clone(), home.clone());
    let fetch = tokio::task::spawn_blocking(move || {
        mapvlm(
            &["models", "fetch", "--source", "hf"],
            &pack2,
            &home2,
            &[("HF_ENDPOINT", endpoint.as_str())],
        )
    })
    .await
    .unwrap();
    assert!(fetch.status.success(), "{}", text(&fetch));
    assert!(
        String::from_utf8_lossy(&fetch.stdout)
            .contains("downloaded from the Hub, verified and linked"),
        "{}",
        text(&fetch)
    );
    let repo = home.join("hub/models--sentence-transformers--all-mpnet-base-v2");
    let weights = repo
        .join("snapshots")
        .join(&hub.revision)
        .join("model.safetensors");
    assert!(weights.is_symlink());
    let blob = fs::canonicalize(&weights).unwrap();
    assert_eq!(
        blob.parent().unwrap(),
        fs::canonicalize(repo.join("blobs")).unwrap()
    );
    assert_eq!(
        blob.file_name().unwrap().to_string_lossy(),
        spec.key_files[0].sha256
    );
    let verify = mapvlm(&["models", "verify"], &pack, &home, &[]);
    assert!(verify.status.success(), "{}", text(&verify));
}
