//! Scoring one 6×10 plan pair with PG2S and KAS: cold (nothing cached, models
//! loaded) and warm (the same pair scored before, then one step edited), and
//! 40 golden pairs as `score --pairs` does them: in memory, and through the
//! embedding store of `$XDG_CACHE_HOME/mapvlm/embeddings` cold (an empty
//! store) and warm (every sentence stored by an earlier run; the encoder is
//! never called). Beside them, what every start pays to trust the pack: the
//! three models' verification stamps checked against their files' metadata
//! (nothing is hashed when the files are unchanged), to be set against the
//! cold pair. Compare with `scripts/bench_reference.py MODELS pair` and
//! `... pairs40`; `scripts/bench` also times whole processes.

use std::path::PathBuf;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use mapvlm::metrics::kas::kas;
use mapvlm::metrics::pg2s::{GoalModels, Pg2sScorer, Pg2sSettings};
use mapvlm::metrics::SentenceEncoder;
use mapvlm::models::{models_dir, verified_model_path, EN_CORE_WEB_SM, GLOVE_6B_50D, MPNET};
use mapvlm::nlp::embedding_cache::CachedEncoder;
use mapvlm::nlp::en::EnPipeline;
use mapvlm::nlp::mpnet::{MpnetEncoder, MpnetOptions};
use mapvlm::nlp::wordvec::WordVectorTable;
use mapvlm::store::DiskStore;

#[path = "support/mod.rs"]
mod support;

struct Models {
    dir: PathBuf,
    goal: GoalModels,
}

fn load() -> Models {
    let dir = models_dir(None);
    let vectors =
        WordVectorTable::load_glove_pack(&dir.join(GLOVE_6B_50D)).unwrap_or_else(|e| panic!("{e}"));
    let parser = EnPipeline::load(&dir.join(EN_CORE_WEB_SM)).unwrap_or_else(|e| panic!("{e}"));
    Models {
        goal: GoalModels {
            vectors: Arc::new(vectors),
            parser: Arc::new(parser),
        },
        dir,
    }
}

/// A fresh scorer: an encoder with an empty cache, and no framed steps.
fn scorer(models: &Models) -> Pg2sScorer {
    let encoder = MpnetEncoder::load(&models.dir.join(MPNET)).unwrap_or_else(|e| panic!("{e}"));
    Pg2sScorer::new(
        Arc::new(encoder),
        Some(models.goal.clone()),
        Pg2sSettings::default(),
    )
}

/// A scorer whose sentences go through the embedding store in `dir`, as a
/// new `score` process's do; `network` embeds the misses (`None`: a miss
/// is an error, so a warm run provably never encodes).
fn stored_scorer(
    models: &Models,
    dir: &std::path::Path,
    network: Option<Arc<dyn SentenceEncoder>>,
) -> Pg2sScorer {
    let store = DiskStore::new(dir, 1 << 30);
    let encoder = CachedEncoder::new(
        Some((store, "bench-model".to_string())),
        Box::new(move || network.clone().ok_or_else(|| "a warm run encoded".into())),
    );
    Pg2sScorer::new(
        Arc::new(encoder),
        Some(models.goal.clone()),
        Pg2sSettings::default(),
    )
}

/// Scores `pairs` as `score --pairs` does: every step warmed up in one
/// batch, then each pair.
fn score_all(s: &Pg2sScorer, pairs: &[(Vec<String>, Vec<String>)]) {
    let steps: Vec<&str> = pairs
        .iter()
        .flat_map(|(g, p)| g.iter().chain(p))
        .map(String::as_str)
        .collect();
    s.warm_up(&steps).unwrap_or_else(|e| panic!("{e}"));
    for (g, p) in pairs {
        s.score(g, p).unwrap_or_else(|e| panic!("{e}"));
    }
}

fn golden_pairs() -> Vec<(Vec<String>, Vec<String>)> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/golden/pairs.dev.jsonl"
    );
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}"));
            let steps = |k: &str| -> Vec<String> {
                serde_json::from_value(v[k].clone()).unwrap_or_else(|e| panic!("{e}"))
            };
            (steps("gt"), steps("pred"))
        })
        .collect()
}

/// The first golden ground truth with six steps, and ten predicted steps
/// taken from the golden predictions (as `scripts/bench_reference.py` does).
fn six_by_ten(pairs: &[(Vec<String>, Vec<String>)]) -> (Vec<String>, Vec<String>) {
    let gt = pairs
        .iter()
        .find(|(gt, _)| gt.len() == 6)
        .map(|(gt, _)| gt.clone())
        .unwrap_or_default();
    let pred = pairs.iter().flat_map(|(_, p)| p.clone()).take(10).collect();
    (gt, pred)
}

fn bench(c: &mut Criterion) {
    let models = load();
    let pairs = golden_pairs();
    let (gt, pred) = six_by_ten(&pairs);
    let mut edited = pred.clone();
    edited[3].push_str(" Then wait.");

    let mut pair = c.benchmark_group("score 6x10 pair");
    pair.sample_size(10);
    pair.bench_function("cold", |b| {
        b.iter_batched(
            || scorer(&models),
            |s| {
                let report = s.score(&gt, &pred).unwrap_or_else(|e| panic!("{e}"));
                (report, kas(&gt, &pred))
            },
            BatchSize::PerIteration,
        )
    });
    pair.bench_function("warm, one step edited", |b| {
        b.iter_batched(
            || {
                let s = scorer(&models);
                s.score(&gt, &pred).unwrap_or_else(|e| panic!("{e}"));
                s
            },
            |s| {
                let report = s.score(&gt, &edited).unwrap_or_else(|e| panic!("{e}"));
                (report, kas(&gt, &edited))
            },
            BatchSize::PerIteration,
        )
    });
    pair.bench_function(
        "the pack's stamps checked at start (3 models, unchanged)",
        |b| {
            b.iter(|| {
                for folder in [MPNET, EN_CORE_WEB_SM, GLOVE_6B_50D] {
                    verified_model_path(&models.dir, folder).unwrap_or_else(|e| panic!("{e}"));
                }
            })
        },
    );
    pair.finish();
    let forty = &pairs[..support::count(40, 4)];
    let mut group = c.benchmark_group("score 40 golden pairs");
    group.sample_size(10);
    group.bench_function("batched and cached, models loaded", |b| {
        b.iter_batched(
            || scorer(&models),
            |s| score_all(&s, forty),
            BatchSize::PerIteration,
        )
    });
    let network: Arc<dyn SentenceEncoder> = Arc::new(
        MpnetEncoder::load_with(
            &models.dir.join(MPNET),
            MpnetOptions {
                cache: false,
                ..MpnetOptions::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}")),
    );
    group.bench_function("embedding store cold (empty)", |b| {
        b.iter_batched(
            || {
                let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
                let s = stored_scorer(&models, dir.path(), Some(Arc::clone(&network)));
                (dir, s)
            },
            |(_dir, s)| score_all(&s, forty),
            BatchSize::PerIteration,
        )
    });
    let warm = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    score_all(
        &stored_scorer(&models, warm.path(), Some(Arc::clone(&network))),
        forty,
    );
    group.bench_function("embedding store warm (never encodes)", |b| {
        b.iter_batched(
            || stored_scorer(&models, warm.path(), None),
            |s| score_all(&s, forty),
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
