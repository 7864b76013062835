//! The command line: one subcommand a module, each with `--json` where a
//! program may read the output.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod models;

/// mapvlm: multi-agent planning with visual language models, and plan metrics.
#[derive(Debug, Parser)]
#[command(name = "mapvlm", version, about)]
pub struct Cli {
    /// The subcommand to run.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Fetch, verify or list the default model pack.
    Models(models::ModelsArgs),
}

/// Parses the command line and runs the chosen command.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        None => Ok(ExitCode::SUCCESS),
        Some(Command::Models(args)) => models::run(args),
    }
}
