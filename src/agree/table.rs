//! `agree --table latex|csv|md`: the correlation table and the corruption
//! table as a paper takes them — LaTeX with `booktabs`, CSV (RFC 4180) or a
//! Markdown pipe table — with the metrics' display names and the same
//! numbers as `--json` (three decimals in LaTeX and Markdown, every digit
//! in CSV).

use std::fmt::Write as _;

use super::plot::display_name;
use super::{Agreement, Detection, HumanAgreement, Interval, METRICS};
use crate::sanitize::csv_field;
use crate::stats::Estimate;

/// The layouts `--table` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TableFormat {
    /// A LaTeX `table` with a `booktabs` tabular (`\toprule`, `\midrule`,
    /// `\bottomrule`), names escaped.
    Latex,
    /// CSV as RFC 4180 writes it (CRLF line ends, fields quoted as needed);
    /// the two tables one after the other, an empty line between them.
    Csv,
    /// Markdown pipe tables.
    Md,
}

/// One table before it is laid out: a title, the header and the rows, each
/// cell already text.
struct Table {
    /// What the table shows (a LaTeX caption, a Markdown heading line).
    title: String,
    /// The LaTeX label.
    label: &'static str,
    /// The column names (in LaTeX, LaTeX source: written as they are).
    header: Vec<String>,
    /// Whether each column holds numbers (right-aligned).
    numeric: Vec<bool>,
    /// The rows, one cell per column.
    rows: Vec<Vec<String>>,
}

/// The tables of an analysis in `format`: the correlations with people
/// (when there are annotations) and the corruption table (when there is a
/// corrupted item whose source is scored).
pub fn render(agreement: &Agreement, format: TableFormat) -> String {
    let mut tables = Vec::new();
    let aggregate = agreement.settings.aggregate.describe();
    if let Some(h) = &agreement.human {
        tables.push(correlations(h, agreement, format));
    }
    if !agreement.corruption.is_empty() {
        tables.push(corruption(agreement, aggregate, format));
    }
    let laid_out: Vec<String> = tables
        .iter()
        .map(|t| match format {
            TableFormat::Latex => latex(t),
            TableFormat::Csv => csv(t),
            TableFormat::Md => markdown(t),
        })
        .collect();
    let gap = if format == TableFormat::Csv {
        "\r\n"
    } else {
        "\n"
    };
    laid_out.join(gap)
}

/// The text of an undefined cell.
fn missing(format: TableFormat) -> String {
    match format {
        TableFormat::Latex => "--".into(),
        TableFormat::Csv => String::new(),
        TableFormat::Md => "—".into(),
    }
}

/// A number as `format` prints it: every digit in CSV, three decimals else.
fn number(x: f64, format: TableFormat) -> String {
    match format {
        TableFormat::Csv => format!("{x}"),
        _ => format!("{x:.3}"),
    }
}

/// Each metric's n, tau-b, rho, r and pairwise accuracy against people,
/// with their 95% intervals (in brackets; in CSV, two columns of their own).
fn correlations(h: &HumanAgreement, agreement: &Agreement, format: TableFormat) -> Table {
    let statistics = [
        ("Kendall τb", "Kendall $\\tau_b$", "kendall_tau_b"),
        ("Spearman ρ", "Spearman $\\rho$", "spearman"),
        ("Pearson r", "Pearson $r$", "pearson"),
        (
            "Pairwise accuracy",
            "Pairwise accuracy",
            "pairwise_accuracy",
        ),
    ];
    let mut header = vec![
        "Metric".to_string(),
        if format == TableFormat::Latex {
            "$n$"
        } else {
            "n"
        }
        .to_string(),
    ];
    for (name, latex_name, key) in statistics {
        match format {
            TableFormat::Csv => {
                header.extend([key.to_string(), format!("{key}_low"), format!("{key}_high")])
            }
            TableFormat::Latex => header.push(latex_name.to_string()),
            TableFormat::Md => header.push(name.to_string()),
        }
    }
    let rows = h
        .metrics
        .iter()
        .map(|m| {
            let c = &m.correlations;
            let mut row = vec![display_name(m.metric).to_string(), c.n.to_string()];
            for (e, ci) in [
                (c.kendall_tau_b, m.ci95.kendall_tau_b),
                (c.spearman, m.ci95.spearman),
                (c.pearson, m.ci95.pearson),
                (c.pairwise_accuracy, m.ci95.pairwise_accuracy),
            ] {
                with_interval(e, ci, format, &mut row);
            }
            row
        })
        .collect();
    let mut numeric = vec![true; header.len()];
    numeric[0] = false;
    Table {
        title: format!(
            "Agreement of each metric with the human score ({}) over the rated items that have the metric; in brackets 95% percentile-bootstrap intervals, {} resamples",
            agreement.settings.aggregate.describe(),
            agreement.settings.bootstrap.resamples
        ),
        label: "tab:agree-correlations",
        header,
        numeric,
        rows,
    }
}

/// Appends a statistic and its interval to `row`: one cell `0.214 [0.083,
/// 0.336]`, or in CSV three cells.
fn with_interval(e: Estimate, ci: Interval, format: TableFormat, row: &mut Vec<String>) {
    let value = e.map_or_else(|_| missing(format), |x| number(x, format));
    let bounds = ci.map(|[lo, hi]| (number(lo, format), number(hi, format)));
    match format {
        TableFormat::Csv => {
            let (lo, hi) = bounds.unwrap_or_else(|_| (missing(format), missing(format)));
            row.extend([value, lo, hi]);
        }
        _ => row.push(match (e, bounds) {
            (Ok(_), Ok((lo, hi))) => format!("{value} [{lo}, {hi}]"),
            _ => value,
        }),
    }
}

/// The corruption table: for each kind, each metric's and people's counts
/// of source higher / tied / corruption higher, of n. In CSV one row per
/// kind and column, with the four counts as columns.
fn corruption(agreement: &Agreement, aggregate: &str, format: TableFormat) -> Table {
    let columns: Vec<(&str, &str)> = METRICS
        .iter()
        .map(|&m| (m, display_name(m)))
        .chain([("human", "Human")])
        .collect();
    let title = format!(
        "Corruption detection: source higher / tied / corruption higher (of n), for each metric and for people (Human: {aggregate})"
    );
    if format == TableFormat::Csv {
        let header = ["Kind", "Column", "n", "detected", "tied", "reversed"].map(String::from);
        let mut rows = Vec::new();
        for (kind, row) in &agreement.corruption {
            for (key, name) in &columns {
                if let Some(d) = row.get(*key) {
                    rows.push(vec![
                        kind.clone(),
                        (*name).to_string(),
                        d.n.to_string(),
                        d.detected.to_string(),
                        d.tied.to_string(),
                        d.reversed.to_string(),
                    ]);
                }
            }
        }
        return Table {
            title,
            label: "tab:agree-corruption",
            header: header.to_vec(),
            numeric: vec![false, false, true, true, true, true],
            rows,
        };
    }
    let header: Vec<String> = ["Kind"]
        .into_iter()
        .chain(columns.iter().map(|c| c.1))
        .map(|name| match format {
            TableFormat::Latex => latex_escape(name),
            _ => name.to_string(),
        })
        .collect();
    let rows = agreement
        .corruption
        .iter()
        .map(|(kind, row)| {
            let mut cells = vec![kind.clone()];
            for (key, _) in &columns {
                cells.push(
                    row.get(*key)
                        .map_or_else(|| missing(format), Detection::to_string),
                );
            }
            cells
        })
        .collect();
    let mut numeric = vec![true; header.len()];
    numeric[0] = false;
    Table {
        title,
        label: "tab:agree-corruption",
        header,
        numeric,
        rows,
    }
}

/// `text` with LaTeX's special characters escaped.
fn latex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\textbackslash{}"),
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '_' | '%' | '&' | '#' | '$' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            _ => out.push(c),
        }
    }
    out
}

fn latex(t: &Table) -> String {
    let mut out = String::new();
    let align: String = t
        .numeric
        .iter()
        .map(|&n| if n { 'r' } else { 'l' })
        .collect();
    let row = |cells: &[String]| {
        let escaped: Vec<String> = cells.iter().map(|c| latex_escape(c)).collect();
        format!("{} \\\\\n", escaped.join(" & "))
    };
    out.push_str("% needs \\usepackage{booktabs}\n\\begin{table}[t]\n\\centering\n");
    let _ = writeln!(out, "\\caption{{{}.}}", latex_escape(&t.title));
    let _ = writeln!(out, "\\label{{{}}}", t.label);
    let _ = writeln!(out, "\\begin{{tabular}}{{{align}}}\n\\toprule");
    let _ = writeln!(out, "{} \\\\", t.header.join(" & "));
    out.push_str("\\midrule\n");
    for r in &t.rows {
        out.push_str(&row(r));
    }
    out.push_str("\\bottomrule\n\\end{tabular}\n\\end{table}\n");
    out
}

fn csv(t: &Table) -> String {
    let line = |cells: &[String]| {
        let fields: Vec<String> = cells.iter().map(|c| csv_field(c)).collect();
        format!("{}\r\n", fields.join(","))
    };
    let mut out = line(&t.header);
    for r in &t.rows {
        out.push_str(&line(r));
    }
    out
}

fn markdown(t: &Table) -> String {
    let line = |cells: &[String]| {
        let escaped: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
        format!("| {} |\n", escaped.join(" | "))
    };
    let mut out = format!("{}.\n\n", t.title);
    out.push_str(&line(&t.header));
    let rule: Vec<String> = t
        .numeric
        .iter()
        .map(|&n| if n { "---:" } else { "---" }.to_string())
        .collect();
    out.push_str(&format!("|{}|\n", rule.join("|")));
    for r in &t.rows {
        out.push_str(&line(r));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latex_escapes_every_special_character() {
        assert_eq!(
            latex_escape(r"a_b%c&d#e$f{g}h~i^j\k"),
            r"a\_b\%c\&d\#e\$f\{g\}h\textasciitilde{}i\textasciicircum{}j\textbackslash{}k"
        );
        assert_eq!(latex_escape("object-swap"), "object-swap");
    }

    #[test]
    fn csv_quotes_as_rfc_4180_and_markdown_escapes_pipes() {
        let t = Table {
            title: "T".into(),
            label: "tab:t",
            header: vec!["a".into(), "b".into()],
            numeric: vec![false, true],
            rows: vec![
                vec!["x,\"y\"".into(), "1".into()],
                vec!["p|q".into(), "2".into()],
            ],
        };
        assert_eq!(csv(&t), "a,b\r\n\"x,\"\"y\"\"\",1\r\np|q,2\r\n");
        assert_eq!(
            markdown(&t),
            "T.\n\n| a | b |\n|---|---:|\n| x,\"y\" | 1 |\n| p\\|q | 2 |\n"
        );
        let tex = latex(&t);
        assert!(tex.contains("\\begin{tabular}{lr}\n\\toprule\na & b \\\\\n\\midrule\n"));
        assert!(tex.contains("p|q & 2 \\\\\n\\bottomrule\n"), "{tex}");
    }
}
