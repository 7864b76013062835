//! `mapvlm corrupt`: a dataset's plans or an items file, plus seeded
//! corruptions of every plan, written as an items file (`annotate.md` §2)
//! that `score --pairs` reads as it is.

use std::path::{Component, Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use clap::Args;

use crate::agents::Approach;
use crate::corrupt::{Corrupter, Kind, Language, Vocabulary};
use crate::dataset::{open_pairs, Dataset, Pair};
use crate::nlp::en::EnPipeline;

/// Arguments of `mapvlm corrupt`.
#[derive(Debug, Args)]
#[command(after_long_help = VOCABULARY_HELP, after_help = VOCABULARY_HELP)]
pub struct CorruptArgs {
    /// A dataset folder (or its tasks.jsonl): its published plans of --approach are the items.
    #[arg(long, value_name = "DIR", required_unless_present = "items")]
    pub dataset: Option<PathBuf>,
    /// Whose published plans to corrupt [default: multi-image].
    #[arg(long, value_name = "NAME", conflicts_with = "items")]
    pub approach: Option<Approach>,
    /// An items (pairs) file whose `pred` plans to corrupt.
    #[arg(long, value_name = "FILE", conflicts_with = "dataset")]
    pub items: Option<PathBuf>,
    /// The kinds, comma-separated [default: all eight].
    #[arg(long, value_name = "K,K,...", value_delimiter = ',')]
    pub kinds: Vec<Kind>,
    /// The seed of every draw; with the item id and the kind it fixes the corruption.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 0
    )]
    pub seed: u64,
    /// The items file to write (every original item, then its corruptions).
    /// Without it, --blind makes a blind copy of --items as it is.
    #[arg(long, value_name = "FILE", required_unless_present = "blind")]
    pub out: Option<PathBuf>,
    /// Also write a blind copy for annotators into this folder
    /// (DIR/items.jsonl: opaque ids and groups, no source or corruption,
    /// image paths relative to DIR), and its key (see --key).
    #[arg(long, value_name = "DIR")]
    pub blind: Option<PathBuf>,
    /// Where the key of the blind copy goes, which maps its ids back and is
    /// not for annotators [default: beside the full items, ITEMS.key.jsonl].
    #[arg(long, value_name = "FILE", requires = "blind")]
    pub key: Option<PathBuf>,
    /// A folder of vocabulary files adding to the built-in ones [default: the user folder below].
    #[arg(long, value_name = "DIR")]
    pub vocabulary: Option<PathBuf>,
    /// Model settings shared with the other model-backed commands.
    #[command(flatten)]
    pub models: super::ModelArgs,
}

/// Where the vocabularies are, for `--help`.
const VOCABULARY_HELP: &str = "\
Vocabularies: the swaps draw from four lists built into mapvlm (in the
repository: src/corrupt/vocab/objects.txt, places.txt, verbs.txt and
same.txt). Add words with files of the same names in
$XDG_CONFIG_HOME/mapvlm/corrupt/ (else ~/.config/mapvlm/corrupt/), or in the
folder of --vocabulary: objects.txt and places.txt hold one word a line,
verbs.txt one pair of actions a line (`pick up, put down`), same.txt one
group of words that name the same thing a line (`fridge, refrigerator`:
never swapped for each other); `#` starts a comment.

Steps that only move the agent (every verb one of walk, go, turn, move,
head, navigate, proceed, approach, return, step, face, come, rotate, travel,
continue, enter, back) are never repeated by duplicate nor swapped with each
other by reorder.

Blind copy: --blind DIR writes DIR/items.jsonl for annotators (opaque ids,
an opaque group per plan and its corruptions, no source or corruption) and a
key (--key, default ITEMS.key.jsonl beside the full items) that only the
researcher keeps; `mapvlm agree --key` maps judgements back.";

/// Runs `mapvlm corrupt`.
pub fn run(args: &CorruptArgs) -> anyhow::Result<ExitCode> {
    let Some(out) = &args.out else {
        return blind_only(args);
    };
    let kinds = requested_kinds(&args.kinds);
    let out_dir = output_dir(out)?;
    let (items, trials, problems) = read_items(args, &out_dir)?;
    for line in &problems {
        eprintln!(
            "mapvlm: {}",
            crate::sanitize::for_terminal(&line.to_string())
        );
    }
    if items.is_empty() {
        bail!(
            "{}: no item with a plan; nothing to corrupt",
            args.items
                .as_deref()
                .or(args.dataset.as_deref())
                .unwrap_or(Path::new("?"))
                .display()
        );
    }
    let vocabulary_dir = args
        .vocabulary
        .clone()
        .or_else(crate::corrupt::user_vocabulary_dir);
    let vocabulary = Vocabulary::load(vocabulary_dir.as_deref())?;
    let dir = crate::models::models_dir(args.models.models_dir.as_deref());
    super::models::ensure_pack(&dir, &super::say, &crate::models::Progress::stderr())?;
    if args.models.paper {
        super::models::ensure_paper_vectors(&dir, &super::say, &crate::models::Progress::stderr())?;
    }
    let (parser, vectors) = std::thread::scope(|s| {
        let parser = s.spawn(|| -> anyhow::Result<EnPipeline> {
            let path = crate::models::verified_model_path(&dir, crate::models::EN_CORE_WEB_SM)?;
            Ok(EnPipeline::load(&path)?)
        });
        let vectors = s.spawn(|| super::load_vectors(&args.models, &dir));
        (super::joined(parser), super::joined(vectors))
    });
    let (parser, vectors) = (parser?, vectors?);
    let corrupter = Corrupter {
        language: Language {
            parser: &parser,
            vectors: &vectors,
        },
        vocabulary: &vocabulary,
        seed: args.seed,
    };
    let (written, skipped) = corrupter.corrupt_items(&items, &trials, &kinds);
    for s in &skipped {
        eprintln!(
            "mapvlm: {}; skipped",
            crate::sanitize::for_terminal(&s.to_string())
        );
    }
    write_items(out, &written)?;
    eprintln!(
        "mapvlm: wrote {} items to {}: {} originals, {} corruptions, {} skipped",
        written.len(),
        out.display(),
        items.len(),
        written.len() - items.len(),
        skipped.len()
    );
    let mut blind_problems = Vec::new();
    if let Some(dir) = &args.blind {
        write_blind(
            &written,
            &out_dir,
            out,
            dir,
            args.key.as_deref(),
            &mut blind_problems,
        )?;
    }
    for line in &blind_problems {
        eprintln!("mapvlm: {}", crate::sanitize::for_terminal(line));
    }
    Ok(if problems.is_empty() && blind_problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Writes items as JSON Lines, atomically.
fn write_items(path: &Path, items: &[Pair]) -> anyhow::Result<()> {
    let mut text = String::new();
    for item in items {
        text.push_str(&serde_json::to_string(item)?);
        text.push('\n');
    }
    crate::fsutil::write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// `corrupt --items FILE --blind DIR` without `--out`: the blind copy of an
/// existing items file, nothing corrupted.
fn blind_only(args: &CorruptArgs) -> anyhow::Result<ExitCode> {
    let Some(path) = &args.items else {
        bail!("--blind without --out blinds an existing items file: give --items FILE (or --out FILE to corrupt first)");
    };
    let Some(dir) = &args.blind else {
        bail!("give --out FILE");
    };
    let base = std::path::absolute(path.parent().unwrap_or(Path::new("")))
        .with_context(|| format!("cannot resolve the folder of {}", path.display()))?;
    let mut problems = Vec::new();
    let mut items = Vec::new();
    for line in open_pairs(path)? {
        match line {
            Ok(item) => items.push(item),
            Err(e) => problems.push(format!("{e}; that line was skipped")),
        }
    }
    if items.is_empty() {
        bail!("{}: no item to blind", path.display());
    }
    write_blind(&items, &base, path, dir, args.key.as_deref(), &mut problems)?;
    for line in &problems {
        eprintln!("mapvlm: {line}");
    }
    Ok(if problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Writes the blind copy of `items` (whose image paths are relative to
/// `items_dir`) as `DIR/items.jsonl`, image paths relative to DIR, and its
/// key to `key` (default: beside `items_file`, `NAME.key.jsonl`).
fn write_blind(
    items: &[Pair],
    items_dir: &Path,
    items_file: &Path,
    dir: &Path,
    key: Option<&Path>,
    problems: &mut Vec<String>,
) -> anyhow::Result<()> {
    let key_file = match key {
        Some(k) => k.to_path_buf(),
        None => {
            let stem = items_file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "items".into());
            items_file.with_file_name(format!("{stem}.key.jsonl"))
        }
    };
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let dir_abs = dir
        .canonicalize()
        .with_context(|| format!("cannot resolve {}", dir.display()))?;
    let key_folder = key_file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if key_folder
        .canonicalize()
        .is_ok_and(|folder| folder.starts_with(&dir_abs))
    {
        bail!(
            "{}: the key would be inside the blind folder {}, which annotators get; write it elsewhere with --key FILE",
            key_file.display(),
            dir.display()
        );
    }
    let blinded = crate::corrupt::blind::blind(items, &crate::corrupt::blind::fresh_secret())?;
    let mut copies = blinded.items;
    for copy in &mut copies {
        copy.image = copy
            .image
            .take()
            .map(|image| image_for(&items_dir.join(image), &dir_abs, problems));
    }
    let blind_file = dir.join("items.jsonl");
    write_items(&blind_file, &copies)?;
    let mut text = String::new();
    for entry in &blinded.key {
        text.push_str(&serde_json::to_string(entry)?);
        text.push('\n');
    }
    crate::fsutil::write_atomic(&key_file, text.as_bytes())?;
    eprintln!(
        "mapvlm: wrote the blind copy {} ({} items, for annotators) and its key {} (not for annotators)",
        blind_file.display(),
        copies.len(),
        key_file.display()
    );
    Ok(())
}

/// The kinds asked for, each once, in the order given; all eight by default.
fn requested_kinds(asked: &[Kind]) -> Vec<Kind> {
    if asked.is_empty() {
        return Kind::ALL.to_vec();
    }
    let mut kinds = Vec::new();
    for &k in asked {
        if !kinds.contains(&k) {
            kinds.push(k);
        }
    }
    kinds
}

/// The folder of the output file, absolute, once the file is known to be
/// writable (checked before any work).
fn output_dir(out: &Path) -> anyhow::Result<PathBuf> {
    crate::fsutil::check_writable(out).context("--out")?;
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    parent
        .canonicalize()
        .with_context(|| format!("cannot resolve the folder of {}", out.display()))
}

/// The items and their trials (`None` for an items file, which has none).
type ItemsRead = (Vec<Pair>, Vec<Option<String>>, Vec<String>);

/// The items to corrupt, with their image paths rewritten relative to
/// `out_dir`, their trials, and the lines and tasks that could not be used.
fn read_items(args: &CorruptArgs, out_dir: &Path) -> anyhow::Result<ItemsRead> {
    let mut problems = Vec::new();
    let mut items = Vec::new();
    let mut trials = Vec::new();
    if let Some(path) = &args.items {
        let base = path.parent().unwrap_or(Path::new(""));
        for line in open_pairs(path)? {
            match line {
                Ok(mut item) => {
                    item.image = item
                        .image
                        .map(|image| image_for(&base.join(image), out_dir, &mut problems));
                    items.push(item);
                    trials.push(None);
                }
                Err(e) => problems.push(format!("{e}; that line was skipped")),
            }
        }
    } else if let Some(dir) = &args.dataset {
        let approach = args.approach.unwrap_or(Approach::MultiImage);
        let (dataset, errors) = Dataset::load(dir)?;
        problems.extend(errors.iter().map(|e| format!("{e}; that task was skipped")));
        for task in &dataset.tasks {
            let Some(plan) = task.plans.get(approach.dataset_field()) else {
                problems.push(format!(
                    "{}: task {} has no {approach} plan (field `{}`); skipped",
                    dir.display(),
                    task.id,
                    approach.dataset_field()
                ));
                continue;
            };
            let mut item = Pair::new(&task.id, task.ground_truth.clone(), plan.clone());
            item.task = Some(task.task.clone());
            item.image = task
                .image
                .as_deref()
                .map(|image| image_for(image, out_dir, &mut problems));
            items.push(item);
            trials.push(task.trial.clone());
        }
    }
    Ok((items, trials, problems))
}

/// How the output file refers to `image`: relative to the output's folder
/// when the two share more than the root, else absolute. A missing image is
/// reported (and kept, so the item still names it).
fn image_for(image: &Path, out_dir: &Path, problems: &mut Vec<String>) -> String {
    let resolved = match image.canonicalize() {
        Ok(p) => p,
        Err(e) => {
            problems.push(format!("image {}: {e}", image.display()));
            std::path::absolute(image).unwrap_or_else(|_| image.to_path_buf())
        }
    };
    relative_to(&resolved, out_dir)
        .unwrap_or(resolved)
        .to_string_lossy()
        .into_owned()
}

/// `path` relative to the folder `base` (both absolute and normalised), when
/// they share a folder below the root.
fn relative_to(path: &Path, base: &Path) -> Option<PathBuf> {
    let (p, b): (Vec<Component>, Vec<Component>) =
        (path.components().collect(), base.components().collect());
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let below_root = p
        .iter()
        .take(common)
        .filter(|c| matches!(c, Component::Normal(_)))
        .count();
    if below_root == 0 {
        return None;
    }
    let mut out: PathBuf = b[common..].iter().map(|_| Component::ParentDir).collect();
    out.extend(&p[common..]);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_are_written_relative_to_the_output_when_they_share_a_folder() {
        let rel = |p: &str, b: &str| relative_to(Path::new(p), Path::new(b));
        assert_eq!(
            rel("/work/shared/data/images/7.jpg", "/work/out"),
            Some(PathBuf::from("../shared/data/images/7.jpg"))
        );
        assert_eq!(
            rel("/work/a/7.jpg", "/work/a"),
            Some(PathBuf::from("7.jpg"))
        );
        assert_eq!(rel("/data/7.jpg", "/tmp/out"), None);
    }

    #[test]
    fn kinds_default_to_all_and_are_kept_once() {
        assert_eq!(requested_kinds(&[]), Kind::ALL);
        assert_eq!(
            requested_kinds(&[Kind::Drop, Kind::Reorder, Kind::Drop]),
            [Kind::Drop, Kind::Reorder]
        );
    }
}
