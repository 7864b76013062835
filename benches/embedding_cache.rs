//! The embedding cache per sentence: a lookup served from the disk store (a
//! fresh process's first sight of a stored sentence), and an insert (a miss
//! whose vector is stored). The network is replaced by a fixed 768-d vector,
//! so only the cache's own cost is measured.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use mapvlm::metrics::{ModelError, SentenceEncoder};
use mapvlm::nlp::embedding_cache::CachedEncoder;
use mapvlm::store::{DiskStore, DEFAULT_MAX_BYTES};

/// A 768-d unit vector for any sentence.
struct Fixed;

impl SentenceEncoder for Fixed {
    fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError> {
        Ok(sentences.iter().map(|_| vec![0.036_084_4; 768]).collect())
    }
}

fn encoder(dir: &std::path::Path) -> CachedEncoder {
    CachedEncoder::new(
        Some((DiskStore::new(dir, DEFAULT_MAX_BYTES), "bench".into())),
        Box::new(|| Ok(Arc::new(Fixed) as Arc<dyn SentenceEncoder>)),
    )
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let sentence = "Pick up the yellow sponge from the edge of the bathtub.";
    encoder(dir.path())
        .encode(&[sentence])
        .unwrap_or_else(|e| panic!("{e}"));
    let mut group = c.benchmark_group("embedding cache, one sentence");
    group.bench_function("lookup (disk hit)", |b| {
        b.iter_batched(
            || encoder(dir.path()),
            |cache| cache.encode(&[sentence]).unwrap_or_else(|e| panic!("{e}")),
            BatchSize::SmallInput,
        )
    });
    let fresh = AtomicU64::new(0);
    group.bench_function("insert (miss stored)", |b| {
        b.iter_batched(
            || {
                let n = fresh.fetch_add(1, Ordering::Relaxed);
                (encoder(dir.path()), format!("{sentence} {n}"))
            },
            |(cache, text)| cache.encode(&[&text]).unwrap_or_else(|e| panic!("{e}")),
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
