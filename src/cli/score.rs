//! `mapvlm score`: KAS and PG2S of plan pairs, with the explanation of every
//! point lost, for people and (with `--json`) for programs.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::bail;
use clap::{Args, ValueEnum};
use serde_json::{json, Value};

use crate::agree::MetricValues;
use crate::dataset::{open_pairs, LineError, Pair};
use crate::metrics::kas::{kas, KasReport};
use crate::metrics::pg2s::{Pg2sReport, Pg2sScorer, Pg2sSettings};
use crate::metrics::shown;
use crate::plan::{bound_steps, parse_steps};

/// A metric `score` can compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Metric {
    /// The KeyActionScore; needs no model.
    Kas,
    /// PG2S with S_plan and S_goal; needs the model pack.
    Pg2s,
}

/// Arguments of `mapvlm score`. With no input, the built-in example is scored.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// Ground-truth step file (one step a line; numbering and bullets are removed).
    #[arg(long, requires = "pred", conflicts_with = "pairs")]
    pub gt: Option<PathBuf>,
    /// Predicted step file, or raw model output.
    #[arg(long, requires = "gt")]
    pub pred: Option<PathBuf>,
    /// A pairs file: `{"id", "gt", "pred"}` per line (`-` for standard input).
    #[arg(long, value_name = "FILE")]
    pub pairs: Option<PathBuf>,
    /// Print one JSON object per pair instead of the explanation.
    #[arg(long)]
    pub json: bool,
    /// The metrics to compute.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Metric::Kas, Metric::Pg2s])]
    pub metrics: Vec<Metric>,
    /// Model settings shared with the other model-backed commands.
    #[command(flatten)]
    pub models: super::ModelArgs,
    /// Neither read nor write any cache (here: the embedding cache).
    #[arg(long)]
    pub no_cache: bool,
    /// The PG2S thresholds and weight.
    #[command(flatten)]
    pub pg2s: super::Pg2sArgs,
    /// Which pairs of `--pairs` this process scores.
    #[command(flatten)]
    pub shard: super::ShardArgs,
}

/// One pair's scores.
struct Scored<'a> {
    pair: &'a Pair,
    kas: Option<KasReport>,
    pg2s: Option<Pg2sReport>,
}

/// Runs `mapvlm score`.
pub fn run(args: &ScoreArgs) -> anyhow::Result<ExitCode> {
    let settings = args.pg2s.settings()?;
    let shard = args.shard.shard()?;
    if args.shard.shard.is_some() && args.pairs.is_none() {
        bail!("--shard splits a pairs file: give --pairs FILE");
    }
    let pairs = read_pairs(args)?;
    let scorer = if args.metrics.contains(&Metric::Pg2s) {
        Some(super::load_scorer(
            &args.models.with_no_cache(args.no_cache),
            settings,
            &super::say,
            &crate::models::Progress::stderr(),
        )?)
    } else {
        None
    };
    let mut out = std::io::stdout().lock();
    let mut chunk = Vec::new();
    let mut chunk_steps = 0;
    let mut bad_lines = 0usize;
    for item in pairs {
        let mut pair = match item {
            Ok(pair) if shard.contains(&pair.id) => pair,
            Ok(_) => continue,
            Err(line) => {
                eprintln!(
                    "mapvlm: {}; that line was skipped, the others were scored",
                    crate::sanitize::for_terminal(&line.to_string())
                );
                bad_lines += 1;
                continue;
            }
        };
        bound_pair(&mut pair);
        chunk_steps += pair.gt.len() + pair.pred.len();
        chunk.push(pair);
        if chunk_steps >= CHUNK_STEPS {
            score_chunk(args, scorer.as_ref(), &chunk, &mut out)?;
            chunk.clear();
            chunk_steps = 0;
        }
    }
    score_chunk(args, scorer.as_ref(), &chunk, &mut out)?;
    out.flush()?;
    Ok(if bad_lines == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The steps of the pairs scored together: their sentences are embedded in
/// one batch, and the pairs, their steps and the encoder's working set are
/// all the memory a run keeps, whatever the number of pairs.
const CHUNK_STEPS: usize = 4_096;

/// Scores `pairs` and writes each one's lines to `out`. A failed write is
/// returned as the `io::Error` it is, so that a closed pipe (`| head`) ends
/// the run quietly (see `main`).
fn score_chunk(
    args: &ScoreArgs,
    scorer: Option<&Pg2sScorer>,
    pairs: &[Pair],
    out: &mut impl std::io::Write,
) -> anyhow::Result<()> {
    let utf8 = crate::locale::utf8_locale();
    if let Some(scorer) = scorer {
        warm_up(scorer, pairs)?;
    }
    for pair in pairs {
        let scored = Scored {
            pair,
            kas: args
                .metrics
                .contains(&Metric::Kas)
                .then(|| kas(&pair.gt, &pair.pred)),
            pg2s: match scorer {
                Some(s) => Some(
                    s.score(&pair.gt, &pair.pred)
                        .map_err(|e| anyhow::anyhow!("scoring {}: {e}", pair.id))?,
                ),
                None => None,
            },
        };
        let text = if args.json {
            format!("{}\n", to_json(&scored))
        } else {
            // The ids and steps come from the user's file: data, shown as
            // such, in the characters the locale can show.
            let text = crate::sanitize::for_terminal(&explain(&scored));
            crate::locale::for_locale(&text, utf8).into_owned()
        };
        out.write_all(text.as_bytes())?;
    }
    Ok(())
}

/// The four metric values of every item (in the order of
/// [`crate::agree::METRICS`]), scored with the model pack and `settings`,
/// for `agree` without `--scores`.
pub(super) fn metric_values(
    items: &mut [Pair],
    models: &super::ModelArgs,
    settings: Pg2sSettings,
) -> anyhow::Result<HashMap<String, MetricValues>> {
    for item in items.iter_mut() {
        bound_pair(item);
    }
    let scorer = super::load_scorer(
        models,
        settings,
        &super::say,
        &crate::models::Progress::stderr(),
    )?;
    warm_up(&scorer, items)?;
    items
        .iter()
        .map(|item| {
            let p = scorer
                .score(&item.gt, &item.pred)
                .map_err(|e| anyhow::anyhow!("scoring {}: {e}", item.id))?;
            let k = kas(&item.gt, &item.pred);
            Ok((
                item.id.clone(),
                [p.pg2s(), Some(p.s_plan), p.s_goal(), k.kas],
            ))
        })
        .collect()
}

/// Embeds every distinct step of every pair in one batched call, so that the
/// encoder can sort them by length and each pair then hits its cache.
fn warm_up(scorer: &Pg2sScorer, pairs: &[Pair]) -> anyhow::Result<()> {
    let mut seen = std::collections::HashSet::new();
    let steps: Vec<&str> = pairs
        .iter()
        .flat_map(|p| p.gt.iter().chain(&p.pred))
        .map(String::as_str)
        .filter(|s| seen.insert(*s))
        .collect();
    scorer
        .warm_up(&steps)
        .map_err(|e| anyhow::anyhow!("embedding the steps: {e}"))
}

/// The pairs to score, one at a time: the lines of `--pairs` (each a pair or
/// the reason its line was skipped), else the one pair of `--gt`/`--pred`,
/// else the built-in example.
fn read_pairs(
    args: &ScoreArgs,
) -> anyhow::Result<Box<dyn Iterator<Item = Result<Pair, LineError>>>> {
    if let Some(path) = &args.pairs {
        return Ok(Box::new(open_pairs(path)?));
    }
    let pair = match (&args.gt, &args.pred) {
        (Some(gt), Some(pred)) => Pair::new(
            format!("{} vs {}", pred.display(), gt.display()),
            read_plan(gt)?,
            read_plan(pred)?,
        ),
        _ => Pair::new(
            format!("built-in example: {}", crate::demo::TASK.trim()),
            parse_steps(crate::demo::GROUND_TRUTH),
            parse_steps(crate::demo::PLAN),
        ),
    };
    Ok(Box::new(std::iter::once(Ok(pair))))
}

/// Cuts a pair's plans to the limits of [`bound_steps`], saying so on stderr.
fn bound_pair(pair: &mut Pair) {
    for (name, steps) in [
        ("ground truth", &mut pair.gt),
        ("prediction", &mut pair.pred),
    ] {
        if let Some(note) = bound_steps(steps) {
            eprintln!(
                "mapvlm: {}",
                crate::sanitize::for_terminal(&format!("{}: {name}: {note}", pair.id))
            );
        }
    }
}

/// Reads a step file; a file with no steps is an error.
fn read_plan(path: &Path) -> anyhow::Result<Vec<String>> {
    let text =
        crate::dataset::read_text_within(path, crate::limits::MAX_STEP_FILE_BYTES, "a step file")?;
    let steps = parse_steps(&text);
    if steps.is_empty() {
        bail!(
            "{}: no steps found; a plan file has one step a line",
            path.display()
        );
    }
    Ok(steps)
}

/// The JSON object of one pair, with the fields of the golden file and, for
/// every metric that could not be computed, the reason.
fn to_json(s: &Scored) -> Value {
    let mut obj = json!({ "id": s.pair.id, "gt": s.pair.gt, "pred": s.pair.pred });
    let mut reasons = serde_json::Map::new();
    if let Some(k) = &s.kas {
        obj["kas"] = json!(k.kas);
        obj["kas_chunks"] = json!(k.chunks);
        if let Some(r) = &k.reason {
            reasons.insert("kas".into(), json!(r));
        }
    }
    if let Some(p) = &s.pg2s {
        obj["s_plan"] = json!(p.s_plan);
        obj["s_goal"] = json!(p.s_goal());
        obj["pg2s"] = json!(p.pg2s());
        obj["pg2s_settings"] = json!(p.settings);
        obj["sentence_matches"] = p
            .sentence_matches
            .iter()
            .map(|m| json!([m.gt, m.pred, m.cosine]))
            .collect();
        match &p.goal {
            Ok(g) => {
                obj["gt_actions"] = g.gt_actions.iter().map(|a| json!(a.words)).collect();
                obj["pred_actions"] = g.pred_actions.iter().map(|a| json!(a.words)).collect();
                obj["action_matches"] = g
                    .action_matches
                    .iter()
                    .map(|m| json!([m.gt, m.pred]))
                    .collect();
            }
            Err(reason) => {
                reasons.insert("s_goal".into(), json!(reason.to_string()));
                reasons.insert("pg2s".into(), json!(reason.to_string()));
            }
        }
    }
    if !reasons.is_empty() {
        obj["reasons"] = Value::Object(reasons);
    }
    obj
}

/// The explanation of one pair for a person.
fn explain(s: &Scored) -> String {
    let mut out = String::new();
    let (gt, pred) = (&s.pair.gt, &s.pair.pred);
    let _ = writeln!(out, "{}", s.pair.id);
    if let Some(p) = &s.pg2s {
        let _ = writeln!(
            out,
            "  PG2S {}   S_plan {}   S_goal {}",
            shown(p.pg2s()),
            shown(Some(p.s_plan)),
            shown(p.s_goal())
        );
    }
    if let Some(k) = &s.kas {
        let _ = write!(out, "  KAS  {}", shown(k.kas));
        match &k.reason {
            Some(r) => {
                let _ = writeln!(out, "   ({r})");
            }
            None => out.push('\n'),
        }
    }
    if let Some(p) = &s.pg2s {
        let threshold = p.settings.sentence_threshold;
        let _ = writeln!(out, "  steps (ground truth → prediction, cosine):");
        for m in &p.sentence_matches {
            let _ = match (m.pred, m.cosine, m.closest) {
                (Some(j), Some(c), _) => {
                    writeln!(out, "    ✓ {} → {}  {c:.3}  {}", m.gt + 1, j + 1, gt[m.gt])
                }
                (_, _, Some((j, c))) => writeln!(
                    out,
                    "    ✗ {}  {}\n        closest free step {} at {c:.3}, not above {threshold}",
                    m.gt + 1,
                    gt[m.gt],
                    j + 1
                ),
                _ => writeln!(
                    out,
                    "    ✗ {}  {}\n        no predicted step left",
                    m.gt + 1,
                    gt[m.gt]
                ),
            };
        }
        match &p.goal {
            Ok(g) => {
                let _ = writeln!(out, "  actions (ground truth → prediction):");
                for m in &g.action_matches {
                    let a = &g.gt_actions[m.gt].words;
                    let _ = match m.pred {
                        Some(j) => writeln!(
                            out,
                            "    ✓ {a:?} → {:?}",
                            g.pred_actions[j].words
                        ),
                        None => writeln!(
                            out,
                            "    ✗ {a:?}: no free predicted action with a verb above {} and agreeing nouns",
                            p.settings.word_threshold
                        ),
                    };
                }
            }
            Err(reason) => {
                let _ = writeln!(out, "  S_goal not computed: {reason}");
            }
        }
        let unmatched: Vec<String> = (0..pred.len())
            .filter(|j| !p.sentence_matches.iter().any(|m| m.pred == Some(*j)))
            .map(|j| (j + 1).to_string())
            .collect();
        if !unmatched.is_empty() {
            let _ = writeln!(
                out,
                "  predicted steps matching no ground truth: {}",
                unmatched.join(", ")
            );
        }
    }
    out
}
