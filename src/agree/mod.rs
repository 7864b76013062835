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
pub mod table;

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crate::dataset::Pair;
use crate::stats::bootstrap::{percentile, percentile_interval, Bootstrap};
use crate::stats::correlation::{Correlations, Paired};
use crate::stats::holm::holm;
use crate::stats::krippendorff::{alpha, alpha_weighted, Level};
use crate::stats::permutation::{tau_b_difference, PermutationTest};
use crate::stats::pvalue::PValues;
use crate::stats::williams::{williams_columns, Williams};
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
    /// Current step labels: (item, annotator, 0-based step, label); a step
    /// given several labels by one annotator has them joined by `+`.
    pub step_labels: Vec<(String, String, usize, String)>,
}

/// How the current ratings of an item make its human score.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Aggregate {
    /// The mean of its ratings.
    #[default]
    Mean,
    /// The median of its ratings.
    Median,
    /// The mean of its ratings as z-scores of each annotator (the rating
    /// minus the annotator's mean, over the annotator's population standard
    /// deviation, as `scipy.stats.zscore`), so that a harsh and a lenient
    /// annotator weigh alike.
    Z,
}

impl Aggregate {
    /// The name `--aggregate` takes.
    pub fn as_str(self) -> &'static str {
        match self {
            Aggregate::Mean => "mean",
            Aggregate::Median => "median",
            Aggregate::Z => "z",
        }
    }

    /// How an item's human score is made, in words, for every report and
    /// table that shows one (the human column of the corruption table too).
    pub fn describe(self) -> &'static str {
        match self {
            Aggregate::Mean => "the mean of an item's ratings",
            Aggregate::Median => "the median of an item's ratings",
            Aggregate::Z => "the mean of an item's ratings as per-annotator z-scores",
        }
    }
}

/// How the resampling statistics are drawn, and how ratings are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Settings {
    /// How an item's ratings make its human score.
    pub aggregate: Aggregate,
    /// Bootstrap resamples and the seed shared by both streams.
    pub bootstrap: Bootstrap,
    /// Permutations of the PG2S-against-KAS test.
    pub permutations: usize,
}

/// Below this many items a statistic is reported with a warning: it
/// rests on too few items to mean much.
pub const FEW_ITEMS: usize = 10;

/// Everything `agree` reports.
#[derive(Debug, Clone, PartialEq)]
pub struct Agreement {
    /// What the reader should know before trusting a number: statistics
    /// over very few items, resamples or permutations left out.
    pub warnings: Vec<String>,
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
    pub pg2s_vs_kas: KasTest,
    /// Williams' test of every pair of metrics on Pearson's r, in the order
    /// of [`METRICS`] (pg2s–s_plan, pg2s–s_goal, …, s_goal–kas).
    pub williams: Vec<MetricPairTest>,
    /// Agreement between annotators.
    pub inter_annotator: InterAnnotator,
    /// Agreement with pairwise preferences, in the order of [`METRICS`].
    pub pairwise: Vec<PairwiseAgreement>,
    /// The human ceiling: each annotator against the mean of the others.
    pub ceiling: Ceiling,
}

/// The human ceiling, the usual upper bound of metric–human agreement: for
/// each annotator, the correlation of their ratings with the mean rating of
/// the other annotators, over the items they rated that another annotator
/// rated too (leave one annotator out).
#[derive(Debug, Clone, PartialEq)]
pub struct Ceiling {
    /// (annotator, correlations), in the order of the annotators.
    pub by_annotator: Vec<(String, Correlations)>,
    /// The mean over annotators of each defined correlation; its `n` is the
    /// number of items the mean rests on, those rated by two or more
    /// annotators (not the sum of the annotators' n, which counts an item
    /// once per annotator who rated it).
    pub mean: Correlations,
}

/// The statistics of one column against one annotator's own ratings.
pub type ByAnnotator = Vec<(String, Correlations)>;

/// The paired permutation test of PG2S against KAS, with what it was
/// computed over even when it has no value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KasTest {
    /// The rated items that have both PG2S and KAS.
    pub n: usize,
    /// tau-b of PG2S minus tau-b of KAS over those items.
    pub difference: Estimate,
    /// The test itself (its p-value and the permutations that had a value).
    pub test: Result<PermutationTest, Undefined>,
    /// The permutations asked for (`--permutations`).
    pub asked: usize,
}

/// Williams' test of one pair of metrics: is the human score correlated
/// more with one than with the other (Pearson's r, over the rated items that
/// have both), with its p-value corrected by Holm over the pairs tested.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricPairTest {
    /// The two metrics (of [`METRICS`]); t > 0 when the first agrees more.
    pub metrics: [&'static str; 2],
    /// The rated items that have both metrics.
    pub n: usize,
    /// The test, or why there is none.
    pub test: Result<Williams, Undefined>,
    /// Its p-value adjusted by Holm's step-down correction over the family
    /// of the pairs that have a test.
    pub p_holm: Estimate,
}

/// Williams' test of every pair of metrics, with Holm's correction over
/// the pairs whose test is defined.
fn williams_tests(
    rated: &[&str],
    human: &BTreeMap<String, f64>,
    value: impl Fn(&str, usize) -> Option<f64>,
) -> Vec<MetricPairTest> {
    let mut pairs = Vec::new();
    for (a, first_name) in METRICS.iter().enumerate() {
        for (b, second_name) in METRICS.iter().enumerate().skip(a + 1) {
            let (mut h, mut first, mut second) = (Vec::new(), Vec::new(), Vec::new());
            for &item in rated {
                if let (Some(x), Some(y)) = (value(item, a), value(item, b)) {
                    h.push(human[item]);
                    first.push(x);
                    second.push(y);
                }
            }
            pairs.push((
                [*first_name, *second_name],
                h.len(),
                williams_columns(&h, &first, &second),
            ));
        }
    }
    let p: Vec<Estimate> = pairs
        .iter()
        .map(|(_, _, test)| test.map(|w| w.p_value))
        .collect();
    pairs
        .into_iter()
        .zip(holm(&p))
        .map(|((metrics, n, test), p_holm)| MetricPairTest {
            metrics,
            n,
            test,
            p_holm,
        })
        .collect()
}

impl KasTest {
    /// The permutations whose difference was defined (0 without a test).
    pub fn permutations_used(&self) -> usize {
        self.test.map_or(0, |t| t.permutations)
    }
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
    /// How many resamples each interval rests on (those on which the
    /// statistic was defined), in the order of the fields of [`Intervals`].
    pub ci95_resamples: [usize; 4],
    /// The two-sided p-values of tau-b, rho and r (as scipy's).
    pub p_values: PValues,
    /// The metric against each annotator's own ratings, over the items that
    /// annotator rated, in the order of the annotators.
    pub by_annotator: ByAnnotator,
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
    /// The 95% percentile-bootstrap intervals of the ordinal and interval
    /// alpha, on the resamples of the rated items that the correlations use.
    pub ci95: [Interval; 2],
    /// How many resamples each of those intervals rests on.
    pub ci95_resamples: [usize; 2],
    /// Krippendorff's alpha, nominal, of the step labels: a unit is a step of
    /// an item that an annotator labelled, a value the label given.
    pub step_labels: Estimate,
    /// Steps labelled by two or more annotators.
    pub step_labels_shared: usize,
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

/// The cell as the report and the tables write it: `source higher / tied /
/// corruption higher of n`.
impl std::fmt::Display for Detection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}/{}/{} of {}",
            self.detected, self.tied, self.reversed, self.n
        )
    }
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
    let mut warnings_out = Vec::new();
    let human_scores = judged
        .map(|j| human_scores(j, settings.aggregate, &mut warnings_out))
        .unwrap_or_default();
    let human = judged.map(|j| human_agreement(j, &human_scores, scores, settings));
    if let Some(h) = &human {
        warnings_out.extend(warnings(h, settings));
    }
    Agreement {
        warnings: warnings_out,
        human,
        corruption: corruption(items, scores, &human_scores),
        settings,
    }
}

/// Each item's human score: its current ratings combined by `aggregate`.
/// With z-scores, an annotator whose ratings are all the same has none,
/// and is left out with a warning.
fn human_scores(
    judged: &Judged,
    aggregate: Aggregate,
    warnings: &mut Vec<String>,
) -> BTreeMap<String, f64> {
    let mut by_item: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let standard = if aggregate == Aggregate::Z {
        z_parameters(judged, warnings)
    } else {
        HashMap::new()
    };
    for (item, annotator, rating) in &judged.ratings {
        let value = match aggregate {
            Aggregate::Z => match standard.get(annotator.as_str()) {
                Some((mean, sd)) => (rating - mean) / sd,
                None => continue,
            },
            _ => *rating,
        };
        by_item.entry(item).or_default().push(value);
    }
    by_item
        .into_iter()
        .map(|(item, mut values)| {
            let score = match aggregate {
                Aggregate::Median => {
                    values.sort_unstable_by(f64::total_cmp);
                    percentile(&values, 0.5)
                }
                _ => values.iter().sum::<f64>() / values.len() as f64,
            };
            (item.to_string(), score)
        })
        .collect()
}

/// The mean and population standard deviation of each annotator's current
/// ratings; annotators whose ratings do not vary are left out, with a warning.
fn z_parameters<'a>(
    judged: &'a Judged,
    warnings: &mut Vec<String>,
) -> HashMap<&'a str, (f64, f64)> {
    let mut by_annotator: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (_, annotator, rating) in &judged.ratings {
        by_annotator.entry(annotator).or_default().push(*rating);
    }
    let mut out = HashMap::new();
    for (annotator, ratings) in by_annotator {
        let n = ratings.len() as f64;
        let mean = ratings.iter().sum::<f64>() / n;
        let sd = (ratings.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
        if sd > 0.0 {
            out.insert(annotator, (mean, sd));
        } else {
            warnings.push(format!(
                "--aggregate z: {} gave every item the same rating, so has no z-scores; left out",
                crate::sanitize::for_terminal(annotator)
            ));
        }
    }
    out
}

/// Each annotator's own ratings by item.
fn ratings_by_annotator<'a>(
    judged: &'a Judged,
    annotators: &[String],
) -> Vec<BTreeMap<&'a str, f64>> {
    let mut out = vec![BTreeMap::new(); annotators.len()];
    for (item, annotator, rating) in &judged.ratings {
        if let Ok(a) = annotators.binary_search(annotator) {
            out[a].insert(item.as_str(), *rating);
        }
    }
    out
}

/// The human ceiling ([`Ceiling`]).
fn ceiling(own: &[BTreeMap<&str, f64>], annotators: &[String]) -> Ceiling {
    let mut shared: BTreeSet<&str> = BTreeSet::new();
    let by_annotator: Vec<(String, Correlations)> = annotators
        .iter()
        .enumerate()
        .map(|(a, name)| {
            let (mut x, mut y) = (Vec::new(), Vec::new());
            for (item, &rating) in &own[a] {
                let others: Vec<f64> = (0..own.len())
                    .filter(|&b| b != a)
                    .filter_map(|b| own[b].get(item).copied())
                    .collect();
                if !others.is_empty() {
                    shared.insert(item);
                    x.push(rating);
                    y.push(others.iter().sum::<f64>() / others.len() as f64);
                }
            }
            (name.clone(), Paired::new(&x, &y).correlations())
        })
        .collect();
    let mean = |f: fn(&Correlations) -> Estimate| -> Estimate {
        let defined: Vec<f64> = by_annotator.iter().filter_map(|(_, c)| f(c).ok()).collect();
        crate::stats::summary::mean(&defined).map_err(|_| Undefined::NoSharedUnits)
    };
    Ceiling {
        mean: Correlations {
            n: shared.len() as u64,
            kendall_tau_b: mean(|c| c.kendall_tau_b),
            spearman: mean(|c| c.spearman),
            pearson: mean(|c| c.pearson),
            pairwise_accuracy: mean(|c| c.pairwise_accuracy),
        },
        by_annotator,
    }
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
    let annotators: Vec<String> = judged
        .ratings
        .iter()
        .map(|(_, a, _)| a.clone())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let matrix = coder_matrix(judged, &rated, &annotators);
    let alphas = |weights: &[u32]| {
        [Level::Ordinal, Level::Interval].map(|level| {
            if annotators.len() < 2 {
                Err(Undefined::NoSharedUnits)
            } else {
                alpha_weighted(&matrix, level, weights)
            }
        })
    };
    let both_resampled = settings.bootstrap.map(rated.len(), |counts| {
        let correlations = columns
            .iter()
            .zip(&paired)
            .map(|(idx, p)| {
                let w: Vec<u32> = idx.iter().map(|&i| counts[i]).collect();
                p.correlations_weighted(&w)
            })
            .collect::<Vec<_>>();
        (correlations, alphas(counts))
    });
    let (resampled, alpha_resampled): (Vec<_>, Vec<_>) = both_resampled.into_iter().unzip();
    let alpha_ci = [0, 1]
        .map(|k| percentile_interval(alpha_resampled.iter().map(|a: &[Estimate; 2]| a[k]), 0.95));
    let alpha_used = [0, 1].map(|k| alpha_resampled.iter().filter(|a| a[k].is_ok()).count());
    let own = ratings_by_annotator(judged, &annotators);
    let metrics = (0..METRICS.len())
        .map(|m| {
            let interval = |f: fn(&Correlations) -> Estimate| {
                percentile_interval(resampled.iter().map(|r| f(&r[m])), 0.95)
            };
            let used = |f: fn(&Correlations) -> Estimate| {
                resampled.iter().filter(|r| f(&r[m]).is_ok()).count()
            };
            MetricAgreement {
                metric: METRICS[m],
                ci95_resamples: [
                    used(|c| c.kendall_tau_b),
                    used(|c| c.spearman),
                    used(|c| c.pearson),
                    used(|c| c.pairwise_accuracy),
                ],
                correlations: paired[m].correlations(),
                by_annotator: annotators
                    .iter()
                    .zip(&own)
                    .map(|(name, theirs)| {
                        let (x, y): (Vec<f64>, Vec<f64>) = theirs
                            .iter()
                            .filter_map(|(item, &r)| Some((value(item, m)?, r)))
                            .unzip();
                        (name.clone(), Paired::new(&x, &y).correlations())
                    })
                    .collect(),
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
    let human_both: Vec<f64> = both.iter().map(|i| human[*i]).collect();
    let (a, b) = (column(pg2s), column(kas));
    let all = vec![1u32; both.len()];
    let tau = |x: &[f64]| Paired::new(x, &human_both).kendall_tau_b(&all);
    let pg2s_vs_kas = KasTest {
        n: both.len(),
        difference: tau(&a).and_then(|ta| tau(&b).map(|tb| ta - tb)),
        test: tau_b_difference(
            &a,
            &b,
            &human_both,
            settings.permutations,
            settings.bootstrap.seed,
        ),
        asked: settings.permutations,
    };
    let williams = williams_tests(&rated, human, value);
    let mut inter_annotator = inter_annotator(&matrix, &annotators);
    inter_annotator.ci95 = alpha_ci;
    inter_annotator.ci95_resamples = alpha_used;
    (
        inter_annotator.step_labels,
        inter_annotator.step_labels_shared,
    ) = step_label_alpha(judged);
    HumanAgreement {
        items: rated.len(),
        ceiling: ceiling(&own, &annotators),
        inter_annotator,
        annotators,
        metrics,
        pg2s_vs_kas,
        williams,
        pairwise: pairwise(judged, scores),
    }
}

/// The warnings of a result: statistics over fewer than [`FEW_ITEMS`]
/// items, intervals or tests that rest on fewer resamples or permutations
/// than were asked for.
fn warnings(h: &HumanAgreement, settings: Settings) -> Vec<String> {
    let mut out = Vec::new();
    let few = |n: usize| n > 0 && n < FEW_ITEMS;
    let asked = settings.bootstrap.resamples;
    let names = ["tau-b", "rho", "r", "pairwise accuracy"];
    for m in &h.metrics {
        let n = m.correlations.n as usize;
        if few(n) {
            out.push(format!("{}: correlations over {n} items", m.metric));
        }
        for (name, &used) in names.iter().zip(&m.ci95_resamples) {
            if n > 0 && used < asked {
                out.push(format!(
                    "{} {name}: interval over {used} of {asked} resamples (undefined on the others)",
                    m.metric
                ));
            }
        }
    }
    let t = &h.pg2s_vs_kas;
    if few(t.n) {
        out.push(format!("PG2S against KAS over {} items", t.n));
    }
    if t.difference.is_ok() && t.permutations_used() < t.asked {
        out.push(format!(
            "PG2S against KAS: {} of {} permutations had a defined tau-b",
            t.permutations_used(),
            t.asked
        ));
    }
    for w in &h.williams {
        if few(w.n) {
            out.push(format!(
                "Williams' test of {} against {} over {} items",
                w.metrics[0], w.metrics[1], w.n
            ));
        }
    }
    let ia = &h.inter_annotator;
    if few(ia.shared_items) {
        out.push(format!(
            "Krippendorff's alpha over {} shared items",
            ia.shared_items
        ));
    }
    for (name, &used) in ["ordinal", "interval"].iter().zip(&ia.ci95_resamples) {
        if ia.shared_items > 0 && used < asked {
            out.push(format!(
                "alpha {name}: interval over {used} of {asked} resamples (undefined on the others)"
            ));
        }
    }
    if few(ia.step_labels_shared) {
        out.push(format!(
            "nominal alpha of the step labels over {} shared steps",
            ia.step_labels_shared
        ));
    }
    out
}

/// The ratings as coders × units (one row per annotator, one column per
/// rated item), as Krippendorff's alpha reads them.
fn coder_matrix(judged: &Judged, rated: &[&str], annotators: &[String]) -> Vec<Vec<Option<f64>>> {
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
    data
}

/// Nominal alpha of the step labels and how many labelled steps two or more
/// annotators labelled.
fn step_label_alpha(judged: &Judged) -> (Estimate, usize) {
    let mut units: BTreeMap<(&str, usize), BTreeMap<&str, &str>> = BTreeMap::new();
    let mut labels: BTreeSet<&str> = BTreeSet::new();
    for (item, annotator, step, label) in &judged.step_labels {
        units
            .entry((item.as_str(), *step))
            .or_default()
            .insert(annotator.as_str(), label.as_str());
        labels.insert(label.as_str());
    }
    let coders: BTreeSet<&str> = units.values().flat_map(|u| u.keys().copied()).collect();
    let code = |label: &str| labels.iter().position(|&l| l == label).map(|p| p as f64);
    let data: Vec<Vec<Option<f64>>> = coders
        .iter()
        .map(|c| {
            units
                .values()
                .map(|u| u.get(c).and_then(|l| code(l)))
                .collect()
        })
        .collect();
    let shared = units.values().filter(|u| u.len() >= 2).count();
    let estimate = if shared == 0 {
        Err(Undefined::NoSharedSteps)
    } else {
        alpha(&data, Level::Nominal)
    };
    (estimate, shared)
}

/// Krippendorff's alpha of the coder matrix and the items it shares.
fn inter_annotator(data: &[Vec<Option<f64>>], annotators: &[String]) -> InterAnnotator {
    let units = data.first().map_or(0, Vec::len);
    let shared_items = (0..units)
        .filter(|&u| data.iter().filter(|row| row[u].is_some()).count() >= 2)
        .count();
    let mut by_pair = Vec::new();
    for a in 0..annotators.len() {
        for b in a + 1..annotators.len() {
            let shared = (0..units)
                .filter(|&u| data[a][u].is_some() && data[b][u].is_some())
                .count();
            by_pair.push((annotators[a].clone(), annotators[b].clone(), shared));
        }
    }
    let level = |level| {
        if annotators.len() < 2 || shared_items == 0 {
            Err(Undefined::NoSharedUnits)
        } else {
            alpha(data, level)
        }
    };
    InterAnnotator {
        ordinal: level(Level::Ordinal),
        interval: level(Level::Interval),
        ci95: [Err(Undefined::NoResample); 2],
        ci95_resamples: [0; 2],
        step_labels: Err(Undefined::NoSharedSteps),
        step_labels_shared: 0,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(resamples: usize, permutations: usize) -> Settings {
        Settings {
            aggregate: Aggregate::Mean,
            bootstrap: Bootstrap { resamples, seed: 5 },
            permutations,
        }
    }

    fn scores(rows: &[(&str, MetricValues)]) -> HashMap<String, MetricValues> {
        rows.iter().map(|(id, v)| (id.to_string(), *v)).collect()
    }

    fn ratings(rows: &[(&str, &str, f64)]) -> Judged {
        Judged {
            ratings: rows
                .iter()
                .map(|(i, a, r)| (i.to_string(), a.to_string(), *r))
                .collect(),
            ..Judged::default()
        }
    }

    #[test]
    fn every_key_is_there_with_null_and_a_reason() {
        // Two items; KAS is the same on both, so its tau-b, the difference
        // and the test are undefined, and nothing has S_plan.
        let scores = scores(&[
            ("a", [Some(0.2), None, Some(0.1), Some(0.3)]),
            ("b", [Some(0.4), None, Some(0.9), Some(0.3)]),
        ]);
        let judged = ratings(&[("a", "x", 1.0), ("b", "x", 3.0)]);
        let agreement = analyse(&[], &scores, Some(&judged), settings(20, 50));
        let doc = json::to_json(&agreement);
        let test = &doc["pg2s_vs_kas"];
        assert_eq!(test["n"], 2);
        assert!(test["difference"].is_null() && test["p_value"].is_null());
        assert_eq!(
            test["reasons"]["difference"],
            "the metric column is constant"
        );
        assert_eq!(test["permutations"], 0);
        assert_eq!(test["permutations_asked"], 50);
        let s_plan = &doc["metrics"]["s_plan"];
        assert_eq!(s_plan["n"], 0);
        assert!(s_plan["kendall_tau_b"].is_null());
        assert_eq!(s_plan["reasons"]["kendall_tau_b"], "fewer than two items");
        assert_eq!(s_plan["ci95_resamples"]["pearson"], 0);
        let warnings = doc["warnings"].as_array().cloned().unwrap_or_default();
        assert!(
            warnings.contains(&"pg2s: correlations over 2 items".into()),
            "{warnings:?}"
        );
        assert!(
            warnings.contains(&"PG2S against KAS over 2 items".into()),
            "{warnings:?}"
        );
        // Williams' test needs four items: every pair is there, null, with why.
        let williams = &doc["williams"];
        assert_eq!(williams["holm_family"], 0);
        let pairs = williams["pairs"].as_object().cloned().unwrap_or_default();
        assert_eq!(pairs.len(), 6, "{pairs:?}");
        let pg2s_kas = &pairs["pg2s_vs_kas"];
        assert_eq!(
            (&pg2s_kas["n"], &pg2s_kas["first"]),
            (&2.into(), &"pg2s".into())
        );
        for key in ["r_first", "t", "df", "p_value", "p_holm"] {
            assert!(pg2s_kas[key].is_null(), "{key}");
            assert_eq!(pg2s_kas["reasons"][key], "fewer than four items");
        }
        assert_eq!(pairs["pg2s_vs_s_plan"]["n"], 0);
        let without = json::to_json(&analyse(&[], &scores, None, settings(20, 50)));
        for key in [
            "items",
            "metrics",
            "pg2s_vs_kas",
            "williams",
            "inter_annotator",
            "pairwise",
        ] {
            assert!(without[key].is_null(), "{key}");
            assert_eq!(without["reasons"][key], "no annotations given");
        }
    }

    #[test]
    fn alpha_has_an_interval_on_the_resamples_of_the_correlations() {
        // Three items, two annotators: the interval is the percentile
        // interval of alpha on each resample of the three items.
        let scores = scores(&[
            ("a", [Some(0.1), None, None, None]),
            ("b", [Some(0.5), None, None, None]),
            ("c", [Some(0.9), None, None, None]),
        ]);
        let mut judged = ratings(&[
            ("a", "x", 1.0),
            ("b", "x", 3.0),
            ("c", "x", 5.0),
            ("a", "y", 2.0),
            ("b", "y", 3.0),
            ("c", "y", 4.0),
        ]);
        let step = |i: &str, a: &str, s, l: &str| (i.into(), a.into(), s, l.to_string());
        judged.step_labels = vec![
            step("a", "x", 0, "ok"),
            step("a", "y", 0, "ok"),
            step("b", "x", 1, "unsafe"),
            step("b", "y", 1, "unsafe"),
            step("c", "x", 2, "unsafe"),
            step("c", "y", 2, "ok"),
        ];
        let s = settings(300, 10);
        let h = analyse(&[], &scores, Some(&judged), s)
            .human
            .unwrap_or_else(|| panic!("no human part"));
        let ia = &h.inter_annotator;
        // Interval alpha by hand: pairable values 1, 2, 3, 3, 5, 4 (n = 6);
        // D_o = 2·1² + 0 + 2·1² = 4 over ordered pairs within units;
        // D_e = 2·(6·Σv² − (Σv)²) / (n − 1) = 2·(384 − 324) / 5 = 24.
        assert_eq!(
            ia.interval.map(|a| (a * 1e12).round()),
            Ok((5e12 / 6.0_f64).round())
        );
        let data = vec![
            vec![Some(1.0), Some(3.0), Some(5.0)],
            vec![Some(2.0), Some(3.0), Some(4.0)],
        ];
        let by_resample: Vec<Estimate> = (0..300)
            .map(|b| alpha_weighted(&data, Level::Interval, &s.bootstrap.counts(b, 3)))
            .collect();
        let used = by_resample.iter().filter(|a| a.is_ok()).count();
        assert_eq!(ia.ci95_resamples[1], used);
        assert!(used > 200 && used < 300, "{used}");
        assert_eq!(ia.ci95[1], percentile_interval(by_resample, 0.95));
        // Step labels: units (a,0) ok/ok, (b,1) unsafe/unsafe, (c,2)
        // unsafe/ok: the nominal case worked by hand in stats::krippendorff.
        let nominal = ia.step_labels.unwrap_or(f64::NAN);
        assert!((nominal - (1.0 - 2.0 / 3.6)).abs() < 1e-12, "{nominal}");
        assert_eq!(ia.step_labels_shared, 3);
    }

    /// Items that have PG2S only.
    fn pg2s_only(rows: &[(&str, f64)]) -> HashMap<String, MetricValues> {
        rows.iter()
            .map(|&(id, v)| (id.to_string(), [Some(v), None, None, None]))
            .collect()
    }

    /// Three annotators over five items (`y` leaves `e` out).
    fn three_annotators() -> (HashMap<String, MetricValues>, Judged) {
        let scores = pg2s_only(&[("a", 0.1), ("b", 0.3), ("c", 0.2), ("d", 0.8), ("e", 0.7)]);
        let mut rows = Vec::new();
        for (who, ratings) in [
            (
                "x",
                [("a", 1.0), ("b", 2.0), ("c", 3.0), ("d", 4.0), ("e", 5.0)].as_slice(),
            ),
            ("y", &[("a", 2.0), ("b", 2.0), ("c", 4.0), ("d", 5.0)]),
            (
                "z",
                &[("a", 1.0), ("c", 2.0), ("d", 4.0), ("e", 4.0), ("b", 3.0)],
            ),
        ] {
            rows.extend(ratings.iter().map(|&(i, r)| (i, who, r)));
        }
        (scores, ratings(&rows))
    }

    fn near(e: Estimate, want: f64) {
        let got = e.unwrap_or(f64::NAN);
        assert!((got - want).abs() < 1e-12, "{got} against {want}");
    }

    #[test]
    fn the_ceiling_and_the_annotators_match_definitional_python() {
        // scipy 1.17.1: each annotator against the mean of the others, and
        // PG2S against each annotator (/tmp scratch ceiling.py).
        let (scores, judged) = three_annotators();
        let h = analyse(&[], &scores, Some(&judged), settings(10, 10))
            .human
            .unwrap_or_else(|| panic!("no human part"));
        let want = [
            (
                "x",
                5,
                0.7999999999999999,
                0.8999999999999998,
                0.9271726499455307,
            ),
            (
                "y",
                4,
                0.7999999999999999,
                0.8333333333333335,
                0.816496580927726,
            ),
            (
                "z",
                5,
                0.7378647873726218,
                0.8720815992723809,
                0.7922178413538746,
            ),
        ];
        for ((name, c), (w, n, tau, rho, r)) in h.ceiling.by_annotator.iter().zip(want) {
            assert_eq!((name.as_str(), c.n), (w, n));
            near(c.kendall_tau_b, tau);
            near(c.spearman, rho);
            near(c.pearson, r);
        }
        near(
            h.ceiling.mean.kendall_tau_b,
            (0.7999999999999999 * 2.0 + 0.7378647873726218) / 3.0,
        );
        let want = [
            ("x", 5, 0.6, 0.7999999999999999, 0.8630442403635761),
            (
                "y",
                4,
                0.5477225575051662,
                0.632455532033676,
                0.7504787743864566,
            ),
            (
                "z",
                5,
                0.9486832980505137,
                0.9746794344808964,
                0.9357789437979189,
            ),
        ];
        for ((name, c), (w, n, tau, rho, r)) in h.metrics[0].by_annotator.iter().zip(want) {
            assert_eq!((name.as_str(), c.n), (w, n));
            near(c.kendall_tau_b, tau);
            near(c.spearman, rho);
            near(c.pearson, r);
        }
    }

    #[test]
    fn the_ceilings_n_counts_the_items_it_rests_on_once() {
        // x and y share b, y and z share c: the ceiling rests on b and c,
        // though x's, y's and z's n are 1, 2 and 1.
        let scores = pg2s_only(&[("a", 0.1), ("b", 0.2), ("c", 0.3), ("d", 0.4)]);
        let judged = ratings(&[
            ("a", "x", 1.0),
            ("b", "x", 2.0),
            ("b", "y", 3.0),
            ("c", "y", 4.0),
            ("c", "z", 5.0),
            ("d", "z", 1.0),
        ]);
        let agreement = analyse(&[], &scores, Some(&judged), settings(10, 10));
        let h = agreement
            .human
            .as_ref()
            .unwrap_or_else(|| panic!("no human part"));
        let each: Vec<u64> = h.ceiling.by_annotator.iter().map(|(_, c)| c.n).collect();
        assert_eq!(each, [1, 2, 1]);
        assert_eq!(h.ceiling.mean.n, 2);
        assert_eq!(h.inter_annotator.shared_items, 2);
        assert_eq!(json::to_json(&agreement)["human_ceiling"]["mean"]["n"], 2);
        // Three annotators over five items, each rated by two or more.
        let (scores, judged) = three_annotators();
        let h = analyse(&[], &scores, Some(&judged), settings(10, 10)).human;
        assert_eq!(h.map(|h| h.ceiling.mean.n), Some(5));
    }

    #[test]
    fn z_scores_and_the_median_match_definitional_python() {
        let (scores, judged) = three_annotators();
        let with = |aggregate| {
            let s = Settings {
                aggregate,
                ..settings(10, 10)
            };
            let mut warnings = Vec::new();
            let h = human_scores(&judged, aggregate, &mut warnings);
            assert!(warnings.is_empty(), "{warnings:?}");
            (h, analyse(&[], &scores, Some(&judged), s))
        };
        // The mean over annotators of scipy.stats.zscore of each one's ratings.
        let (z, agreement) = with(Aggregate::Z);
        for (item, want) in [
            ("a", -1.3066504257683504),
            ("b", -0.49928621489780495),
            ("c", -0.03621469046013651),
            ("d", 1.0277496400502426),
            ("e", 1.2216025366140741),
        ] {
            near(Ok(z[item]), want);
        }
        let pg2s = |a: &Agreement| a.human.as_ref().map(|h| h.metrics[0].correlations);
        near(
            pg2s(&agreement).map_or(Err(Undefined::NoResample), |c| c.kendall_tau_b),
            0.6,
        );
        let (median, agreement) = with(Aggregate::Median);
        assert_eq!(median["e"], 4.5);
        assert_eq!(median["b"], 2.0);
        near(
            pg2s(&agreement).map_or(Err(Undefined::NoResample), |c| c.pearson),
            0.8745845667776,
        );
        // An annotator who gives one rating throughout has no z-scores.
        let flat = ratings(&[
            ("a", "x", 1.0),
            ("b", "x", 3.0),
            ("a", "q", 4.0),
            ("b", "q", 4.0),
        ]);
        let mut warnings = Vec::new();
        let z = human_scores(&flat, Aggregate::Z, &mut warnings);
        assert_eq!((z["a"], z["b"]), (-1.0, 1.0));
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("q gave every item the same rating"));
    }

    #[test]
    fn williams_tests_every_pair_and_holm_corrects_over_those_tested() {
        // Six items with PG2S, S_goal and KAS; S_plan on three only, so its
        // pairs have no test and the family is the other three pairs.
        let rows: Vec<(String, MetricValues)> = (0..6)
            .map(|i| {
                let v = f64::from(i);
                let s_plan = (i < 3).then_some(v / 10.0);
                let values = [
                    Some(v / 6.0),
                    s_plan,
                    Some(((v * 7.0) % 5.0) / 5.0),
                    Some(((v * 3.0) % 4.0) / 4.0),
                ];
                (format!("i{i}"), values)
            })
            .collect();
        let scores: HashMap<String, MetricValues> = rows.into_iter().collect();
        let judged = ratings(&[
            ("i0", "x", 1.0),
            ("i1", "x", 3.0),
            ("i2", "x", 2.0),
            ("i3", "x", 5.0),
            ("i4", "x", 3.0),
            ("i5", "x", 4.0),
        ]);
        let h = analyse(&[], &scores, Some(&judged), settings(10, 10))
            .human
            .unwrap_or_else(|| panic!("no human part"));
        let names: Vec<[&str; 2]> = h.williams.iter().map(|w| w.metrics).collect();
        assert_eq!(
            names,
            [
                ["pg2s", "s_plan"],
                ["pg2s", "s_goal"],
                ["pg2s", "kas"],
                ["s_plan", "s_goal"],
                ["s_plan", "kas"],
                ["s_goal", "kas"]
            ]
        );
        let human: Vec<f64> = judged.ratings.iter().map(|r| r.2).collect();
        let column =
            |m: usize| -> Vec<f64> { (0..6).filter_map(|i| scores[&format!("i{i}")][m]).collect() };
        let mut raw = Vec::new();
        for w in &h.williams {
            let [a, b] = w
                .metrics
                .map(|m| METRICS.iter().position(|&n| n == m).unwrap_or(9));
            if a == 1 || b == 1 {
                assert_eq!((w.n, w.test), (3, Err(Undefined::FewerThanFourItems)));
                assert_eq!(w.p_holm, Err(Undefined::FewerThanFourItems));
                continue;
            }
            assert_eq!(w.n, 6);
            let want = crate::stats::williams::williams_columns(&human, &column(a), &column(b));
            assert_eq!(w.test, want);
            raw.push(want.map(|t| t.p_value).unwrap_or(f64::NAN));
        }
        // Holm by hand over the three defined p-values.
        let mut sorted = raw.clone();
        sorted.sort_by(f64::total_cmp);
        let step = [
            3.0 * sorted[0],
            (3.0 * sorted[0]).max(2.0 * sorted[1]),
            (3.0 * sorted[0]).max(2.0 * sorted[1]).max(sorted[2]),
        ]
        .map(|v| v.min(1.0));
        let defined: Vec<f64> = h.williams.iter().filter_map(|w| w.p_holm.ok()).collect();
        for (p, adjusted) in raw.iter().zip(&defined) {
            let rank = sorted.iter().position(|s| s == p).unwrap_or(9);
            assert_eq!(*adjusted, step[rank]);
        }
        assert_eq!(defined.len(), 3);
    }

    #[test]
    fn the_resamples_an_interval_rests_on_are_counted() {
        // Two items with different scores: tau-b is defined on a resample
        // exactly when it holds both items once each.
        let scores = scores(&[
            ("a", [Some(0.2), None, None, Some(0.3)]),
            ("b", [Some(0.4), None, None, Some(0.1)]),
        ]);
        let judged = ratings(&[("a", "x", 1.0), ("b", "x", 3.0)]);
        let s = settings(200, 40);
        let agreement = analyse(&[], &scores, Some(&judged), s);
        let both = (0..200)
            .filter(|&b| s.bootstrap.counts(b, 2) == [1, 1])
            .count();
        assert!(both > 50 && both < 150, "{both}");
        let h = agreement
            .human
            .as_ref()
            .unwrap_or_else(|| panic!("no human part"));
        assert_eq!(h.metrics[0].ci95_resamples[0], both);
        assert_eq!(h.metrics[0].ci95_resamples[3], both);
        let warning =
            format!("pg2s tau-b: interval over {both} of 200 resamples (undefined on the others)");
        assert!(
            agreement.warnings.contains(&warning),
            "{:?}",
            agreement.warnings
        );
        // Swapping the ranks of two items: half the swaps tie the columns.
        let t = h.pg2s_vs_kas;
        assert_eq!((t.n, t.difference), (2, Ok(2.0)));
        assert!(t.permutations_used() < 40, "{t:?}");
        assert!(agreement
            .warnings
            .iter()
            .any(|w| w.ends_with("of 40 permutations had a defined tau-b")));
    }
}
