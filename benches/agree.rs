//! `agree` at the scale of the spec: 10,000 items (a third of them
//! corruptions of another), 3 annotators rating every item, 1,000 bootstrap
//! resamples and 1,000 permutations. The budget is 5 s on the 2-core
//! machine; the statistics are O(n log n) per resample.

use std::collections::HashMap;

use criterion::{criterion_group, criterion_main, Criterion};
use mapvlm::agree::{analyse, Judged, MetricValues, Settings};
use mapvlm::dataset::{Corruption, Pair};
use mapvlm::stats::bootstrap::Bootstrap;
use mapvlm::stats::rng::{below, stream};

const ITEMS: usize = 10_000;

/// Items, scores and ratings from a fixed stream: scores on grids of
/// different coarseness (so ties occur), KAS missing for a fifth, ratings
/// that lean with PG2S.
fn data() -> (Vec<Pair>, HashMap<String, MetricValues>, Judged) {
    let mut rng = stream(2026, 0);
    let mut uniform = |grid: u64| below(&mut rng, grid + 1) as f64 / grid as f64;
    let mut items = Vec::new();
    let mut scores = HashMap::new();
    let mut ratings = Vec::new();
    for i in 0..ITEMS {
        let mut item = Pair::new(format!("t{i}"), vec!["A.".into()], vec!["B.".into()]);
        if i % 3 == 2 {
            item.source = Some(format!("t{}", i - 1));
            item.corruption = Some(Corruption {
                kind: ["drop", "reorder", "object-swap"][i % 9 / 3].into(),
                seed: 0,
                edits: Vec::new(),
                similarity: None,
                words: None,
                touches_task: None,
                adjacent: None,
                version: None,
            });
        }
        let pg2s = uniform(1_000_000);
        let kas = (uniform(10) > 0.2).then(|| uniform(1000));
        scores.insert(
            item.id.clone(),
            [Some(pg2s), Some(uniform(12)), Some(uniform(5)), kas],
        );
        for who in ["ana", "bo", "chen"] {
            let rating = (1.0 + (pg2s * 2.0 + uniform(2) * 2.0).round()).min(5.0);
            ratings.push((item.id.clone(), who.to_string(), rating));
        }
        items.push(item);
    }
    let judged = Judged {
        ratings,
        preferences: Vec::new(),
        step_labels: Vec::new(),
    };
    (items, scores, judged)
}

fn bench(c: &mut Criterion) {
    let (items, scores, judged) = data();
    let settings = Settings {
        aggregate: mapvlm::agree::Aggregate::Mean,
        bootstrap: Bootstrap {
            resamples: 1000,
            seed: 0,
        },
        permutations: 1000,
    };
    let mut group = c.benchmark_group("agree");
    group.sample_size(10);
    group.bench_function(
        "10000 items x 3 annotators, 1000 resamples, 1000 permutations",
        |b| b.iter(|| analyse(&items, &scores, Some(&judged), settings)),
    );
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
