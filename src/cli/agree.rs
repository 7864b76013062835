//! `mapvlm agree`: how far PG2S, S_plan, S_goal and KAS agree with people
//! (`annotate.md` §4), as a report, as JSON and as a figure.

use std::collections::{BTreeMap, HashMap};
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use clap::Args;

use crate::agree::scores::load_scores;
use crate::agree::table::{self, TableFormat};
use crate::agree::{analyse, json, plot, report, Aggregate, Judged, Settings};
use crate::annotate::{Annotations, Current, Preference};
use crate::dataset::{open_pairs, Pair};
use crate::stats::bootstrap::Bootstrap;

/// The most resamples or permutations one run may ask for.
const MAX_RESAMPLES: usize = 100_000;

/// Arguments of `mapvlm agree`.
#[derive(Debug, Args)]
pub struct AgreeArgs {
    /// The items file (a pairs file; `source` and `corruption` are read).
    #[arg(long, value_name = "FILE")]
    pub items: PathBuf,
    /// The scores of the items (`mapvlm score --pairs ITEMS --json`); without
    /// it the items are scored now, with the model pack.
    #[arg(long, value_name = "FILE")]
    pub scores: Option<PathBuf>,
    /// Annotations files, read in the order given (a later line supersedes an
    /// earlier one for the same item and annotator); without any, only the
    /// corruption table is reported.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub annotations: Vec<PathBuf>,
    /// The key of a blind copy (`corrupt --blind`): the annotations name the
    /// blind ids, which this file maps back to the ids of --items (the full
    /// items file, not the blind copy).
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Print one JSON document instead of the report.
    #[arg(long)]
    pub json: bool,
    /// Print the correlation and corruption tables as a paper takes them
    /// instead of the report: LaTeX (booktabs), CSV (RFC 4180) or Markdown.
    #[arg(long, value_enum, value_name = "FORMAT", conflicts_with = "json")]
    pub table: Option<TableFormat>,
    /// Also draw the figure, one panel per metric against the human score,
    /// into this file (.svg or .png).
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub plot: Option<PathBuf>,
    /// How an item's ratings make its human score: their mean, their median,
    /// or the mean of each annotator's z-scores. The human column of the
    /// corruption table compares these scores too.
    #[arg(long, value_enum, default_value_t = Aggregate::Mean, value_name = "HOW")]
    pub aggregate: Aggregate,
    /// The figure's size in pixels (the PNG's; the SVG's drawing units).
    #[arg(long, value_name = "WxH", default_value = "1200x900", value_parser = parse_size)]
    pub size: (u32, u32),
    /// The figure's resolution: its physical size is --size / DPI inches,
    /// and text, lines and points scale with DPI / 96.
    #[arg(long, value_name = "DPI", default_value_t = plot::DEFAULT_DPI)]
    pub dpi: u32,
    /// Keep only the current judgements made under the guidelines with this
    /// hash (the `guidelines` of each judgement line); by default all are
    /// pooled, with a warning when there is more than one hash.
    #[arg(long, value_name = "HASH")]
    pub guidelines_hash: Option<String>,
    /// Bootstrap resamples for the 95% intervals.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 1000,
        value_name = "N"
    )]
    pub bootstrap: usize,
    /// Permutations of the PG2S-against-KAS test.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 1000,
        value_name = "N"
    )]
    pub permutations: usize,
    /// Seed of the bootstrap and permutation streams (ChaCha20).
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 0,
        value_name = "N"
    )]
    pub seed: u64,
    /// Model settings, for scoring the items without --scores.
    #[command(flatten)]
    pub models: super::ModelArgs,
    /// The PG2S thresholds and weight: the items are scored with them, or
    /// the --scores file must have been made with them.
    #[command(flatten)]
    pub pg2s: super::Pg2sArgs,
}

/// Runs `mapvlm agree`.
pub fn run(args: &AgreeArgs) -> anyhow::Result<ExitCode> {
    for (flag, n) in [
        ("--bootstrap", args.bootstrap),
        ("--permutations", args.permutations),
    ] {
        if n > MAX_RESAMPLES {
            bail!("{flag} {n} is more than {MAX_RESAMPLES}; ask for fewer");
        }
        if n == 0 {
            bail!("{flag} 0: the intervals and the test need at least 1 (1000 by default); ask for some");
        }
    }
    let pg2s = args.pg2s.settings()?;
    let layout = plot::Layout::new(args.size, args.dpi, args.seed)?;
    let mut bad_lines = 0usize;
    let mut items = read_items(args, &mut bad_lines)?;
    let scores = match &args.scores {
        Some(path) => {
            let loaded = load_scores(path)?;
            loaded.check_settings(path, pg2s)?;
            for e in &loaded.errors {
                eprintln!(
                    "mapvlm: {}; that line was skipped",
                    crate::sanitize::for_terminal(&e.to_string())
                );
            }
            bad_lines += loaded.errors.len();
            loaded.values
        }
        None => super::score::metric_values(&mut items, &args.models, pg2s)?,
    };
    let mut guidelines_warning = None;
    let judged = if args.annotations.is_empty() {
        None
    } else {
        Some(read_judgements(
            args,
            &items,
            &mut bad_lines,
            &mut guidelines_warning,
        )?)
    };
    let settings = Settings {
        aggregate: args.aggregate,
        bootstrap: Bootstrap {
            resamples: args.bootstrap,
            seed: args.seed,
        },
        permutations: args.permutations,
    };
    let mut agreement = analyse(&items, &scores, judged.as_ref(), settings);
    if let Some(w) = guidelines_warning {
        agreement.warnings.insert(0, w);
    }
    if let Some(path) = &args.plot {
        match &agreement.human {
            Some(human) => {
                let kinds: HashMap<String, String> = items
                    .iter()
                    .filter_map(|i| Some((i.id.clone(), i.corruption.as_ref()?.kind.clone())))
                    .collect();
                plot::write_figure(&plot::Figure::of(human, &kinds), &layout, path)?;
            }
            None => bail!("--plot needs --annotations: the figure plots metrics against people"),
        }
    }
    if args.json || args.table.is_some() {
        for w in &agreement.warnings {
            eprintln!("mapvlm: warning: {w}");
        }
    }
    let text = match args.table {
        Some(format) => table::render(&agreement, format),
        None if args.json => format!("{:#}\n", json::to_json(&agreement)),
        None => {
            crate::locale::for_locale(&report::render(&agreement), crate::locale::utf8_locale())
                .into_owned()
        }
    };
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(if bad_lines == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `WxH` as (width, height) in pixels.
fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let wrong =
        || format!("{text:?} is not a size; write it as WIDTHxHEIGHT in pixels, e.g. 1200x900");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(wrong)?;
    Ok((
        w.trim().parse().map_err(|_| wrong())?,
        h.trim().parse().map_err(|_| wrong())?,
    ))
}

/// The items, one per id (a later line with the same id replaces an
/// earlier one, with a warning); unreadable lines are reported and counted.
fn read_items(args: &AgreeArgs, bad_lines: &mut usize) -> anyhow::Result<Vec<Pair>> {
    let mut items: Vec<Pair> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for line in open_pairs(&args.items)? {
        match line {
            Ok(item) => match index.get(&item.id) {
                Some(&i) => {
                    eprintln!(
                        "mapvlm: {}: item {:?} appears twice; the later line is used",
                        args.items.display(),
                        item.id
                    );
                    items[i] = item;
                }
                None => {
                    index.insert(item.id.clone(), items.len());
                    items.push(item);
                }
            },
            Err(e) => {
                eprintln!(
                    "mapvlm: {}; that line was skipped",
                    crate::sanitize::for_terminal(&e.to_string())
                );
                *bad_lines += 1;
            }
        }
    }
    if items.is_empty() {
        bail!(
            "{}: no items; an items file has one {{\"id\", \"gt\", \"pred\"}} a line",
            args.items.display()
        );
    }
    Ok(items)
}

/// The current judgements of all annotations files, those of items that
/// are not in the items file reported and left out, and those made under
/// other guidelines than `--guidelines-hash` too; `warning` is set when
/// judgements under several guidelines are pooled.
fn read_judgements(
    args: &AgreeArgs,
    items: &[Pair],
    bad_lines: &mut usize,
    warning: &mut Option<String>,
) -> anyhow::Result<Judged> {
    let key = match &args.key {
        Some(path) => Some(crate::corrupt::blind::read_key(path)?),
        None => None,
    };
    // A blind id maps to its original id; an id the key lacks stays as it
    // is (and is reported below when --items lacks it too).
    let unblind = |id: &mut String| {
        if let Some(original) = key.as_ref().and_then(|k| k.get(id.as_str())) {
            id.clone_from(original);
        }
    };
    let mut lines = Vec::new();
    for path in &args.annotations {
        let file = Annotations::load(path)?;
        for e in &file.errors {
            eprintln!(
                "mapvlm: {}; that line was skipped",
                crate::sanitize::for_terminal(&e.to_string())
            );
        }
        *bad_lines += file.errors.len();
        lines.extend(file.lines.into_iter().map(|(_, mut j)| {
            match &mut j.subject {
                crate::annotate::Subject::Item(id) => unblind(id),
                crate::annotate::Subject::Pair(l, r) => {
                    unblind(l);
                    unblind(r);
                }
            }
            j
        }));
    }
    let known: HashMap<&str, ()> = items.iter().map(|i| (i.id.as_str(), ())).collect();
    let mut unknown: BTreeMap<String, usize> = BTreeMap::new();
    let current = Current::of(lines.iter().filter(|j| {
        let ids: Vec<&str> = match &j.subject {
            crate::annotate::Subject::Item(id) => vec![id],
            crate::annotate::Subject::Pair(l, r) => vec![l, r],
        };
        let missing: Vec<&&str> = ids.iter().filter(|id| !known.contains_key(**id)).collect();
        for id in &missing {
            *unknown.entry((**id).to_string()).or_default() += 1;
        }
        missing.is_empty()
    }));
    for (id, n) in &unknown {
        eprintln!(
            "mapvlm: {n} judgement line(s) name item {id:?}, which is not in {}; left out",
            args.items.display()
        );
    }
    let current = select_guidelines(current, args.guidelines_hash.as_deref(), warning)?;
    let mut step_labels = Vec::new();
    for j in current.judgements() {
        if let (crate::annotate::Subject::Item(item), Some(v)) = (&j.subject, &j.verdict) {
            let mut by_step: BTreeMap<usize, Vec<&str>> = BTreeMap::new();
            for l in &v.step_labels {
                by_step.entry(l.step).or_default().push(l.label.as_str());
            }
            for (step, mut labels) in by_step {
                labels.sort_unstable();
                labels.dedup();
                step_labels.push((item.clone(), j.annotator.clone(), step, labels.join("+")));
            }
        }
    }
    Ok(Judged {
        step_labels,
        ratings: current
            .ratings()
            .map(|(item, who, r)| (item.to_string(), who.to_string(), f64::from(r)))
            .collect(),
        preferences: current
            .preferences()
            .filter_map(|(left, right, _, p)| match p {
                Preference::Left => Some((left.to_string(), right.to_string())),
                Preference::Right => Some((right.to_string(), left.to_string())),
                Preference::Neither => None,
            })
            .collect(),
    })
}

/// The name of a judgement's guidelines hash in messages.
fn hash_name(hash: &str) -> String {
    if hash.is_empty() {
        "(none)".to_string()
    } else {
        crate::sanitize::for_terminal(hash)
    }
}

/// The current judgements made under the guidelines `wanted` (all of them
/// without it). Pooling judgements under several hashes sets `warning`,
/// naming each hash with its count; a `wanted` hash that no current
/// judgement has is an error that lists the hashes present.
fn select_guidelines(
    current: Current,
    wanted: Option<&str>,
    warning: &mut Option<String>,
) -> anyhow::Result<Current> {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for v in current
        .judgements()
        .iter()
        .filter_map(|j| j.verdict.as_ref())
    {
        *counts.entry(v.guidelines.as_str()).or_default() += 1;
    }
    let listed = || {
        counts
            .iter()
            .map(|(hash, n)| format!("{} ({n})", hash_name(hash)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let Some(wanted) = wanted else {
        if counts.len() > 1 {
            *warning = Some(format!(
                "judgements made under {} guidelines are pooled, by hash: {}; keep one with --guidelines-hash HASH",
                counts.len(),
                listed()
            ));
        }
        return Ok(current);
    };
    if !counts.contains_key(wanted) {
        bail!(
            "--guidelines-hash {}: no current judgement was made under it; the hashes present are {}",
            hash_name(wanted),
            if counts.is_empty() { "none".to_string() } else { listed() }
        );
    }
    Ok(Current::of(current.judgements().iter().filter(|j| {
        j.verdict.as_ref().is_some_and(|v| v.guidelines == wanted)
    })))
}
