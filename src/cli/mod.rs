//! The command line: one subcommand a module, each with `--json` where a
//! program may read the output.

mod models;
mod parse;
mod score;
mod tui;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use crate::metrics::pg2s::{Pg2sScorer, Pg2sSettings};

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
}

/// Where the models come from, for the commands that need them.
#[derive(Debug, Args)]
pub struct ModelArgs {
    /// The model pack folder (default: $MAPVLM_MODELS, else the user's cache folder).
    #[arg(long, env = "MAPVLM_MODELS", value_name = "DIR")]
    pub models_dir: Option<PathBuf>,
    /// Word vectors in word2vec binary or text format, instead of the pack's GloVe
    /// (e.g. GoogleNews-vectors-negative300.bin for the paper's configuration).
    #[arg(long, value_name = "FILE")]
    pub vectors: Option<PathBuf>,
}

/// Loads the models PG2S needs.
fn load_scorer(_models: &ModelArgs, _settings: Pg2sSettings) -> anyhow::Result<Pg2sScorer> {
    anyhow::bail!(
        "PG2S needs the sentence encoder, which this build does not have yet; use --metrics kas"
    )
}

/// Parses the command line and runs the chosen command.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Score(args)) => score::run(&args),
        Some(Command::Models(args)) => models::run(args),
        Some(Command::Tui(args)) => tui::run(args),
        Some(Command::Parse(args)) => {
            parse::run(&args)?;
            Ok(ExitCode::SUCCESS)
        }
        None => tui::run(cli.tui),
    }
}
