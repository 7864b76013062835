//! Throughput of the sentence encoder on the 64 benchmark steps of
//! `shared/golden/sentences.embed.txt`, with the cache off so every
//! iteration runs the network. Prints the achieved FLOP/s of the matrix
//! products beside criterion's timing.
//!
//! Needs the model pack (`$MAPVLM_MODELS`, else the user cache folder);
//! `scripts/bench` runs it together with the Python reference.

use std::time::Instant;

#[path = "support/mod.rs"]
mod support;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mapvlm::models::{models_dir, MPNET};
use mapvlm::nlp::mpnet::{MpnetEncoder, MpnetOptions};

const SENTENCES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/golden/sentences.embed.txt"
);

fn embed(c: &mut Criterion) {
    let dir = models_dir(None).join(MPNET);
    // No pack is a failure, never a silent skip (`./scripts/test` fetches it).
    assert!(
        dir.is_dir(),
        "no model pack at {}: run mapvlm models fetch",
        dir.display()
    );
    let options = MpnetOptions {
        cache: false,
        ..MpnetOptions::default()
    };
    let encoder = MpnetEncoder::load_with(&dir, options).expect("load the encoder");
    let text = std::fs::read_to_string(SENTENCES).expect("benchmark sentences");
    let all: Vec<&str> = text
        .lines()
        .filter(|line| !line.trim().is_empty())
        .collect();
    let sentences = all[..support::count(all.len(), 16)].to_vec();

    let flops = encoder.batch_flops(&sentences).expect("tokenise");
    let rounds = support::count(5, 1);
    let start = Instant::now();
    for _ in 0..rounds {
        encoder.embed(&sentences).expect("embed");
    }
    let seconds = start.elapsed().as_secs_f64() / rounds as f64;
    eprintln!(
        "embed {} sentences: {:.1} ms, {:.1} sentences/s, {:.2} GFLOP per pass, {:.1} GFLOP/s",
        sentences.len(),
        seconds * 1e3,
        sentences.len() as f64 / seconds,
        flops as f64 / 1e9,
        flops as f64 / seconds / 1e9
    );

    let mut group = c.benchmark_group("mpnet");
    group.throughput(Throughput::Elements(sentences.len() as u64));
    group.sample_size(10);
    group.bench_function("embed_64_steps", |b| {
        b.iter(|| encoder.embed(&sentences).expect("embed"))
    });
    group.finish();
}

criterion_group!(benches, embed);
criterion_main!(benches);
