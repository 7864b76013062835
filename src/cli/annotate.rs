//! `mapvlm annotate`: the annotation screen, and `--export` of the current
//! judgements as CSV.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use crate::annotate::guidelines::Guidelines;
use crate::annotate::skips::{load_skips, skips_path};
use crate::annotate::{
    default_annotations_path, export_csv, AnnotationWriter, Annotations, Current,
};
use crate::dataset::open_pairs;
use crate::workbench::annotate::state::Setup;
use crate::workbench::annotate::{self, Options};
use crate::workbench::theme;

/// Arguments of `mapvlm annotate`.
#[derive(Debug, Args)]
pub struct AnnotateArgs {
    /// The items to judge (a pairs file; `task` and `image` are shown).
    #[arg(value_name = "ITEMS.jsonl", required_unless_present = "out")]
    pub items: Option<PathBuf>,
    /// Who is judging; the order of the items is drawn from this name (with
    /// --export: only this annotator's judgements).
    #[arg(long, value_name = "NAME", required_unless_present = "export")]
    pub annotator: Option<String>,
    /// Compare two plans of one task side by side instead of rating one.
    #[arg(long)]
    pub pairwise: bool,
    /// Show the ground-truth plan beside the plan judged.
    #[arg(long)]
    pub show_gt: bool,
    /// A text file with the rating scale (lines `1: …` to `5: …`) and what
    /// to judge; default: the built-in guidelines.
    #[arg(long, value_name = "FILE")]
    pub guidelines: Option<PathBuf>,
    /// The annotations file (default: beside the items, ITEMS.annotations.jsonl).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write the current judgements (superseded and withdrawn ones left
    /// out) of the annotations file as CSV, and exit. Steps are numbered
    /// from 1 there, as on screen (the annotations file's `step` counts
    /// from 0, as `corrupt`'s edits do); a cell a spreadsheet would run as
    /// a formula starts with `'`.
    #[arg(long, value_name = "FILE.csv")]
    pub export: Option<PathBuf>,
    /// The theme: dark, light, high-contrast or one of yours.
    #[arg(long)]
    pub theme: Option<String>,
    /// How the scene image is drawn.
    #[command(flatten)]
    pub graphics: super::graphics::GraphicsArgs,
}

fn warn(line: impl std::fmt::Display) {
    eprintln!(
        "mapvlm: {}",
        crate::sanitize::for_terminal(&line.to_string())
    );
}

/// Runs `mapvlm annotate`.
pub fn run(args: AnnotateArgs) -> anyhow::Result<ExitCode> {
    let annotations = match (&args.out, &args.items) {
        (Some(out), _) => out.clone(),
        (None, Some(items)) => default_annotations_path(items),
        (None, None) => bail!("give the items file or --out ANNOTATIONS.jsonl"),
    };
    if let Some(csv) = &args.export {
        return export(&annotations, csv, args.annotator.as_deref());
    }
    let (Some(items_path), Some(annotator)) = (&args.items, &args.annotator) else {
        bail!("give the items file and --annotator NAME");
    };
    let guidelines = match &args.guidelines {
        Some(path) => Guidelines::load(path)?,
        None => Guidelines::built_in(),
    };
    let (items, mut notices) = read_items(items_path)?;
    let existing = Annotations::load_or_empty(&annotations)?;
    for error in &existing.errors {
        warn(format!("{error} (the line is left as it is)"));
    }
    if let Some(first) = existing.errors.first() {
        notices.push(format!(
            "{} unreadable lines in the annotations file (first: line {}); they are left as they are",
            existing.errors.len(),
            first.line
        ));
    }
    let unknown = existing
        .lines
        .iter()
        .filter(|(_, j)| match &j.subject {
            crate::annotate::Subject::Item(id) => !items.iter().any(|i| &i.id == id),
            crate::annotate::Subject::Pair(l, r) => {
                !items.iter().any(|i| &i.id == l) || !items.iter().any(|i| &i.id == r)
            }
        })
        .count();
    if unknown > 0 {
        warn(format!(
            "{}: {unknown} judgements are of items not in {}; they are kept and not shown",
            annotations.display(),
            items_path.display()
        ));
        notices.push(format!(
            "{unknown} judgements in the annotations file are of items not in this file; they are kept"
        ));
    }
    let skips_file = skips_path(&annotations);
    let (skipped, skip_errors) = load_skips(&skips_file, annotator)?;
    for error in &skip_errors {
        warn(format!("{error} (the line is left as it is)"));
    }
    let (themes, problems) = theme::load_themes(theme::user_theme_dir().as_deref());
    problems.iter().for_each(warn);
    let chosen = match &args.theme {
        Some(name) => Some(theme::named(&themes, name)?),
        None => themes.iter().find(|t| t.name == "dark").or(themes.first()),
    };
    let theme = match chosen {
        Some(theme) if !theme::no_color_requested() => theme.clone(),
        _ => theme::Theme::no_color(),
    };
    super::require_terminal("annotate")?;
    let writer = AnnotationWriter::open(&annotations)?;
    let skips = AnnotationWriter::open(&skips_file)?;
    let items_dir = items_path
        .parent()
        .map_or_else(PathBuf::new, Path::to_path_buf);
    let outcome = annotate::run(Options {
        setup: Setup {
            items,
            items_dir,
            annotator: annotator.clone(),
            pairwise: args.pairwise,
            show_gt: args.show_gt,
            guidelines,
            existing,
            skipped,
            notices,
        },
        writer,
        skips,
        theme,
        graphics: args.graphics.request(None)?,
        query_timeout: args.graphics.timeout(),
    })?;
    for failure in &outcome.failures {
        warn(format!("not saved: {failure}"));
    }
    eprintln!(
        "mapvlm: {} of {} judged by {annotator}; judgements are in {}",
        outcome.judged,
        outcome.total,
        annotations.display()
    );
    Ok(if outcome.failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Reads the items, reporting bad lines on stderr; items without a plan are
/// left out. No item with a plan is an error.
fn read_items(path: &Path) -> anyhow::Result<(Vec<crate::dataset::Pair>, Vec<String>)> {
    let mut items = Vec::new();
    let mut notices = Vec::new();
    let mut bad = Vec::new();
    for line in open_pairs(path)? {
        match line {
            Ok(item) => items.push(item),
            Err(e) => {
                warn(format!("{e} (left out)"));
                bad.push(e.line);
            }
        }
    }
    if let Some(first) = bad.first() {
        // The reason is on stderr: serde's words may name the item's fields.
        notices.push(format!(
            "{} unreadable lines in the items file left out (first: line {first})",
            bad.len()
        ));
    }
    let before = items.len();
    items.retain(|i| !i.pred.is_empty());
    if items.is_empty() {
        bail!(
            "{}: no plans to judge (no line with a non-empty `pred`); give a pairs file of {{\"id\", \"gt\", \"pred\"}} lines",
            path.display()
        );
    }
    let folder = path.parent().unwrap_or(Path::new(""));
    let mut named = std::collections::BTreeSet::new();
    for item in &items {
        let Some(image) = &item.image else { continue };
        let outside = crate::dataset::resolve_inside(folder, image, false).is_err();
        if outside && named.insert(image.clone()) {
            let line = format!(
                "image {} (item {}) is outside the items' folder {}",
                crate::sanitize::for_terminal(image),
                crate::sanitize::for_terminal(&item.id),
                crate::sanitize::for_terminal(&folder.display().to_string())
            );
            warn(&line);
            notices.push(line);
        }
    }
    if items.len() < before {
        warn(format!(
            "{}: {} items have no plan (`pred` is empty) and are left out",
            path.display(),
            before - items.len()
        ));
    }
    Ok((items, notices))
}

/// `--export`: the current judgements as CSV, written atomically.
fn export(annotations: &Path, csv: &Path, annotator: Option<&str>) -> anyhow::Result<ExitCode> {
    let read = Annotations::load(annotations)
        .with_context(|| "nothing to export: the annotations file cannot be read")?;
    for error in &read.errors {
        warn(format!("{error} (left out of the export)"));
    }
    let current = Current::of(
        read.lines
            .iter()
            .map(|(_, j)| j)
            .filter(|j| annotator.is_none_or(|a| j.annotator == a)),
    );
    export_csv(&current, csv)?;
    eprintln!(
        "mapvlm: {} current judgements written to {}",
        current.judgements().len(),
        csv.display()
    );
    Ok(ExitCode::SUCCESS)
}
