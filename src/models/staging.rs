//! The staged install of a model folder: a staging folder inside the pack
//! that a fetch or a link fills, then moves into place in one rename (the
//! folder it replaces put aside, and restored if the move fails).

use std::fs;
use std::path::{Path, PathBuf};

use super::ModelsError;

/// A staging folder inside the pack, removed with everything in it when
/// dropped.
pub(crate) struct Staging {
    pub(crate) path: PathBuf,
}

impl Staging {
    pub(crate) fn create(models_dir: &Path, folder: &str) -> Result<Self, ModelsError> {
        let path = models_dir.join(format!(".staging-{folder}-{}", std::process::id()));
        fs::create_dir(&path).map_err(ModelsError::io("create", &path))?;
        Ok(Self { path })
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        // Best effort: the folder holds only what this fetch downloaded.
        let _ = fs::remove_dir_all(&self.path);
    }
}

/// Removes staging folders of `folder` left by an interrupted fetch.
pub(crate) fn remove_stale_staging(models_dir: &Path, folder: &str) -> Result<(), ModelsError> {
    let prefix = format!(".staging-{folder}-");
    let entries = fs::read_dir(models_dir).map_err(ModelsError::io("list", models_dir))?;
    for entry in entries.flatten() {
        if entry.file_name().to_string_lossy().starts_with(&prefix) {
            let path = entry.path();
            fs::remove_dir_all(&path).map_err(ModelsError::io("remove", &path))?;
        }
    }
    Ok(())
}

/// Moves `assembled` to `target`, putting an earlier `target` aside in
/// `previous` (restored if the move fails).
pub(crate) fn install(assembled: &Path, target: &Path, previous: &Path) -> Result<(), ModelsError> {
    let replacing = target.exists();
    if replacing {
        fs::rename(target, previous).map_err(ModelsError::io("move aside", target))?;
    }
    if let Err(source) = fs::rename(assembled, target) {
        if replacing {
            let _ = fs::rename(previous, target);
        }
        return Err(ModelsError::Io {
            action: "move into place",
            path: target.to_path_buf(),
            source,
        });
    }
    Ok(())
}
