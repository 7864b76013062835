//! The lines of the run diff page: the verdicts, each agent's settings,
//! prompt and output changes with its tokens and cost, and the plans step
//! by step with their scores, wrapped to the overlay's width with their
//! styles kept.

use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use unicode_width::UnicodeWidthChar;

use crate::metrics::shown;
use crate::workbench::run_diff::{
    changed_lines, cost_text, AgentSide, DiffLine, Judgement, Piece, RunDiff, StepChange, StepRow,
    StepSide, Verdict,
};
use crate::workbench::theme::Theme;

/// The samples a user is told to ask for when a run has too few to judge.
const SAMPLES_ADVISED: usize = 5;

/// Unchanged lines kept around each changed line of a prompt or output.
const CONTEXT_LINES: usize = 1;

/// A change in a metric as the diff shows it: `+0.079`, or `–`.
fn signed(change: Option<f64>) -> String {
    change.map_or("n/a".to_string(), |c| format!("{c:+.3}"))
}

/// The verdict's one line: the metric, the means, the change, and whether
/// it exceeds the spread of the samples.
fn verdict_line(v: &Verdict, t: &Theme) -> Line<'static> {
    let [n, m] = v.samples;
    let (judged, style) = match v.judgement {
        Judgement::Beyond { p } => (
            format!("exceeds the spread of {n}+{m} samples (p {p:.3})"),
            t.good.add_modifier(Modifier::BOLD),
        ),
        Judgement::Within { p } => (
            format!("within the spread of {n}+{m} samples (p {p:.3}): may be noise"),
            t.warn,
        ),
        Judgement::TooFewSamples => (
            format!("{n}+{m} samples: cannot tell a change from noise"),
            t.warn,
        ),
        Judgement::Missing => ("not scored in both runs".to_string(), t.muted),
    };
    Line::from(vec![
        Span::styled(format!("{:<7}", v.metric), t.accent),
        Span::styled(
            format!(
                "{:>5} → {:>5} {:>7}  ",
                shown(v.before),
                shown(v.after),
                signed(v.change())
            ),
            t.base,
        ),
        Span::styled(judged, style),
    ])
}

/// An agent's tokens and cost in one run, or that it did not run.
fn side_text(side: Option<AgentSide>, other: u64) -> String {
    match side {
        Some(s) => format!(
            "{}+{} tok {}{}",
            s.usage.input_tokens,
            s.usage.output_tokens,
            cost_text(s.usd),
            if s.cached { " (cached)" } else { "" }
        ),
        None => format!("did not run (the output of #{other} was reused)"),
    }
}

/// The spans of word-diff pieces: removed text as `[-…-]` and added text as
/// `{+…+}`, so the change reads without colour too.
fn piece_spans(pieces: &[Piece], t: &Theme) -> Vec<Span<'static>> {
    pieces
        .iter()
        .map(|p| match p {
            Piece::Same(text) => Span::styled(text.clone(), t.base),
            Piece::Removed(text) => Span::styled(
                format!("[-{text}-]"),
                t.bad.add_modifier(Modifier::CROSSED_OUT),
            ),
            Piece::Added(text) => {
                Span::styled(format!("{{+{text}+}}"), t.good.add_modifier(Modifier::BOLD))
            }
        })
        .collect()
}

/// A prompt or output diff under its `label`, changed lines with context.
fn text_diff(lines: &mut Vec<Line<'static>>, label: &str, pieces: &[Piece], t: &Theme) {
    lines.push(Line::from(Span::styled(format!("  {label}:"), t.muted)));
    for line in changed_lines(pieces, CONTEXT_LINES) {
        lines.push(match line {
            DiffLine::Text(pieces) => {
                let mut spans = vec![Span::raw("    ")];
                spans.extend(piece_spans(&pieces, t));
                Line::from(spans)
            }
            DiffLine::Unchanged(n) => Line::from(Span::styled(
                format!("    ⋯ {n} unchanged line(s)"),
                t.muted,
            )),
        });
    }
}

/// A step's score in one run: its KAS and its PG2S match.
fn step_score(side: Option<&StepSide>) -> String {
    let Some(side) = side else {
        return "absent".to_string();
    };
    let kas = side
        .score
        .kas
        .map_or("KAS –".to_string(), |k| format!("KAS {k:.2}"));
    match side.score.matched {
        Some((gt, cos)) => format!("{kas}, GT {} cos {cos:.3}", gt + 1),
        None => format!("{kas}, unmatched"),
    }
}

/// Every line of the diff, before wrapping.
pub(super) fn diff_lines(diff: &RunDiff, t: &Theme) -> Vec<Line<'static>> {
    let [a, b] = diff.ids;
    let heading = |text: String| Line::from(Span::styled(text, t.title));
    let mut lines = vec![heading("Verdict per metric (mean of the samples):".into())];
    for (id, state) in diff.ids.iter().zip(&diff.unfinished) {
        if let Some(state) = state {
            lines.push(Line::from(Span::styled(
                format!("  run #{id} {state}"),
                t.bad,
            )));
        }
    }
    lines.extend(diff.verdicts.iter().map(|v| verdict_line(v, t)));
    if diff
        .verdicts
        .iter()
        .any(|v| v.judgement == Judgement::TooFewSamples)
    {
        lines.push(Line::from(Span::styled(
            format!(
                "  One sample cannot tell a change from noise: set samples to {SAMPLES_ADVISED} \
                 (S in the panes, or --samples {SAMPLES_ADVISED}) and run both again."
            ),
            t.warn,
        )));
    }
    lines.push(Line::from(vec![
        Span::styled("Cost    ", t.accent),
        Span::styled(
            format!(
                "#{a} {} → #{b} {}",
                cost_text(diff.costs[0]),
                cost_text(diff.costs[1])
            ),
            t.base,
        ),
    ]));
    for change in &diff.run_changes {
        lines.push(Line::from(vec![
            Span::styled(format!("{} changed: ", change.name), t.warn),
            Span::styled(format!("{} → {}", change.before, change.after), t.base),
        ]));
    }
    for agent in &diff.agents {
        lines.push(Line::default());
        lines.push(heading(format!("── {} ──", agent.agent.label())));
        lines.push(Line::from(Span::styled(
            format!(
                "  #{a} {} → #{b} {}",
                side_text(agent.sides[0], b),
                side_text(agent.sides[1], a)
            ),
            t.muted,
        )));
        for s in &agent.settings {
            lines.push(Line::from(Span::styled(
                format!("  {}: {} → {}", s.name, s.before, s.after),
                t.warn,
            )));
        }
        let ran_in_both = agent.sides.iter().all(Option::is_some);
        match &agent.prompt {
            Some(pieces) => text_diff(&mut lines, "prompt", pieces, t),
            None if ran_in_both => {
                lines.push(Line::from(Span::styled("  prompt unchanged", t.muted)))
            }
            None => {}
        }
        match &agent.output {
            Some(pieces) => text_diff(&mut lines, "output", pieces, t),
            None if ran_in_both => {
                lines.push(Line::from(Span::styled("  output unchanged", t.muted)))
            }
            None => {}
        }
    }
    lines.push(Line::default());
    lines.push(heading(format!(
        "── Plan: #{a} → #{b}, each step's score ──"
    )));
    for row in &diff.steps {
        let number = row
            .after
            .as_ref()
            .or(row.before.as_ref())
            .map_or(0, |s| s.index + 1);
        let (mark, text): (&str, Vec<Span<'static>>) = match &row.change {
            StepChange::Same => (" ", vec![Span::styled(step_text(row), t.base)]),
            StepChange::Removed => ("-", piece_spans(&[Piece::Removed(step_text(row))], t)),
            StepChange::Added => ("+", piece_spans(&[Piece::Added(step_text(row))], t)),
            StepChange::Changed(pieces) => ("~", piece_spans(pieces, t)),
        };
        let mut spans = vec![Span::styled(format!("{mark}{number:>3}. "), t.accent)];
        spans.extend(text);
        lines.push(Line::from(spans));
        let (before, after) = (row.before.as_ref(), row.after.as_ref());
        let changed = before.map(|s| s.score) != after.map(|s| s.score);
        lines.push(Line::from(Span::styled(
            format!("       {} → {}", step_score(before), step_score(after)),
            if changed { t.warn } else { t.muted },
        )));
    }
    lines
}

/// The text of a step in either plan.
fn step_text(row: &StepRow) -> String {
    row.after
        .as_ref()
        .or(row.before.as_ref())
        .map(|s| s.text.clone())
        .unwrap_or_default()
}

/// `lines` wrapped to `width` columns: a long line breaks after its last
/// space that fits (mid-word only for a word longer than the width), so the
/// `[-…-]` and `{+…+}` marks stay whole where they can.
pub(super) fn wrap(lines: Vec<Line<'static>>, width: usize) -> Vec<Line<'static>> {
    let width = width.max(1);
    let mut out = Vec::new();
    for line in lines {
        let cells: Vec<(char, Style)> = line
            .spans
            .iter()
            .flat_map(|span| span.content.chars().map(move |c| (c, span.style)))
            .collect();
        let mut start = 0;
        loop {
            let mut end = start;
            let mut used = 0;
            while end < cells.len() && used + cells[end].0.width().unwrap_or(0) <= width {
                used += cells[end].0.width().unwrap_or(0);
                end += 1;
            }
            if end < cells.len() {
                if let Some(space) = cells[start..end].iter().rposition(|(c, _)| *c == ' ') {
                    end = (start + space + 1).max(start + 1);
                }
            }
            out.push(styled_line(
                &cells[start..end.max(start + 1).min(cells.len())],
            ));
            start = end.max(start + 1);
            if start >= cells.len() {
                break;
            }
        }
    }
    out
}

/// The spans of `cells`, one per run of a style.
fn styled_line(cells: &[(char, Style)]) -> Line<'static> {
    let mut spans: Vec<Span<'static>> = Vec::new();
    for &(c, style) in cells {
        match spans.last_mut() {
            Some(last) if last.style == style => last.content.to_mut().push(c),
            _ => spans.push(Span::styled(c.to_string(), style)),
        }
    }
    Line::from(spans)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_wrap_at_the_width_and_keep_their_styles() {
        let style = Style::default().add_modifier(Modifier::BOLD);
        let lines = vec![Line::from(vec![
            Span::raw("abcd"),
            Span::styled("efgh", style),
        ])];
        let wrapped = wrap(lines, 3);
        let texts: Vec<String> = wrapped.iter().map(|l| l.to_string()).collect();
        assert_eq!(texts, ["abc", "def", "gh"]);
        assert_eq!(wrapped[1].spans[1].style, style);
        let words = wrap(vec![Line::from("one {+two three+} four")], 12);
        let texts: Vec<String> = words.iter().map(|l| l.to_string()).collect();
        assert_eq!(texts, ["one {+two ", "three+} four"]);
        assert_eq!(wrap(vec![Line::default()], 5).len(), 1);
    }
}
