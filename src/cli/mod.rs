//! The command line: one subcommand a module, each with `--json` where a
//! program may read the output.

pub mod parse;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

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
    /// Tag and parse English sentences from standard input (spaCy en_core_web_sm 3.8.0).
    Parse(parse::ParseArgs),
}

/// Parses the command line and runs the chosen command.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        None => Ok(ExitCode::SUCCESS),
        Some(Command::Parse(args)) => {
            parse::run(&args)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
