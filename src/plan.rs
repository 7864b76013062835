//! Plans as lists of steps, and the one step parser shared by step files and
//! raw model output (`dataset.md`, "Step files and raw model output").

/// Turns a step file or a model's raw answer into steps.
///
/// Numbering (`1.`, `1)`, `STEP 1:`, `Step 1 -`), bullets (`-`, `*`, `•`),
/// surrounding whitespace, a trailing `,` after the final period and blank
/// lines are removed; the rest of each sentence is kept as written. When some
/// lines carry a list marker, only those lines are steps, so a preamble such as
/// "Here is the plan:" and closing remarks are left out. When no line carries a
/// marker, every non-blank line is a step, except a first line ending in `:`.
pub fn parse_steps(text: &str) -> Vec<String> {
    let lines = content_lines(text);
    let marked: Vec<Option<&str>> = lines.iter().map(|l| strip_marker(l)).collect();
    let steps: Vec<&str> = if marked.iter().any(Option::is_some) {
        marked.iter().flatten().copied().collect()
    } else {
        let skip = usize::from(lines.first().is_some_and(|l| l.ends_with(':')));
        lines[skip..].to_vec()
    };
    steps
        .into_iter()
        .map(clean_step)
        .filter(|s| !s.is_empty())
        .collect()
}

/// The non-blank lines of a step file or an answer, trimmed, without a
/// byte-order mark.
fn content_lines(text: &str) -> Vec<&str> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect()
}

/// The longest step scored, in characters. The sentence encoder reads at
/// most 384 tokens of a step (about 2,000 characters of English) and the
/// parser needs no more to find a step's actions, so a longer step is cut
/// here rather than costing minutes and gigabytes further on.
pub const MAX_STEP_CHARS: usize = 2_000;

/// The most steps of one plan scored: a plan is a list of actions a person
/// reads, and matching costs the product of the two plans' lengths.
pub const MAX_STEPS: usize = 1_000;

/// Cuts `steps` to the limits above; returns what was cut, in words for the
/// user, or `None` when nothing was.
pub fn bound_steps(steps: &mut Vec<String>) -> Option<String> {
    let mut notes = Vec::new();
    if steps.len() > MAX_STEPS {
        notes.push(format!(
            "{} steps, only the first {MAX_STEPS} kept",
            steps.len()
        ));
        steps.truncate(MAX_STEPS);
    }
    let mut cut = 0;
    for step in steps.iter_mut() {
        if let Some((end, _)) = step.char_indices().nth(MAX_STEP_CHARS) {
            step.truncate(end);
            cut += 1;
        }
    }
    if cut > 0 {
        notes.push(format!(
            "{cut} step(s) longer than {MAX_STEP_CHARS} characters cut to that length"
        ));
    }
    (!notes.is_empty()).then(|| notes.join("; "))
}

/// The steps of a model's answer held to the one step limit (at most
/// [`MAX_STEPS`] steps of at most [`MAX_STEP_CHARS`] characters), the same
/// in `plan`, `eval`, the workbench and `score`; with what was cut, in words.
pub fn bounded_steps(text: &str) -> (Vec<String>, Option<String>) {
    let mut steps = parse_steps(text);
    let note = bound_steps(&mut steps);
    (steps, note)
}

/// Why a model's answer is not a plan, or `None` when it is one: a plan has
/// a step-shaped line (numbered or bulleted), or several lines, or several
/// sentences. A refusal ("I am sorry, but I cannot help with that.") has
/// none of them and must not be scored as a one-step plan.
pub fn not_a_plan(text: &str) -> Option<String> {
    let lines = content_lines(text);
    if lines.iter().any(|l| strip_marker(l).is_some()) {
        return None;
    }
    let skip = usize::from(lines.first().is_some_and(|l| l.ends_with(':')));
    let body = &lines[skip.min(lines.len())..];
    let sentences: usize = body
        .iter()
        .map(|line| {
            line.split_terminator(['.', '!', '?'])
                .filter(|s| s.chars().any(char::is_alphanumeric))
                .count()
        })
        .sum();
    if body.len() >= 2 || sentences >= 2 {
        return None;
    }
    let start: String = text.trim().chars().take(80).collect();
    Some(format!(
        "the answer is not a plan (no numbered or bulleted line, nor several sentences): \"{start}\""
    ))
}

/// Removes a trailing `,` after the final period (`... sink.,`) and markdown
/// emphasis left around the whole step.
fn clean_step(step: &str) -> String {
    let mut s = step.trim();
    if let Some(inner) = s.strip_prefix("**").and_then(|x| x.strip_suffix("**")) {
        s = inner.trim();
    }
    if s.ends_with(".,") {
        s = &s[..s.len() - 1];
    }
    s.trim().to_string()
}

/// Recognises a list marker at the start of a trimmed line and returns the
/// text after it.
fn strip_marker(line: &str) -> Option<&str> {
    let line = line.strip_prefix("**").map_or(line, |l| l.trim_start());
    for bullet in ['-', '*', '•'] {
        if let Some(rest) = line.strip_prefix(bullet) {
            if rest.starts_with(char::is_whitespace) {
                return Some(rest.trim_start());
            }
        }
    }
    strip_step_word(line).or_else(|| strip_number(line))
}

/// `STEP 1:`, `Step 1 -`, `step 2.`, `Step 3)` (any case), with optional
/// markdown bold closing after the marker.
fn strip_step_word(line: &str) -> Option<&str> {
    let head = line.get(..4)?;
    if !head.eq_ignore_ascii_case("step") {
        return None;
    }
    let after_word = line[4..].trim_start();
    let digits = after_word.len()
        - after_word
            .trim_start_matches(|c: char| c.is_ascii_digit())
            .len();
    if digits == 0 {
        return None;
    }
    let after_num = &after_word[digits..];
    let trimmed = after_num.trim_start();
    let rest = if let Some(r) = trimmed.strip_prefix([':', '.', ')', '-', '–']) {
        r
    } else if after_num.starts_with(char::is_whitespace) {
        trimmed
    } else {
        return None;
    };
    let rest = rest.trim_start();
    Some(rest.strip_prefix("**").map_or(rest, str::trim_start))
}

/// `1.` or `1)` followed by whitespace or the end of the line (so `1.5 m` is
/// not numbering).
fn strip_number(line: &str) -> Option<&str> {
    let digits = line.len() - line.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    if digits == 0 {
        return None;
    }
    let rest = line[digits..].strip_prefix(['.', ')'])?;
    let rest = rest.strip_prefix("**").unwrap_or(rest);
    if rest.is_empty() || rest.starts_with(char::is_whitespace) {
        Some(rest.trim_start())
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::{bound_steps, parse_steps, MAX_STEPS, MAX_STEP_CHARS};

    #[test]
    fn a_bom_does_not_hide_the_first_step() {
        assert_eq!(parse_steps("\u{feff}1. Go.\n2. Stop."), ["Go.", "Stop."]);
        assert_eq!(parse_steps("\u{feff}Go.\nStop."), ["Go.", "Stop."]);
    }

    #[test]
    fn steps_are_bounded_in_length_and_number() {
        let mut steps = vec!["é".repeat(MAX_STEP_CHARS + 5), "Go.".into()];
        let note = bound_steps(&mut steps).unwrap_or_default();
        assert_eq!(steps[0].chars().count(), MAX_STEP_CHARS);
        assert_eq!(steps[1], "Go.");
        assert!(note.contains("1 step(s) longer"), "{note}");
        let mut many = vec!["Go.".to_string(); MAX_STEPS + 1];
        assert!(bound_steps(&mut many).is_some());
        assert_eq!(many.len(), MAX_STEPS);
        assert_eq!(bound_steps(&mut many), None);
    }

    #[test]
    fn strips_numbering_bullets_and_step_words() {
        let raw = "1. Walk to the sink.\n2) Pick up the cup.\n- Turn left.\n* Go on.\n• Stop.\nSTEP 6: Open it.\nStep 7 - Close it.\nstep 8. Done.";
        assert_eq!(
            parse_steps(raw),
            [
                "Walk to the sink.",
                "Pick up the cup.",
                "Turn left.",
                "Go on.",
                "Stop.",
                "Open it.",
                "Close it.",
                "Done."
            ]
        );
    }

    #[test]
    fn drops_preamble_postamble_and_blank_lines() {
        let raw = "Here is the plan:\n\n1. Walk to the sink.,\n\n2. Wash the cup.,\nThis plan completes the task.";
        assert_eq!(parse_steps(raw), ["Walk to the sink.", "Wash the cup."]);
    }

    #[test]
    fn plain_step_file_keeps_every_line() {
        let raw = "  Walk to the bathtub.  \nPick up the sponge, then turn.\n";
        assert_eq!(
            parse_steps(raw),
            ["Walk to the bathtub.", "Pick up the sponge, then turn."]
        );
    }

    #[test]
    fn plain_list_with_a_heading_drops_the_heading() {
        assert_eq!(parse_steps("Plan:\nWalk.\nStop."), ["Walk.", "Stop."]);
    }

    #[test]
    fn keeps_numbers_inside_sentences() {
        assert_eq!(
            parse_steps("1.5 meters ahead is the sink.\nWalk 2 steps."),
            ["1.5 meters ahead is the sink.", "Walk 2 steps."]
        );
    }

    #[test]
    fn bold_markdown_markers() {
        assert_eq!(
            parse_steps("**Step 1:** Walk to the sink.\n**2.** Stop."),
            ["Walk to the sink.", "Stop."]
        );
    }

    #[test]
    fn only_a_trailing_comma_after_a_period_is_removed() {
        assert_eq!(parse_steps("1. Walk, then stop,"), ["Walk, then stop,"]);
    }

    #[test]
    fn empty_input_has_no_steps() {
        assert!(parse_steps("").is_empty());
        assert!(parse_steps("\n \n").is_empty());
    }

    mod properties {
        use super::{bound_steps, parse_steps, MAX_STEPS, MAX_STEP_CHARS};
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]

            /// Any text, markers and odd characters included: no panic, and
            /// each step is one trimmed, non-empty line.
            #[test]
            fn any_text_gives_trimmed_one_line_steps(
                text in "([0-9]{0,2}[.):]? ?(\\*\\*)?(STEP|Step|-|•|\\*)? ?[a-zé.,:\t ]{0,12}\r?\n?){0,8}"
            ) {
                let steps = parse_steps(&text);
                prop_assert!(steps.len() <= text.lines().count());
                for step in &steps {
                    prop_assert!(!step.is_empty());
                    prop_assert_eq!(step.trim(), step.as_str());
                    prop_assert!(!step.contains('\n'));
                }
            }

            /// Steps written as a numbered list (or one a line) read back
            /// as the same steps.
            #[test]
            fn a_numbered_list_reads_back_as_its_steps(
                steps in prop::collection::vec("[A-Z][a-z]{0,8}( [a-z]{1,8}){0,5}\\.", 1..12),
                numbered in any::<bool>(),
            ) {
                let text: String = steps
                    .iter()
                    .enumerate()
                    .map(|(i, s)| if numbered { format!("{}. {s}\n", i + 1) } else { format!("{s}\n") })
                    .collect();
                prop_assert_eq!(parse_steps(&text), steps);
            }

            /// The bounds hold for any plan, and the note says exactly when
            /// they cut.
            #[test]
            fn bounds_hold_and_are_said(
                count in 0usize..(MAX_STEPS + 3),
                long in prop::collection::vec(0usize..(MAX_STEP_CHARS + 3), 0..4),
            ) {
                let mut steps: Vec<String> = (0..count).map(|i| format!("Step {i}.")).collect();
                for (i, len) in long.iter().enumerate() {
                    if i < steps.len() {
                        steps[i] = "é".repeat(*len);
                    }
                }
                let before = steps.clone();
                let note = bound_steps(&mut steps);
                prop_assert!(steps.len() <= MAX_STEPS);
                prop_assert!(steps.iter().all(|s| s.chars().count() <= MAX_STEP_CHARS));
                prop_assert_eq!(note.is_some(), steps != before);
            }
        }
    }
}
