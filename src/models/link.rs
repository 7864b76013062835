//! Installing a model folder that points at files kept elsewhere (a Hugging
//! Face cache snapshot, or a folder given with `--from`): the pack gets a
//! folder of symbolic links to the real files (their blobs, for a cache), so
//! no weights are copied, and the verification stamp lives in the pack
//! folder, never beside the files it points at.

use std::fs;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::staging::{install, remove_stale_staging, Staging};
use super::verify::write_stamp;
use super::{ModelSpec, ModelsError};

/// Name of the file recording, inside a linked model folder, where its files are.
pub(crate) const SOURCE_FILE: &str = ".mapvlm-source.json";

/// Where a linked model's files come from, recorded in [`SOURCE_FILE`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LinkedFrom {
    /// `hf-cache` or `folder`.
    pub kind: &'static str,
    /// The folder linked to.
    pub path: PathBuf,
    /// The Hub repository, for a cache snapshot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub repo: Option<String>,
    /// The snapshot's revision, for a cache snapshot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub revision: Option<String>,
}

/// Makes `models_dir/spec.folder` a folder of links to every file under
/// `source` (already verified by the caller), stamps it, and moves it into
/// place with one rename; an earlier folder is replaced only once the new
/// one is complete.
pub(crate) fn install_links(
    models_dir: &Path,
    spec: &ModelSpec,
    source: &Path,
    from: &LinkedFrom,
) -> Result<(), ModelsError> {
    fs::create_dir_all(models_dir).map_err(ModelsError::io("create", models_dir))?;
    remove_stale_staging(models_dir, &spec.folder)?;
    let staging = Staging::create(models_dir, &spec.folder)?;
    let out = staging.path.join("model");
    link_tree(source, &out)?;
    write_stamp(&out, &spec.key_files)?;
    let record = serde_json::to_vec_pretty(from).map_err(|e| ModelsError::Io {
        action: "encode the source record for",
        path: out.clone(),
        source: e.into(),
    })?;
    let record_path = out.join(SOURCE_FILE);
    fs::write(&record_path, record).map_err(ModelsError::io("write", &record_path))?;
    let target = models_dir.join(&spec.folder);
    install(&out, &target, &staging.path.join("previous"))
}

/// Recreates the tree of `source` under `out`, each file a link to the file
/// it resolves to (so a cache's snapshot link is followed to its blob).
/// Files of ours (`.mapvlm-*`) are left out.
fn link_tree(source: &Path, out: &Path) -> Result<(), ModelsError> {
    fs::create_dir_all(out).map_err(ModelsError::io("create", out))?;
    let entries = fs::read_dir(source).map_err(ModelsError::io("list", source))?;
    for entry in entries {
        let entry = entry.map_err(ModelsError::io("list", source))?;
        let name = entry.file_name();
        if name.to_string_lossy().starts_with(".mapvlm-") {
            continue;
        }
        let path = entry.path();
        let dest = out.join(&name);
        if path.is_dir() {
            link_tree(&path, &dest)?;
        } else {
            let real = fs::canonicalize(&path).map_err(ModelsError::io("resolve", &path))?;
            link_file(&real, &dest)?;
        }
    }
    Ok(())
}

#[cfg(unix)]
fn link_file(real: &Path, dest: &Path) -> Result<(), ModelsError> {
    std::os::unix::fs::symlink(real, dest).map_err(ModelsError::io("link", dest))
}

/// Where symbolic links need privileges, a hard link (same volume) still
/// avoids a copy.
#[cfg(not(unix))]
fn link_file(real: &Path, dest: &Path) -> Result<(), ModelsError> {
    fs::hard_link(real, dest).map_err(ModelsError::io("link", dest))
}
