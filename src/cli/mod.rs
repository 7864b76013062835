//! The command line: one subcommand a module, each with `--json` where a
//! program may read the output.

mod agree;
mod annotate;
mod cache;
mod completions;
mod corrupt;
mod embed;
mod eval;
mod eval_batch;
mod graphics;
mod logging;
mod merge;
mod models;
mod parse;
mod plan;
mod score;
mod tui;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::bail;
use clap::{Args, Parser, Subcommand};

use crate::metrics::pg2s::{GoalModels, Pg2sScorer, Pg2sSettings};
use crate::metrics::{ModelError, SentenceEncoder};
use crate::models::Progress;
use crate::nlp::embedding_cache::{stamped_identity, CachedEncoder};
use crate::nlp::en::EnPipeline;
use crate::nlp::mpnet::{MpnetEncoder, MpnetOptions};
use crate::nlp::wordvec::WordVectorTable;
use crate::store::DiskStore;

/// mapvlm: multi-agent planning with visual language models, and plan metrics.
#[derive(Debug, Parser)]
#[command(
    name = "mapvlm",
    version,
    about,
    args_conflicts_with_subcommands = true
)]
pub struct Cli {
    /// The subcommand to run; without one, the terminal workbench opens.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// The workbench's options, when no subcommand is given.
    #[command(flatten)]
    pub tui: tui::TuiArgs,
    /// Where warnings and notices go and how many.
    #[command(flatten)]
    pub log: logging::LogArgs,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Score predicted plans against ground truths with PG2S and KAS.
    Score(score::ScoreArgs),
    /// Fetch, verify or list the default model pack.
    Models(models::ModelsArgs),
    /// The terminal workbench (also what `mapvlm` alone opens).
    Tui(tui::TuiArgs),
    /// Tag and parse English sentences from standard input (spaCy en_core_web_sm 3.8.0).
    Parse(parse::ParseArgs),
    /// Embed sentences from standard input with all-mpnet-base-v2.
    Embed(embed::EmbedArgs),
    /// Make a plan with the agents of one approach.
    Plan(plan::PlanArgs),
    /// Plan and score every task of a dataset; write the paper's Table 3.
    Eval(eval::EvalArgs),
    /// Join the output folders of `eval --shard` runs into one run's files and tables.
    Merge(merge::MergeArgs),
    /// How far PG2S, S_plan, S_goal and KAS agree with human judgements.
    Agree(agree::AgreeArgs),
    /// Show, prune or clear the embedding and response caches.
    Cache(cache::CacheArgs),
    /// Write a dataset's plans or an items file plus seeded corruptions of every plan.
    Corrupt(corrupt::CorruptArgs),
    /// Judge plans blind, one screen per item (or pair); --export writes CSV.
    Annotate(annotate::AnnotateArgs),
    /// Write a shell completion script on standard output.
    Completions(completions::CompletionsArgs),
    /// Write the man page (roff) on standard output.
    Man,
}

/// Where the model pack is, for the commands that need one model of it.
#[derive(Debug, Args)]
pub struct PackArgs {
    /// The model pack folder (default: $MAPVLM_MODELS, else the user's cache folder).
    #[arg(long, env = "MAPVLM_MODELS", value_name = "DIR")]
    pub models_dir: Option<PathBuf>,
}

impl PackArgs {
    /// The folder of model `folder`, fetching the pack's missing models first.
    fn model(&self, folder: &str) -> anyhow::Result<PathBuf> {
        let dir = crate::models::models_dir(self.models_dir.as_deref());
        models::ensure_pack(&dir, &say, &Progress::stderr())?;
        Ok(crate::models::verified_model_path(&dir, folder)?)
    }
}

/// Where the models come from, for the commands that need them.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    /// The model pack folder (default: $MAPVLM_MODELS, else the user's cache folder).
    #[arg(long, env = "MAPVLM_MODELS", value_name = "DIR")]
    pub models_dir: Option<PathBuf>,
    /// Word vectors in word2vec binary or text format, instead of the pack's GloVe
    /// (e.g. GoogleNews-vectors-negative300.bin for the paper's configuration).
    #[arg(long, value_name = "FILE", conflicts_with = "paper")]
    pub vectors: Option<PathBuf>,
    /// The paper's configuration: word2vec GoogleNews 300-d vectors (gensim
    /// KeyedVectors from the Hugging Face Hub, fetched once into the pack).
    #[arg(long)]
    pub paper: bool,
    /// Neither read nor write the embedding cache ($XDG_CACHE_HOME/mapvlm/embeddings).
    #[arg(long)]
    pub no_embedding_cache: bool,
    /// The embedding cache's size bound in MB; the least recently used entries go first.
    #[arg(long, allow_negative_numbers = true, env = "MAPVLM_CACHE_MAX_MB", value_name = "MB", default_value_t = crate::store::DEFAULT_MAX_BYTES >> 20,
          value_parser = clap::value_parser!(u64).range(1..=crate::store::MAX_CACHE_MB))]
    pub cache_max_mb: u64,
}

impl ModelArgs {
    /// These settings, with the embedding cache off too when `no_cache`
    /// (a command's `--no-cache` turns off every cache it reads).
    fn with_no_cache(&self, no_cache: bool) -> Self {
        let mut models = self.clone();
        models.no_embedding_cache |= no_cache;
        models
    }

    /// The sentence encoder of the pack `dir`: behind the embedding cache
    /// unless `--no-cache` (or the model is not verified as it is now), and
    /// loaded only when a sentence is not in the cache.
    fn encoder(&self, dir: &Path, report: &dyn Fn(String)) -> CachedEncoder {
        let folder = crate::models::verified_model_path(dir, crate::models::MPNET);
        let store = if self.no_embedding_cache {
            None
        } else {
            let identity = stamped_identity(dir, crate::models::MPNET);
            if identity.is_none() {
                report(format!(
                    "embedding cache off: {} is not verified as it is now; run `mapvlm models verify`",
                    crate::models::MPNET
                ));
            }
            identity.map(|model| (embedding_store(self.cache_max_mb << 20), model))
        };
        CachedEncoder::new(
            store,
            Box::new(move || -> Result<Arc<dyn SentenceEncoder>, ModelError> {
                let options = MpnetOptions {
                    cache: false,
                    ..MpnetOptions::default()
                };
                let path = folder.as_ref().map_err(|e| e.to_string())?;
                Ok(Arc::new(MpnetEncoder::load_with(path, options)?))
            }),
        )
    }
}

impl ModelArgs {
    /// The verification stamps of the sentence encoder and of the word
    /// vectors these settings load (a `--vectors` file: its name and
    /// SHA-256; `--paper`: [`crate::models::paper_vectors_identity`]): what
    /// an eval's provenance records, so that results scored with other
    /// models are never joined. Call after the models loaded.
    fn stamps(&self) -> anyhow::Result<(Option<String>, Option<String>)> {
        let dir = crate::models::models_dir(self.models_dir.as_deref());
        let stamp = |folder: &str| {
            stamped_identity(&dir, folder).map(|identity| format!("{folder}: {identity}"))
        };
        let vectors = match &self.vectors {
            Some(file) => Some(format!(
                "{}: sha256={}",
                file.file_name().unwrap_or_default().to_string_lossy(),
                file_sha256(file)?
            )),
            None if self.paper => Some(crate::models::paper_vectors_identity(&dir)?),
            None => stamp(crate::models::GLOVE_6B_50D),
        };
        Ok((stamp(crate::models::MPNET), vectors))
    }
}

/// The SHA-256 of the file at `path`, in hex, read in pieces.
fn file_sha256(path: &Path) -> anyhow::Result<String> {
    crate::models::sha256_file(path, |_| {})
        .map_err(|err| anyhow::anyhow!("{}: cannot be read ({err})", path.display()))
}

/// The PG2S thresholds and weight, the same flags on every command that
/// scores (`score`, `eval`, `agree`, the workbench), so that their scores
/// can be compared.
#[derive(Debug, Clone, Copy, Args)]
pub struct Pg2sArgs {
    /// A sentence match needs a cosine strictly above this (-1 to 1).
    #[arg(long, allow_negative_numbers = true, value_name = "COSINE", default_value_t = Pg2sSettings::default().sentence_threshold)]
    pub sentence_threshold: f64,
    /// A verb match needs a similarity above this; nouns agree at or above it (-1 to 1).
    #[arg(long, allow_negative_numbers = true, value_name = "COSINE", default_value_t = Pg2sSettings::default().word_threshold)]
    pub word_threshold: f64,
    /// The weight of S_goal in PG2S: (1 - alpha) S_plan + alpha S_goal (0 to 1).
    #[arg(long, allow_negative_numbers = true, value_name = "WEIGHT", default_value_t = Pg2sSettings::default().alpha)]
    pub alpha: f64,
}

impl Pg2sArgs {
    /// The settings of these flags, or which flag is out of range and why.
    pub fn settings(&self) -> anyhow::Result<Pg2sSettings> {
        use crate::metrics::pg2s::Pg2sSetting;
        Pg2sSettings::new(self.sentence_threshold, self.word_threshold, self.alpha).map_err(|e| {
            let flag = match e.setting {
                Pg2sSetting::SentenceThreshold => "--sentence-threshold",
                Pg2sSetting::WordThreshold => "--word-threshold",
                Pg2sSetting::Alpha => "--alpha",
            };
            anyhow::anyhow!("{flag}: {e}")
        })
    }
}

/// Which share of the work this process does, for job arrays (see [`crate::shard`]).
#[derive(Debug, Clone, Args)]
pub struct ShardArgs {
    /// Only the items of shard I of N (I from 1 to N; an item's shard is
    /// 1 + the first 8 bytes of SHA-256 of its id, big-endian, mod N), or
    /// `auto`: from a Slurm job array or a Kubernetes Indexed Job.
    #[arg(long, allow_hyphen_values = true, value_name = "I/N|auto")]
    pub shard: Option<String>,
    /// N for `--shard auto` in a Kubernetes Indexed Job (its `completions`).
    #[arg(
        long,
        allow_negative_numbers = true,
        env = "MAPVLM_SHARD_COUNT",
        value_name = "N"
    )]
    pub shard_count: Option<u64>,
}

impl ShardArgs {
    /// The shard asked for, or the whole work when `--shard` is not given.
    fn shard(&self) -> anyhow::Result<crate::shard::Shard> {
        let Some(value) = &self.shard else {
            return Ok(crate::shard::Shard::WHOLE);
        };
        value
            .parse::<crate::shard::ShardSpec>()
            .and_then(|spec| spec.resolve(self.shard_count))
            .map_err(|e| anyhow::anyhow!("--shard {e}"))
    }
}

/// The embedding cache, `$XDG_CACHE_HOME/mapvlm/embeddings`, kept under `max_bytes`.
fn embedding_store(max_bytes: u64) -> DiskStore {
    DiskStore::new(
        crate::store::user_cache_root().join("embeddings"),
        max_bytes,
    )
}

/// Prints a line about the model pack on stderr.
fn say(line: String) {
    eprintln!("mapvlm: {}", crate::sanitize::for_terminal(&line));
}

/// Loads the models PG2S needs, side by side on threads, fetching the pack
/// first when a model is missing; `report` and `progress` tell the user
/// about a fetch.
fn load_scorer(
    args: &ModelArgs,
    settings: Pg2sSettings,
    report: &dyn Fn(String),
    progress: &Progress,
) -> anyhow::Result<Pg2sScorer> {
    Ok(load_models(args, settings, report, progress)?.0)
}

/// The PG2S scorer, and the English pipeline and word vectors it frames and
/// compares with (the workbench corrupts plans with the same two).
fn load_models(
    args: &ModelArgs,
    settings: Pg2sSettings,
    report: &dyn Fn(String),
    progress: &Progress,
) -> anyhow::Result<(Pg2sScorer, Arc<EnPipeline>, Arc<WordVectorTable>)> {
    let dir = crate::models::models_dir(args.models_dir.as_deref());
    models::ensure_pack(&dir, report, progress)?;
    if args.paper {
        models::ensure_paper_vectors(&dir, report, progress)?;
    }
    let (vectors, parser) = std::thread::scope(|s| {
        let vectors = s.spawn(|| load_vectors(args, &dir));
        let parser = s.spawn(|| load_parser(&dir));
        (joined(vectors), joined(parser))
    });
    let (vectors, parser) = (Arc::new(vectors?), parser?);
    let goal = GoalModels {
        vectors: vectors.clone(),
        parser: parser.clone(),
    };
    let scorer = Pg2sScorer::new(Arc::new(args.encoder(&dir, report)), Some(goal), settings);
    Ok((scorer, parser, vectors))
}

/// The word vectors of `--vectors`, else the pack's GloVe.
fn load_vectors(args: &ModelArgs, dir: &Path) -> anyhow::Result<WordVectorTable> {
    Ok(match &args.vectors {
        Some(file) => WordVectorTable::load_word2vec(file)?,
        None if args.paper => {
            let folder = crate::models::model_path(dir, crate::models::WORD2VEC_GOOGLE_NEWS)?;
            WordVectorTable::load_keyed_vectors(
                &folder.join(crate::models::WORD2VEC_GOOGLE_NEWS_FILE),
            )?
        }
        None => WordVectorTable::load_glove_pack(&crate::models::verified_model_path(
            dir,
            crate::models::GLOVE_6B_50D,
        )?)?,
    })
}

/// The framing parser (the spaCy-compatible English pipeline).
fn load_parser(dir: &Path) -> anyhow::Result<Arc<EnPipeline>> {
    let path = crate::models::verified_model_path(dir, crate::models::EN_CORE_WEB_SM)?;
    Ok(Arc::new(EnPipeline::load(&path)?))
}

/// The result of a loading thread; a panic there becomes an error.
fn joined<T>(handle: std::thread::ScopedJoinHandle<'_, anyhow::Result<T>>) -> anyhow::Result<T> {
    handle
        .join()
        .unwrap_or_else(|_| Err(anyhow::anyhow!("a model loader crashed")))
}

/// Parses the command line and runs the chosen command.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    let screen = matches!(
        cli.command,
        None | Some(Command::Tui(_)) | Some(Command::Annotate(_))
    );
    logging::install(&cli.log, screen)?;
    match cli.command {
        Some(Command::Score(args)) => score::run(&args),
        Some(Command::Models(args)) => models::run(args),
        Some(Command::Tui(args)) => tui::run(args),
        Some(Command::Parse(args)) => parse::run(&args),
        Some(Command::Embed(args)) => embed::run(&args),
        Some(Command::Plan(args)) => plan::run(&args),
        Some(Command::Eval(args)) => eval::run(&args),
        Some(Command::Merge(args)) => merge::run(&args),
        Some(Command::Agree(args)) => agree::run(&args),
        Some(Command::Cache(args)) => cache::run(&args),
        Some(Command::Corrupt(args)) => corrupt::run(&args),
        Some(Command::Annotate(args)) => annotate::run(args),
        Some(Command::Completions(args)) => completions::completions(&args),
        Some(Command::Man) => completions::man(),
        None => tui::run(cli.tui),
    }
}

/// Refuses to open a full-screen view (`what`) where it cannot work: standard
/// input or output not a terminal (`mapvlm < /dev/null > out` would draw the
/// screen into the file and wait for keys that never come), or `TERM=dumb`
/// (no cursor movement). Called after the arguments are checked, so their
/// errors come first, and before the terminal is touched.
fn require_terminal(what: &str) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    let why = if std::env::var("TERM").is_ok_and(|term| term == "dumb") {
        "TERM is dumb"
    } else if !std::io::stdin().is_terminal() {
        "standard input is not a terminal"
    } else if !std::io::stdout().is_terminal() {
        "standard output is not a terminal"
    } else {
        return Ok(());
    };
    bail!("{what} needs a terminal, and {why}; run it in one (the commands plan, eval, score and agree work without)")
}
