//! `mapvlm parse`: analyse sentences from standard input with the English
//! pipeline, one line in, one analysis out.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::PackArgs;
use crate::dataset::lines::BoundedLines;
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

/// The longest line analysed, in characters: the parser's memory grows with
/// a sentence's length, and no sentence needs more. A longer line, however
/// long, is cut to its first `MAX_SENTENCE_CHARS` characters, and stderr
/// says so; it is never skipped.
pub const MAX_SENTENCE_CHARS: usize = 10_000;

/// The bytes of a line kept in memory: enough for `MAX_SENTENCE_CHARS`
/// characters of four bytes and one more, so that a line cut by the reader
/// always has more characters than the limit and its cut is said.
const MAX_LINE_BYTES: usize = MAX_SENTENCE_CHARS * 4 + 4;

/// Runs `mapvlm parse`; lines that are not UTF-8 are reported and skipped,
/// and make the exit status a failure.
pub fn run(args: &ParseArgs) -> anyhow::Result<ExitCode> {
    let dir = args.pack.model(EN_CORE_WEB_SM)?;
    let nlp = EnPipeline::load(&dir)?;
    let stdin = std::io::stdin().lock();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut failed = false;
    for line in BoundedLines::cutting(stdin, MAX_LINE_BYTES) {
        let (n, text) = line.context("cannot read standard input")?;
        let mut text = match text {
            Ok(text) => text,
            Err(problem) => {
                eprintln!(
                    "mapvlm: standard input, line {n}: {}; that line was skipped",
                    crate::sanitize::for_terminal(&problem.to_string())
                );
                failed = true;
                continue;
            }
        };
        if let Some((end, _)) = text.char_indices().nth(MAX_SENTENCE_CHARS) {
            eprintln!(
                "mapvlm: standard input, line {n}: longer than {MAX_SENTENCE_CHARS} characters; only those were parsed"
            );
            text.truncate(end);
        }
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
    Ok(if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
