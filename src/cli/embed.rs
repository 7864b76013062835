//! `mapvlm embed`: sentence embeddings of the lines of standard input.

use std::io::{BufRead, Write};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::PackArgs;
use crate::models::MPNET;
use crate::nlp::mpnet::MpnetEncoder;

/// Lines embedded per call to the encoder, so output starts before the end
/// of a long input.
const LINES_PER_CHUNK: usize = 1024;

/// Embeds each non-blank line of standard input with all-mpnet-base-v2.
#[derive(Debug, Args)]
pub struct EmbedArgs {
    /// Print one JSON object `{"text", "embedding"}` per line.
    #[arg(long)]
    pub json: bool,
    /// Where the model pack is.
    #[command(flatten)]
    pub pack: PackArgs,
}

/// One line of `--json` output.
#[derive(Serialize)]
struct EmbeddingLine<'a> {
    text: &'a str,
    embedding: &'a [f32],
}

/// Runs `mapvlm embed`.
pub fn run(args: &EmbedArgs) -> anyhow::Result<ExitCode> {
    let encoder = MpnetEncoder::load(&args.pack.model(MPNET)?)?;
    let stdin = std::io::stdin().lock();
    let mut stdout = std::io::BufWriter::new(std::io::stdout().lock());
    let mut chunk: Vec<String> = Vec::with_capacity(LINES_PER_CHUNK);
    for (number, line) in stdin.lines().enumerate() {
        let line = line.with_context(|| format!("reading standard input, line {}", number + 1))?;
        if line.trim().is_empty() {
            continue;
        }
        chunk.push(line);
        if chunk.len() == LINES_PER_CHUNK {
            write_embeddings(&encoder, &chunk, args.json, &mut stdout)?;
            chunk.clear();
        }
    }
    write_embeddings(&encoder, &chunk, args.json, &mut stdout)?;
    stdout.flush().context("writing standard output")?;
    Ok(ExitCode::SUCCESS)
}

/// Embeds `lines` and writes one output line for each.
fn write_embeddings(
    encoder: &MpnetEncoder,
    lines: &[String],
    json: bool,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let sentences: Vec<&str> = lines.iter().map(String::as_str).collect();
    let vectors = encoder.embed(&sentences)?;
    for (text, embedding) in sentences.iter().zip(&vectors) {
        if json {
            serde_json::to_writer(&mut *out, &EmbeddingLine { text, embedding })?;
            writeln!(out)?;
        } else {
            let head: Vec<String> = embedding
                .iter()
                .take(4)
                .map(|x| format!("{x:.4}"))
                .collect();
            writeln!(
                out,
                "{text}\t[{}, …] ({} dims)",
                head.join(", "),
                embedding.len()
            )?;
        }
    }
    Ok(())
}
