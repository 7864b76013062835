//! Word vectors: loading the GloVe pack and one S_goal word similarity.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use mapvlm::metrics::WordVectors;
use mapvlm::models;
use mapvlm::nlp::wordvec::WordVectorTable;

fn glove_dir() -> std::path::PathBuf {
    models::models_dir(None).join(models::GLOVE_6B_50D)
}

fn wordvec(c: &mut Criterion) {
    let dir = glove_dir();
    c.bench_function("load_glove_pack", |b| {
        b.iter(|| WordVectorTable::load_glove_pack(black_box(&dir)))
    });
    let Ok(table) = WordVectorTable::load_glove_pack(&dir) else {
        panic!(
            "no GloVe pack in {} (run `mapvlm models fetch`)",
            dir.display()
        );
    };
    c.bench_function("similarity", |b| {
        b.iter(|| table.similarity(black_box("pick"), black_box("grab")))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = wordvec
}
criterion_main!(benches);
