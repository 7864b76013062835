//! Scoring one 6×10 plan pair with PG2S and KAS: cold (nothing cached, models
//! loaded) and warm (the same pair scored before, then one step edited), and
//! 40 golden pairs as `score --pairs` does them. Compare with
//! `scripts/bench_reference.py MODELS pair` and `... pairs40`.

use std::path::PathBuf;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use mapvlm::metrics::kas::kas;
use mapvlm::metrics::pg2s::{GoalModels, Pg2sScorer, Pg2sSettings};
use mapvlm::models::{models_dir, EN_CORE_WEB_SM, GLOVE_6B_50D, MPNET};
use mapvlm::nlp::en::EnPipeline;
use mapvlm::nlp::mpnet::MpnetEncoder;
use mapvlm::nlp::wordvec::WordVectorTable;

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
        Ok(models.goal.clone()),
        Pg2sSettings::default(),
    )
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
    pair.finish();
    let forty = &pairs[..40];
    let mut group = c.benchmark_group("score 40 golden pairs");
    group.sample_size(10);
    group.bench_function("batched and cached, models loaded", |b| {
        b.iter_batched(
            || scorer(&models),
            |s| {
                let steps: Vec<&str> = forty
                    .iter()
                    .flat_map(|(g, p)| g.iter().chain(p))
                    .map(String::as_str)
                    .collect();
                s.warm_up(&steps).unwrap_or_else(|e| panic!("{e}"));
                for (g, p) in forty {
                    s.score(g, p).unwrap_or_else(|e| panic!("{e}"));
                }
            },
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
