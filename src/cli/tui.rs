//! `mapvlm` with no subcommand, or `mapvlm tui`: the terminal workbench.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::Args;

use crate::agents::cache::ResponseCache;
use crate::agents::config::ConfigFile;
use crate::agents::cost::PriceTable;
use crate::agents::pipeline::MAX_SAMPLES;
use crate::agents::prompts::PromptSet;
use crate::agents::replay::Pace;
use crate::corrupt::{user_vocabulary_dir, Vocabulary};
use crate::dataset::Dataset;
use crate::lock::{Lock, LockError};
use crate::workbench::agents::{prompt_texts, AgentsPipeline, ProviderConfig};
use crate::workbench::corrupting::{CorruptError, CorruptionModels};
use crate::workbench::scoring::{LoadError, Loaded};
use crate::workbench::{self, session, theme, Options};

/// Arguments of the workbench.
#[derive(Debug, Args)]
pub struct TuiArgs {
    /// A dataset folder (with tasks.jsonl) to choose tasks and ground truths from.
    #[arg(long, value_name = "DIR")]
    pub dataset: Option<PathBuf>,
    /// The session file (default: $XDG_STATE_HOME/mapvlm/session.json).
    #[arg(long, value_name = "FILE")]
    pub session: Option<PathBuf>,
    /// The theme to start with: dark, light, high-contrast or one of yours.
    #[arg(long)]
    pub theme: Option<String>,
    /// How the scene image is drawn.
    #[command(flatten)]
    pub graphics: super::graphics::GraphicsArgs,
    /// Milliseconds between two words of a replayed recording (at most 10000).
    #[arg(long, allow_negative_numbers = true, default_value_t = 12, value_name = "MS", value_parser = clap::value_parser!(u64).range(0..=10_000))]
    pub replay_delay: u64,
    /// The config file with providers and keys (default:
    /// $XDG_CONFIG_HOME/mapvlm/config.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// A folder of prompt templates overriding the built-in ones (default:
    /// $XDG_CONFIG_HOME/mapvlm/prompts).
    #[arg(long, value_name = "DIR")]
    pub prompts: Option<PathBuf>,
    /// How many samples `r` asks each agent for (1 to 100; default: the
    /// session's setting, which S changes).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SAMPLES)))]
    pub samples: Option<u32>,
    /// Model settings shared with the other model-backed commands.
    #[command(flatten)]
    pub models: super::ModelArgs,
    /// The PG2S thresholds and weight the plans are scored with.
    #[command(flatten)]
    pub pg2s: super::Pg2sArgs,
}

/// Runs the workbench.
pub fn run(args: TuiArgs) -> anyhow::Result<ExitCode> {
    let env = |name: &str| std::env::var(name).ok();
    let (file, path) = match &args.config {
        Some(path) => (ConfigFile::load(path, true)?, Some(path.clone())),
        None => match ConfigFile::default_path(&env) {
            Some(path) => (ConfigFile::load(&path, false)?, Some(path)),
            None => (ConfigFile::default(), None),
        },
    };
    let graphics = args.graphics.request(file.graphics.as_deref())?;
    let prompt_dir = args.prompts.clone().or_else(PromptSet::default_dir);
    let prompts = PromptSet::load(prompt_dir.as_deref())?;
    let pace = match args.replay_delay {
        0 => Pace::Instant,
        ms => Pace::Every(Duration::from_millis(ms)),
    };
    let prices = PriceTable::from_config(&file.prices);
    let providers = ProviderConfig {
        file,
        path,
        env: Box::new(env),
    };
    let configured = providers.configured_agents();
    let pipeline = AgentsPipeline::new(
        providers,
        ResponseCache::default_dir().map(ResponseCache::new),
        pace,
    )
    .context("the workbench cannot start")?;
    let models = args.models;
    let settings = args.pg2s.settings()?;
    let (themes, theme_problems) = theme::load_themes(theme::user_theme_dir().as_deref());
    if let Some(name) = &args.theme {
        theme::named(&themes, name)?;
    }
    let dataset = match &args.dataset {
        Some(path) => Some(Dataset::load(path).context("--dataset")?),
        None => None,
    };
    let session = args.session.clone().or_else(session::default_path);
    let _lock = session.as_deref().map(lock_session).transpose()?;
    super::require_terminal("the workbench")?;
    let options = Options {
        samples: args.samples,
        dataset,
        session,
        themes,
        theme_problems,
        theme: args.theme,
        scorer: Box::new(move |progress: &dyn Fn(String)| {
            progress("loading the models".to_string());
            let (scorer, parser, vectors) = super::load_models(
                &models,
                settings,
                progress,
                &crate::models::Progress::hidden(),
            )
            .map_err(|e| LoadError::Models {
                reason: format!("{e:#}"),
            })?;
            // Without the vocabularies only the corruptions are off.
            let vocabulary = Vocabulary::load(user_vocabulary_dir().as_deref());
            Ok(Loaded {
                scorer,
                corruption: vocabulary
                    .map(|vocabulary| CorruptionModels {
                        parser,
                        vectors,
                        vocabulary: Arc::new(vocabulary),
                    })
                    .map_err(|e| CorruptError::Unavailable(e.to_string())),
            })
        }),
        pipeline: Arc::new(pipeline),
        prompts: prompt_texts(&prompts),
        graphics,
        query_timeout: args.graphics.timeout(),
        prices,
        configured,
        prompt_sets: crate::agents::prompt_sets::default_root(),
    };
    workbench::run(options)?;
    Ok(ExitCode::SUCCESS)
}

/// Takes the session file's lock for the workbench's whole life, after
/// checking the file can be read and written: two workbenches on one
/// session would each save over the other's edits, so the second is refused,
/// naming the first; the kernel frees the lock however the holder ends.
fn lock_session(path: &Path) -> anyhow::Result<Lock> {
    let shown = || crate::sanitize::for_terminal(&path.display().to_string());
    if path.is_dir() {
        bail!(
            "the session file {} is a folder; give --session FILE",
            shown()
        );
    }
    if path.exists() {
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .with_context(|| {
                format!(
                    "the session file {} cannot be read and written; fix its permissions or give --session FILE",
                    shown()
                )
            })?;
    }
    let mut lock_path = path.as_os_str().to_owned();
    lock_path.push(".lock");
    match Lock::acquire(Path::new(&lock_path), "mapvlm workbench") {
        Ok(lock) => Ok(lock),
        Err(LockError::Held { holder, .. }) => bail!(
            "the session {} is open in another workbench ({}); close that one, or open a second workbench on its own session with --session FILE",
            shown(),
            crate::sanitize::for_terminal(&holder)
        ),
        Err(err) => Err(err).with_context(|| {
            format!(
                "the session file {} cannot be written; fix its folder's permissions or give --session FILE",
                shown()
            )
        }),
    }
}
