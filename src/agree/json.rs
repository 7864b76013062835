//! The `--json` document of `agree`, in the shape of `annotate.md` §4: an
//! undefined statistic is `null` at its own key, with its reason in a
//! `reasons` map beside it.

use serde_json::{json, Map, Value};

use super::{Agreement, Detection, HumanAgreement, InterAnnotator, MetricPairTest};
use crate::stats::correlation::Correlations;
use crate::stats::Undefined;

/// The keys that need human judgements, `null` without annotations.
const HUMAN_KEYS: [&str; 8] = [
    "items",
    "human_ceiling",
    "annotators",
    "metrics",
    "pg2s_vs_kas",
    "williams",
    "inter_annotator",
    "pairwise",
];

/// The whole document.
pub fn to_json(agreement: &Agreement) -> Value {
    let mut doc = Map::new();
    match &agreement.human {
        Some(human) => human_json(human, &mut doc),
        None => {
            // Every key is there; each is null for the same reason.
            let mut reasons = Map::new();
            for key in HUMAN_KEYS {
                doc.insert(key.into(), Value::Null);
                reasons.insert(key.into(), json!("no annotations given"));
            }
            doc.insert("reasons".into(), Value::Object(reasons));
        }
    }
    let corruption: Map<String, Value> = agreement
        .corruption
        .iter()
        .map(|(kind, row)| {
            let cells = row
                .iter()
                .map(|(m, cell)| (m.clone(), detection(cell)))
                .collect();
            (kind.clone(), Value::Object(cells))
        })
        .collect();
    doc.insert("corruption".into(), Value::Object(corruption));
    let s = agreement.settings;
    doc.insert(
        "settings".into(),
        json!({"aggregate": s.aggregate.as_str(), "bootstrap": s.bootstrap.resamples, "permutations": s.permutations, "seed": s.bootstrap.seed}),
    );
    doc.insert("warnings".into(), json!(agreement.warnings));
    Value::Object(doc)
}

fn human_json(h: &HumanAgreement, doc: &mut Map<String, Value>) {
    doc.insert("items".into(), json!(h.items));
    doc.insert("annotators".into(), json!(h.annotators));
    let metrics: Map<String, Value> = h
        .metrics
        .iter()
        .map(|m| {
            let c = &m.correlations;
            let mut obj = Fields::default();
            obj.map.insert("n".into(), json!(c.n));
            obj.estimate("kendall_tau_b", c.kendall_tau_b);
            obj.estimate("spearman", c.spearman);
            obj.estimate("pearson", c.pearson);
            obj.estimate("pairwise_accuracy", c.pairwise_accuracy);
            let mut ci = Fields::default();
            ci.estimate("kendall_tau_b", m.ci95.kendall_tau_b);
            ci.estimate("spearman", m.ci95.spearman);
            ci.estimate("pearson", m.ci95.pearson);
            ci.estimate("pairwise_accuracy", m.ci95.pairwise_accuracy);
            obj.map.insert("ci95".into(), ci.done());
            let [tau, rho, r, acc] = m.ci95_resamples;
            obj.map.insert(
                "ci95_resamples".into(),
                json!({"kendall_tau_b": tau, "spearman": rho, "pearson": r, "pairwise_accuracy": acc}),
            );
            let mut p = Fields::default();
            p.estimate("kendall_tau_b", m.p_values.kendall_tau_b);
            p.estimate("spearman", m.p_values.spearman);
            p.estimate("pearson", m.p_values.pearson);
            obj.map.insert("p_values".into(), p.done());
            obj.map
                .insert("by_annotator".into(), by_annotator(&m.by_annotator));
            (m.metric.to_string(), obj.done())
        })
        .collect();
    doc.insert("metrics".into(), Value::Object(metrics));
    doc.insert(
        "human_ceiling".into(),
        json!({
            "by_annotator": by_annotator(&h.ceiling.by_annotator),
            "mean": correlations(&h.ceiling.mean),
        }),
    );
    let mut test = Fields::default();
    let t = &h.pg2s_vs_kas;
    test.map.insert("n".into(), json!(t.n));
    test.estimate("difference", t.difference);
    test.estimate("p_value", t.test.map(|t| t.p_value));
    test.map
        .insert("permutations".into(), json!(t.permutations_used()));
    test.map.insert("permutations_asked".into(), json!(t.asked));
    doc.insert("pg2s_vs_kas".into(), test.done());
    doc.insert("williams".into(), williams(&h.williams));
    doc.insert(
        "inter_annotator".into(),
        inter_annotator(&h.inter_annotator),
    );
    let pairwise: Map<String, Value> = h
        .pairwise
        .iter()
        .map(|p| {
            let mut obj = Fields::default();
            obj.map.insert("n".into(), json!(p.n));
            obj.estimate("agreement", p.agreement);
            (p.metric.to_string(), obj.done())
        })
        .collect();
    doc.insert("pairwise".into(), Value::Object(pairwise));
}

/// `{holm_family, pairs: {FIRST_vs_SECOND: {first, second, n, r_first,
/// r_second, r_between, t, df, p_value, p_holm}}}`: Williams' test of each
/// pair of metrics, `holm_family` the number of pairs Holm corrects over.
fn williams(tests: &[MetricPairTest]) -> Value {
    let pairs: Map<String, Value> = tests
        .iter()
        .map(|w| {
            let [first, second] = w.metrics;
            let mut obj = Fields::default();
            obj.map.insert("first".into(), json!(first));
            obj.map.insert("second".into(), json!(second));
            obj.map.insert("n".into(), json!(w.n));
            obj.estimate("r_first", w.test.map(|t| t.r_first));
            obj.estimate("r_second", w.test.map(|t| t.r_second));
            obj.estimate("r_between", w.test.map(|t| t.r_between));
            obj.estimate("t", w.test.map(|t| t.t));
            obj.estimate("df", w.test.map(|t| t.dof));
            obj.estimate("p_value", w.test.map(|t| t.p_value));
            obj.estimate("p_holm", w.p_holm);
            (format!("{first}_vs_{second}"), obj.done())
        })
        .collect();
    let family = tests.iter().filter(|w| w.test.is_ok()).count();
    json!({"holm_family": family, "pairs": pairs})
}

/// `{n, kendall_tau_b, spearman, pearson}` of one set of correlations.
fn correlations(c: &Correlations) -> Value {
    let mut obj = Fields::default();
    obj.map.insert("n".into(), json!(c.n));
    obj.estimate("kendall_tau_b", c.kendall_tau_b);
    obj.estimate("spearman", c.spearman);
    obj.estimate("pearson", c.pearson);
    obj.done()
}

/// `{ANNOTATOR: {n, kendall_tau_b, spearman, pearson}}`.
fn by_annotator(rows: &[(String, Correlations)]) -> Value {
    Value::Object(
        rows.iter()
            .map(|(name, c)| (name.clone(), correlations(c)))
            .collect(),
    )
}

fn inter_annotator(ia: &InterAnnotator) -> Value {
    let mut obj = Fields::default();
    obj.estimate("krippendorff_alpha_ordinal", ia.ordinal);
    obj.estimate("krippendorff_alpha_interval", ia.interval);
    obj.map
        .insert("shared_items".into(), json!(ia.shared_items));
    let mut ci = Fields::default();
    ci.estimate("krippendorff_alpha_ordinal", ia.ci95[0]);
    ci.estimate("krippendorff_alpha_interval", ia.ci95[1]);
    obj.map.insert("ci95".into(), ci.done());
    obj.map.insert(
        "ci95_resamples".into(),
        json!({"krippendorff_alpha_ordinal": ia.ci95_resamples[0], "krippendorff_alpha_interval": ia.ci95_resamples[1]}),
    );
    obj.estimate("krippendorff_alpha_nominal_step_labels", ia.step_labels);
    obj.map
        .insert("step_labels_shared".into(), json!(ia.step_labels_shared));
    let pairs: Vec<Value> = ia
        .by_pair
        .iter()
        .map(|(a, b, n)| json!({"annotators": [a, b], "shared_items": n}))
        .collect();
    obj.map.insert("shared_by_pair".into(), Value::Array(pairs));
    obj.done()
}

fn detection(d: &Detection) -> Value {
    json!({"n": d.n, "detected": d.detected, "tied": d.tied, "reversed": d.reversed})
}

/// An object being built, with the reasons of its `null` fields.
#[derive(Default)]
struct Fields {
    map: Map<String, Value>,
    reasons: Map<String, Value>,
}

impl Fields {
    /// A value (an estimate, an interval, a count) at `key`, or `null` with
    /// the reason in `reasons`.
    fn estimate<T: serde::Serialize>(&mut self, key: &str, value: Result<T, Undefined>) {
        let v = match value {
            Ok(x) => json!(x),
            Err(why) => {
                self.reasons.insert(key.into(), json!(why.to_string()));
                Value::Null
            }
        };
        self.map.insert(key.into(), v);
    }

    fn done(mut self) -> Value {
        if !self.reasons.is_empty() {
            self.map
                .insert("reasons".into(), Value::Object(self.reasons));
        }
        Value::Object(self.map)
    }
}
