//! The readable report of `agree`: tables of the agreement with people,
//! between annotators and of corruption detection, and a scatter plot of
//! each metric against the human score drawn in text.

use std::fmt::Write as _;

use super::{Agreement, Detection, HumanAgreement, Interval, MetricAgreement, METRICS};
use crate::stats::Estimate;

/// Columns and rows of each text scatter plot.
const PLOT_WIDTH: usize = 48;
const PLOT_HEIGHT: usize = 10;

/// The whole report.
pub fn render(agreement: &Agreement) -> String {
    let mut out = String::new();
    if !agreement.warnings.is_empty() {
        out.push_str("Warnings:\n");
        for w in &agreement.warnings {
            let _ = writeln!(out, "  – {w}");
        }
        out.push('\n');
    }
    match &agreement.human {
        Some(h) => human_section(h, agreement, &mut out),
        None => out.push_str("No annotations given: only corruption detection is reported.\n\n"),
    }
    corruption_section(agreement, &mut out);
    if let Some(h) = &agreement.human {
        for m in &h.metrics {
            out.push('\n');
            out.push_str(&scatter(m));
        }
    }
    out
}

fn human_section(h: &HumanAgreement, agreement: &Agreement, out: &mut String) {
    let s = agreement.settings;
    let _ = writeln!(
        out,
        "Agreement with people: {} rated items, {} annotators ({})",
        h.items,
        h.annotators.len(),
        h.annotators.join(", ")
    );
    let _ = writeln!(
        out,
        "Human score: {} (--aggregate {}); 95% intervals: percentile bootstrap, {} resamples, seed {}\n",
        s.aggregate.describe(),
        s.aggregate.as_str(),
        s.bootstrap.resamples,
        s.bootstrap.seed
    );
    let _ = writeln!(
        out,
        "{:<8} {:>6}  {:<22} {:<22} {:<22} pairwise accuracy",
        "metric", "n", "Kendall tau-b", "Spearman rho", "Pearson r"
    );
    let mut notes = Vec::new();
    for m in &h.metrics {
        let c = &m.correlations;
        let mut cell = |name: &str, e: Estimate, ci: Interval| {
            if let Err(why) = e {
                notes.push(format!("{} {name}: {why}", m.metric));
            }
            with_interval(e, ci)
        };
        let row = [
            cell("tau-b", c.kendall_tau_b, m.ci95.kendall_tau_b),
            cell("Spearman", c.spearman, m.ci95.spearman),
            cell("Pearson", c.pearson, m.ci95.pearson),
            cell(
                "pairwise accuracy",
                c.pairwise_accuracy,
                m.ci95.pairwise_accuracy,
            ),
        ];
        let line = format!(
            "{:<8} {:>6}  {:<22} {:<22} {:<22} {:<22}",
            m.metric, c.n, row[0], row[1], row[2], row[3]
        );
        let _ = writeln!(out, "{}", line.trim_end());
    }
    for note in &notes {
        let _ = writeln!(out, "  – {note}");
    }
    let _ = writeln!(
        out,
        "\nHuman ceiling (each annotator against the mean of the others) and each metric against each annotator, tau-b / rho / r:"
    );
    let three = |c: &crate::stats::correlation::Correlations| {
        format!(
            "{} / {} / {} (n {})",
            short(c.kendall_tau_b),
            short(c.spearman),
            short(c.pearson),
            c.n
        )
    };
    for (name, c) in &h.ceiling.by_annotator {
        let _ = writeln!(
            out,
            "  ceiling  {:<10} {}",
            crate::sanitize::for_terminal(name),
            three(c)
        );
    }
    let _ = writeln!(
        out,
        "  ceiling  {:<10} {}: the items rated by two or more",
        "mean",
        three(&h.ceiling.mean)
    );
    for m in &h.metrics {
        for (name, c) in &m.by_annotator {
            let _ = writeln!(
                out,
                "  {:<8} {:<10} {}",
                m.metric,
                crate::sanitize::for_terminal(name),
                three(c)
            );
        }
    }
    let _ = writeln!(out, "\nTwo-sided p-values (as scipy.stats):");
    for m in &h.metrics {
        let p = |e: Estimate| match e {
            Ok(v) => format!("{v:.3e}"),
            Err(_) => "—".to_string(),
        };
        let _ = writeln!(
            out,
            "  {:<8} tau-b {:<10} rho {:<10} r {}",
            m.metric,
            p(m.p_values.kendall_tau_b),
            p(m.p_values.spearman),
            p(m.p_values.pearson)
        );
    }
    let t = &h.pg2s_vs_kas;
    match (t.difference, t.test) {
        (Ok(d), Ok(test)) => {
            let _ = writeln!(
                out,
                "\nPG2S against KAS on tau-b: difference {d:+.3} over {} items, p = {:.3} ({} of {} paired permutations)",
                t.n, test.p_value, test.permutations, t.asked
            );
        }
        (Ok(d), Err(why)) => {
            let _ = writeln!(
                out,
                "\nPG2S against KAS on tau-b: difference {d:+.3} over {} items, no p-value ({why})",
                t.n
            );
        }
        (Err(why), _) => {
            let _ = writeln!(
                out,
                "\nPG2S against KAS on tau-b: no test over {} items ({why})",
                t.n
            );
        }
    }
    williams_section(h, out);
    let ia = &h.inter_annotator;
    let _ = writeln!(
        out,
        "\nBetween annotators: Krippendorff's alpha ordinal {}, interval {}; {} items rated by two or more",
        with_interval(ia.ordinal, ia.ci95[0]),
        with_interval(ia.interval, ia.ci95[1]),
        ia.shared_items
    );
    let _ = writeln!(
        out,
        "  step labels: nominal alpha {} over {} steps labelled by two or more",
        value(ia.step_labels),
        ia.step_labels_shared
    );
    for (a, b, n) in &ia.by_pair {
        let _ = writeln!(out, "  {a} & {b}: {n} shared items");
    }
    let _ = writeln!(
        out,
        "\nPairwise preferences (the metric prefers the same plan):"
    );
    for p in &h.pairwise {
        let _ = writeln!(
            out,
            "  {:<8} {:>6} preferences  {}",
            p.metric,
            p.n,
            value(p.agreement)
        );
    }
    out.push('\n');
}

/// Williams' test of each pair of metrics, beside the permutation test.
fn williams_section(h: &HumanAgreement, out: &mut String) {
    let family = h.williams.iter().filter(|w| w.test.is_ok()).count();
    let _ = writeln!(
        out,
        "Williams' test of each pair of metrics on Pearson r (the human score shared), p Holm-adjusted over the {family} pairs tested:"
    );
    for w in &h.williams {
        let pair = format!("{:<8} {:<8} n {:<6}", w.metrics[0], w.metrics[1], w.n);
        let line = match (w.test, w.p_holm) {
            (Ok(t), Ok(holm)) => format!(
                "{pair} r {:.3} against {:.3} (between {:.3})  t {:+.3} df {}  p {:.3e}  Holm {:.3e}",
                t.r_first, t.r_second, t.r_between, t.t, t.dof, t.p_value, holm
            ),
            (Err(why), _) | (_, Err(why)) => format!("{pair} no test ({why})"),
        };
        let _ = writeln!(out, "  {}", line.trim_end());
    }
}

fn corruption_section(agreement: &Agreement, out: &mut String) {
    if agreement.corruption.is_empty() {
        out.push_str("Corruption detection: no corrupted item whose source is scored.\n");
        return;
    }
    let _ = writeln!(
        out,
        "Corruption detection: source higher / tied / corruption higher (of n); human: {} (--aggregate {})",
        agreement.settings.aggregate.describe(),
        agreement.settings.aggregate.as_str()
    );
    let columns: Vec<&str> = METRICS.iter().copied().chain(["human"]).collect();
    let _ = write!(out, "{:<14}", "kind");
    for c in &columns {
        let _ = write!(out, " {c:<16}");
    }
    out.truncate(out.trim_end().len());
    out.push('\n');
    for (kind, row) in &agreement.corruption {
        let _ = write!(out, "{kind:<14}");
        for c in &columns {
            let text = row
                .get(*c)
                .map_or_else(|| "–".to_string(), Detection::to_string);
            let _ = write!(out, " {text:<16}");
        }
        out.truncate(out.trim_end().len());
        out.push('\n');
    }
}

fn value(e: Estimate) -> String {
    match e {
        Ok(x) => format!("{x:.3}"),
        Err(why) => format!("n/a ({why})"),
    }
}

/// A value with three decimals, or `—` when it has none.
fn short(e: Estimate) -> String {
    e.map_or_else(|_| "—".to_string(), |x| format!("{x:.3}"))
}

fn with_interval(e: Estimate, ci: Interval) -> String {
    match (e, ci) {
        (Ok(x), Ok([lo, hi])) => format!("{x:.3} [{lo:.3}, {hi:.3}]"),
        (Ok(x), Err(_)) => format!("{x:.3}"),
        (Err(_), _) => "n/a".to_string(),
    }
}

/// A text scatter plot of one metric (rows, top = highest) against the
/// human score (columns); a cell shows how many items fall in it.
fn scatter(m: &MetricAgreement) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} against the human score (n {}, tau-b {})",
        m.metric,
        m.points.len(),
        value(m.correlations.kendall_tau_b)
    );
    if m.points.is_empty() {
        out.push_str("  (no items)\n");
        return out;
    }
    let range = |f: fn(&(f64, f64)) -> f64| {
        let lo = m.points.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = m.points.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    };
    let (h_lo, h_hi) = range(|p| p.0);
    let (v_lo, v_hi) = range(|p| p.1);
    let cell = |x: f64, lo: f64, hi: f64, cells: usize| -> usize {
        if hi > lo {
            (((x - lo) / (hi - lo)) * (cells - 1) as f64).round() as usize
        } else {
            cells / 2
        }
    };
    let mut grid = vec![[0u32; PLOT_WIDTH]; PLOT_HEIGHT];
    for &(h, v) in &m.points {
        let row = PLOT_HEIGHT - 1 - cell(v, v_lo, v_hi, PLOT_HEIGHT);
        grid[row][cell(h, h_lo, h_hi, PLOT_WIDTH)] += 1;
    }
    for (r, row) in grid.iter().enumerate() {
        let label = match r {
            0 => format!("{v_hi:>7.3}"),
            r if r == PLOT_HEIGHT - 1 => format!("{v_lo:>7.3}"),
            _ => " ".repeat(7),
        };
        let dots: String = row
            .iter()
            .map(|&n| match n {
                0 => ' ',
                1 => '·',
                2..=3 => '•',
                _ => '●',
            })
            .collect();
        let _ = writeln!(out, "{label} │{}", dots.trim_end());
    }
    let _ = writeln!(out, "{} └{}", " ".repeat(7), "─".repeat(PLOT_WIDTH));
    let left = format!("{h_lo:.2}");
    let right = format!("{h_hi:.2}");
    let gap = PLOT_WIDTH.saturating_sub(left.len() + right.len());
    let _ = writeln!(
        out,
        "{}  {left}{}{right}  human",
        " ".repeat(7),
        " ".repeat(gap)
    );
    out
}
