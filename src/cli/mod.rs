//! The command line: `score`, `embed`, `models` and the other subcommands.

use std::process::ExitCode;

use clap::Parser;

/// mapvlm: multi-agent planning with visual language models, and plan metrics.
#[derive(Debug, Parser)]
#[command(name = "mapvlm", version, about)]
pub struct Cli {}

/// Parses the command line and runs the chosen command.
pub fn run() -> anyhow::Result<ExitCode> {
    let _cli = Cli::parse();
    Ok(ExitCode::SUCCESS)
}
