//! `mapvlm` with no subcommand, or `mapvlm tui`: the terminal workbench.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use clap::Args;

use crate::metrics::pg2s::Pg2sSettings;
use crate::tui::{self, agents::ReplayPipeline, Options};

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
    /// Draw the scene image with half-blocks instead of asking the terminal
    /// (for slow links and terminals that answer queries badly).
    #[arg(long)]
    pub halfblocks: bool,
    /// Milliseconds between two words of a replayed recording.
    #[arg(long, default_value_t = 12, value_name = "MS")]
    pub replay_delay: u64,
    /// Model settings shared with the other model-backed commands.
    #[command(flatten)]
    pub models: super::ModelArgs,
}

/// Runs the workbench.
pub fn run(args: TuiArgs) -> anyhow::Result<ExitCode> {
    let models = args.models;
    let options = Options {
        dataset: args.dataset,
        session: args.session,
        theme: args.theme,
        scorer: Box::new(move |progress: &dyn Fn(String)| {
            progress("loading the models".to_string());
            super::load_scorer(
                &models,
                Pg2sSettings::default(),
                progress,
                &crate::models::Progress::hidden(),
            )
            .map_err(|e| format!("{e:#}"))
        }),
        pipeline: Arc::new(ReplayPipeline {
            delay: Duration::from_millis(args.replay_delay),
        }),
        picker: args
            .halfblocks
            .then(ratatui_image::picker::Picker::halfblocks),
    };
    tui::run(options)?;
    Ok(ExitCode::SUCCESS)
}
