//! Words per second of the English pipeline on the golden step sentences
//! and on long prose-like text.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mapvlm::models::{models_dir, EN_CORE_WEB_SM};
use mapvlm::nlp::en::EnPipeline;

#[path = "support/mod.rs"]
mod support;

const SENTENCES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/golden/sentences.dev.txt"
);

fn bench(c: &mut Criterion) {
    let dir = models_dir(None).join(EN_CORE_WEB_SM);
    let nlp = EnPipeline::load(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let text = std::fs::read_to_string(SENTENCES).unwrap_or_else(|e| panic!("{SENTENCES}: {e}"));
    let all: Vec<&str> = text.lines().collect();
    let sentences = &all[..support::count(all.len(), 20)];
    let words: usize = sentences.iter().map(|s| nlp.analyse(s).len()).sum();
    let mut group = c.benchmark_group("en_parse");
    group.sample_size(10);
    group.throughput(Throughput::Elements(words as u64));
    group.bench_function("golden_steps", |b| {
        b.iter(|| {
            sentences
                .iter()
                .map(|s| nlp.analyse(s).len())
                .sum::<usize>()
        })
    });
    let prose = sentences.join(" ");
    group.throughput(Throughput::Elements(nlp.analyse(&prose).len() as u64));
    group.bench_function("one_long_text", |b| b.iter(|| nlp.analyse(&prose).len()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
