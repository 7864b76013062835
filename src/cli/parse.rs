//! `mapvlm parse`: analyse sentences from standard input with the English
//! pipeline, one line in, one analysis out.

use std::io::{BufRead, Write};

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::PackArgs;
use crate::models::EN_CORE_WEB_SM;
use crate::nlp::en::EnPipeline;
use crate::nlp::Token;

/// Options of `mapvlm parse`.
#[derive(Debug, Args)]
pub struct ParseArgs {
    /// Print one JSON object a line: {text, tokens[{text, ws, tag, pos, dep, head}]}.
    #[arg(long)]
    pub json: bool,
    /// Where the model pack is.
    #[command(flatten)]
    pub pack: PackArgs,
}

#[derive(Serialize)]
struct Analysis<'a> {
    text: &'a str,
    tokens: &'a [Token],
}

/// Runs `mapvlm parse`.
pub fn run(args: &ParseArgs) -> anyhow::Result<()> {
    let dir = args.pack.model(EN_CORE_WEB_SM)?;
    let nlp = EnPipeline::load(&dir)?;
    let stdin = std::io::stdin().lock();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for (n, line) in stdin.lines().enumerate() {
        let text =
            line.with_context(|| format!("standard input, line {}: not UTF-8 text", n + 1))?;
        let tokens = nlp.analyse(&text);
        if args.json {
            let json = serde_json::to_string(&Analysis {
                text: &text,
                tokens: &tokens,
            })?;
            writeln!(out, "{json}")?;
        } else {
            writeln!(out, "{text}")?;
            for (i, t) in tokens.iter().enumerate() {
                writeln!(
                    out,
                    "  {i:>3} {:<16} {:<6} {:<6} {:<10} {}",
                    t.text, t.tag, t.pos, t.dep, t.head
                )?;
            }
        }
    }
    out.flush()?;
    Ok(())
}
