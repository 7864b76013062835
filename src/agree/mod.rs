//! `agree` (`annotate.md` §4): how far the metrics agree with people.
//!
//! Joins the items (their `source` and `corruption`), the metrics' scores
//! and the current human judgements by item id, and computes the agreement
//! of every metric with the human score, the agreement between annotators,
//! the corruption-detection table and the agreement with pairwise
//! preferences. The statistics themselves live in [`crate::stats`]; this
//! module decides what is compared with what.

pub mod json;
pub mod plot;
pub mod report;
pub mod scores;

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crate::dataset::Pair;
use crate::stats::bootstrap::{percentile_interval, Bootstrap};
use crate::stats::correlation::{Correlations, Paired};
use crate::stats::krippendorff::{alpha, Level};
use crate::stats::permutation::{tau_b_difference, PermutationTest};
use crate::stats::pvalue::PValues;
use crate::stats::{Estimate, Undefined};

/// The metrics compared with people, in the order of every table.
pub const METRICS: [&str; 4] = ["pg2s", "s_plan", "s_goal", "kas"];

/// One item's metric values, in the order of [`METRICS`] (`None`: the
/// metric has no value for it, e.g. KAS of a plan without key actions).
pub type MetricValues = [Option<f64>; 4];

/// The current human judgements of items that are in the items file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Judged {
    /// Current ratings: (item, annotator, rating), in the order of their lines.
    pub ratings: Vec<(String, String, f64)>,
    /// Current preferences other than "neither": (preferred item, other item).
    pub preferences: Vec<(String, String)>,
}

/// How the resampling statistics are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Settings {
    /// Bootstrap resamples and the seed shared by both streams.
    pub bootstrap: Bootstrap,
    /// Permutations of the PG2S-against-KAS test.
    pub permutations: usize,
}

/// Everything `agree` reports.
#[derive(Debug, Clone, PartialEq)]
pub struct Agreement {
    /// Agreement with people; `None` when no annotations were given.
    pub human: Option<HumanAgreement>,
    /// Corruption detection: kind → metric (or `human`) → counts.
    pub corruption: BTreeMap<String, BTreeMap<String, Detection>>,
    /// The settings the intervals and the p-value were drawn with.
    pub settings: Settings,
}

/// The statistics that need human judgements.
#[derive(Debug, Clone, PartialEq)]
pub struct HumanAgreement {
    /// Items with at least one current rating.
    pub items: usize,
    /// Annotators with a current rating, sorted.
    pub annotators: Vec<String>,
    /// One entry per metric, in the order of [`METRICS`].
    pub metrics: Vec<MetricAgreement>,
    /// The paired permutation test of PG2S against KAS on tau-b.
    pub pg2s_vs_kas: Result<PermutationTest, Undefined>,
    /// Agreement between annotators.
    pub inter_annotator: InterAnnotator,
    /// Agreement with pairwise preferences, in the order of [`METRICS`].
    pub pairwise: Vec<PairwiseAgreement>,
}

/// One metric against the human score.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricAgreement {
    /// The metric's name (one of [`METRICS`]).
    pub metric: &'static str,
    /// The point estimates over the rated items that have the metric.
    pub correlations: Correlations,
    /// Their 95% percentile-bootstrap intervals.
    pub ci95: Intervals,
    /// The two-sided p-values of tau-b, rho and r (as scipy's).
    pub p_values: PValues,
    /// (human score, metric value) of every item compared, for plots.
    pub points: Vec<(f64, f64)>,
    /// The id of each point's item, in the order of `points` (the figure
    /// colours an item by its corruption kind).
    pub point_items: Vec<String>,
}

/// A confidence interval `[low, high]`, or why there is none.
pub type Interval = Result<[f64; 2], Undefined>;

/// The intervals of the four statistics of [`Correlations`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intervals {
    /// Of Kendall's tau-b.
    pub kendall_tau_b: Interval,
    /// Of Spearman's rho.
    pub spearman: Interval,
    /// Of Pearson's r.
    pub pearson: Interval,
    /// Of pairwise accuracy.
    pub pairwise_accuracy: Interval,
}

/// Agreement between annotators.
#[derive(Debug, Clone, PartialEq)]
pub struct InterAnnotator {
    /// Krippendorff's alpha, ordinal.
    pub ordinal: Estimate,
    /// Krippendorff's alpha, interval.
    pub interval: Estimate,
    /// Items rated by two or more annotators.
    pub shared_items: usize,
    /// For each pair of annotators (sorted), the items both rated.
    pub by_pair: Vec<(String, String, usize)>,
}

/// One metric against the pairwise preferences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairwiseAgreement {
    /// The metric's name.
    pub metric: &'static str,
    /// Preferences whose two items both have the metric's value.
    pub n: usize,
    /// The fraction the metric orders the same way (a tie is not agreement).
    pub agreement: Estimate,
}

/// One cell of the corruption table: how often the source scores higher.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Detection {
    /// Corrupted items compared with their source.
    pub n: usize,
    /// The source scored higher.
    pub detected: usize,
    /// Both scored the same.
    pub tied: usize,
    /// The corruption scored higher.
    pub reversed: usize,
}

impl Detection {
    fn count(&mut self, source: f64, corrupted: f64) {
        self.n += 1;
        if source > corrupted {
            self.detected += 1;
        } else if source == corrupted {
            self.tied += 1;
        } else {
            self.reversed += 1;
        }
    }
}

/// Computes every statistic of `agree` over these items, their scores (by
/// id; a source may be scored without being an item) and, when given, the
/// current judgements (of known items only).
pub fn analyse(
    items: &[Pair],
    scores: &HashMap<String, MetricValues>,
    judged: Option<&Judged>,
    settings: Settings,
) -> Agreement {
    let human_scores = judged.map(human_scores).unwrap_or_default();
    let human = judged.map(|j| human_agreement(j, &human_scores, scores, settings));
    Agreement {
        human,
        corruption: corruption(items, scores, &human_scores),
        settings,
    }
}

/// The mean of each item's current ratings.
fn human_scores(judged: &Judged) -> BTreeMap<String, f64> {
    let mut sums: BTreeMap<&str, (f64, u32)> = BTreeMap::new();
    for (item, _, rating) in &judged.ratings {
        let entry = sums.entry(item).or_default();
        entry.0 += rating;
        entry.1 += 1;
    }
    sums.into_iter()
        .map(|(item, (sum, n))| (item.to_string(), sum / f64::from(n)))
        .collect()
}

fn human_agreement(
    judged: &Judged,
    human: &BTreeMap<String, f64>,
    scores: &HashMap<String, MetricValues>,
    settings: Settings,
) -> HumanAgreement {
    let rated: Vec<&str> = human.keys().map(String::as_str).collect();
    let value = |item: &str, m: usize| scores.get(item).and_then(|v| v[m]);
    // For each metric: the indices (into `rated`) of the items it scores.
    let columns: Vec<Vec<usize>> = (0..METRICS.len())
        .map(|m| {
            (0..rated.len())
                .filter(|&i| value(rated[i], m).is_some())
                .collect()
        })
        .collect();
    let paired: Vec<Paired> = columns
        .iter()
        .enumerate()
        .map(|(m, idx)| {
            let x: Vec<f64> = idx.iter().filter_map(|&i| value(rated[i], m)).collect();
            let y: Vec<f64> = idx.iter().map(|&i| human[rated[i]]).collect();
            Paired::new(&x, &y)
        })
        .collect();
    let resampled = settings.bootstrap.map(rated.len(), |counts| {
        columns
            .iter()
            .zip(&paired)
            .map(|(idx, p)| {
                let w: Vec<u32> = idx.iter().map(|&i| counts[i]).collect();
                p.correlations_weighted(&w)
            })
            .collect::<Vec<_>>()
    });
    let metrics = (0..METRICS.len())
        .map(|m| {
            let interval = |f: fn(&Correlations) -> Estimate| {
                percentile_interval(resampled.iter().map(|r| f(&r[m])), 0.95)
            };
            MetricAgreement {
                metric: METRICS[m],
                correlations: paired[m].correlations(),
                p_values: paired[m].p_values(),
                ci95: Intervals {
                    kendall_tau_b: interval(|c| c.kendall_tau_b),
                    spearman: interval(|c| c.spearman),
                    pearson: interval(|c| c.pearson),
                    pairwise_accuracy: interval(|c| c.pairwise_accuracy),
                },
                points: columns[m]
                    .iter()
                    .filter_map(|&i| Some((human[rated[i]], value(rated[i], m)?)))
                    .collect(),
                point_items: columns[m].iter().map(|&i| rated[i].to_string()).collect(),
            }
        })
        .collect();
    let (pg2s, kas) = (0, 3);
    let both: Vec<&str> = rated
        .iter()
        .copied()
        .filter(|i| value(i, pg2s).is_some() && value(i, kas).is_some())
        .collect();
    let column = |m: usize| -> Vec<f64> { both.iter().filter_map(|i| value(i, m)).collect() };
    let pg2s_vs_kas = tau_b_difference(
        &column(pg2s),
        &column(kas),
        &both.iter().map(|i| human[*i]).collect::<Vec<_>>(),
        settings.permutations,
        settings.bootstrap.seed,
    );
    let annotators: Vec<String> = judged
        .ratings
        .iter()
        .map(|(_, a, _)| a.clone())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    HumanAgreement {
        items: rated.len(),
        inter_annotator: inter_annotator(judged, &rated, &annotators),
        annotators,
        metrics,
        pg2s_vs_kas,
        pairwise: pairwise(judged, scores),
    }
}

fn inter_annotator(judged: &Judged, rated: &[&str], annotators: &[String]) -> InterAnnotator {
    let unit: HashMap<&str, usize> = rated.iter().enumerate().map(|(u, &i)| (i, u)).collect();
    let coder: HashMap<&str, usize> = annotators
        .iter()
        .enumerate()
        .map(|(c, a)| (a.as_str(), c))
        .collect();
    let mut data = vec![vec![None; rated.len()]; annotators.len()];
    for (item, annotator, rating) in &judged.ratings {
        if let (Some(&u), Some(&c)) = (unit.get(item.as_str()), coder.get(annotator.as_str())) {
            data[c][u] = Some(*rating);
        }
    }
    let shared_items = (0..rated.len())
        .filter(|&u| data.iter().filter(|row| row[u].is_some()).count() >= 2)
        .count();
    let mut by_pair = Vec::new();
    for a in 0..annotators.len() {
        for b in a + 1..annotators.len() {
            let shared = (0..rated.len())
                .filter(|&u| data[a][u].is_some() && data[b][u].is_some())
                .count();
            by_pair.push((annotators[a].clone(), annotators[b].clone(), shared));
        }
    }
    let level = |level| {
        if annotators.len() < 2 || shared_items == 0 {
            Err(Undefined::NoSharedUnits)
        } else {
            alpha(&data, level)
        }
    };
    InterAnnotator {
        ordinal: level(Level::Ordinal),
        interval: level(Level::Interval),
        shared_items,
        by_pair,
    }
}

fn pairwise(judged: &Judged, scores: &HashMap<String, MetricValues>) -> Vec<PairwiseAgreement> {
    (0..METRICS.len())
        .map(|m| {
            let value = |item: &String| scores.get(item).and_then(|v| v[m]);
            let (mut n, mut agree) = (0usize, 0usize);
            for (better, worse) in &judged.preferences {
                if let (Some(b), Some(w)) = (value(better), value(worse)) {
                    n += 1;
                    agree += usize::from(b > w);
                }
            }
            PairwiseAgreement {
                metric: METRICS[m],
                n,
                agreement: if n == 0 {
                    Err(Undefined::NoPreferences)
                } else {
                    Ok(agree as f64 / n as f64)
                },
            }
        })
        .collect()
}

/// The corruption table. A corrupted item counts when it and its source are
/// both in the scores (as the reference does, this holds for the `human`
/// cell too); a metric's cell needs both values, the `human` cell both
/// human scores.
fn corruption(
    items: &[Pair],
    scores: &HashMap<String, MetricValues>,
    human: &BTreeMap<String, f64>,
) -> BTreeMap<String, BTreeMap<String, Detection>> {
    let mut table: BTreeMap<String, BTreeMap<String, Detection>> = BTreeMap::new();
    for item in items {
        let (Some(c), Some(source)) = (&item.corruption, &item.source) else {
            continue;
        };
        let (Some(src), Some(own)) = (scores.get(source), scores.get(&item.id)) else {
            continue;
        };
        let row = table.entry(c.kind.clone()).or_default();
        for (m, name) in METRICS.iter().enumerate() {
            if let (Some(a), Some(b)) = (src[m], own[m]) {
                row.entry((*name).to_string()).or_default().count(a, b);
            }
        }
        if let (Some(&a), Some(&b)) = (human.get(source), human.get(&item.id)) {
            row.entry("human".to_string()).or_default().count(a, b);
        }
    }
    table.retain(|_, row| !row.is_empty());
    table
}
