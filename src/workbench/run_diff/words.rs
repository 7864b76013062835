//! Word-level diffs of two texts (prompts, outputs, plan steps), and the
//! lines of one that hold a change, for the run diff view to draw.

use similar::{ChangeTag, TextDiff};

/// A stretch of text in a word diff: in both, only in the first, or only in
/// the second.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// Text both sides have.
    Same(String),
    /// Text only the first (older) side has.
    Removed(String),
    /// Text only the second (newer) side has.
    Added(String),
}

impl Piece {
    /// The text of the piece.
    pub fn text(&self) -> &str {
        match self {
            Piece::Same(t) | Piece::Removed(t) | Piece::Added(t) => t,
        }
    }

    /// Whether the piece is a change.
    pub fn is_change(&self) -> bool {
        !matches!(self, Piece::Same(_))
    }

    /// The same kind of piece holding `text`.
    fn with(&self, text: &str) -> Piece {
        match self {
            Piece::Same(_) => Piece::Same(text.to_string()),
            Piece::Removed(_) => Piece::Removed(text.to_string()),
            Piece::Added(_) => Piece::Added(text.to_string()),
        }
    }
}

/// `old` against `new` word by word: runs of words (and the spaces between
/// them) kept, removed or added, adjacent ones of a kind merged.
pub fn word_diff(old: &str, new: &str) -> Vec<Piece> {
    let diff = TextDiff::from_words(old, new);
    let mut pieces: Vec<Piece> = Vec::new();
    for change in diff.iter_all_changes() {
        let text = change.value();
        let piece = match change.tag() {
            ChangeTag::Equal => Piece::Same(String::new()),
            ChangeTag::Delete => Piece::Removed(String::new()),
            ChangeTag::Insert => Piece::Added(String::new()),
        };
        match pieces.last_mut() {
            Some(last) if std::mem::discriminant(last) == std::mem::discriminant(&piece) => {
                *last = last.with(&format!("{}{text}", last.text()));
            }
            _ => pieces.push(piece.with(text)),
        }
    }
    pieces
}

/// One line of a diff as shown: its pieces, or a count of unchanged lines
/// left out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DiffLine {
    /// A line, with its changes marked.
    Text(Vec<Piece>),
    /// This many unchanged lines left out.
    Unchanged(usize),
}

/// The lines of a word diff that hold a change, with `context` unchanged
/// lines around each; the unchanged stretches between are counted.
pub fn changed_lines(pieces: &[Piece], context: usize) -> Vec<DiffLine> {
    let mut lines: Vec<Vec<Piece>> = vec![Vec::new()];
    for piece in pieces {
        for (i, part) in piece.text().split('\n').enumerate() {
            if i > 0 {
                lines.push(Vec::new());
            }
            if !part.is_empty() {
                if let Some(line) = lines.last_mut() {
                    line.push(piece.with(part));
                }
            }
        }
    }
    let changed: Vec<bool> = lines
        .iter()
        .map(|l| l.iter().any(Piece::is_change))
        .collect();
    let last = lines.len() - 1;
    let near = |i: usize| {
        let (lo, hi) = (i.saturating_sub(context), (i + context).min(last));
        changed[lo..=hi].iter().any(|&c| c)
    };
    let mut out = Vec::new();
    let mut skipped = 0;
    for (i, line) in lines.into_iter().enumerate() {
        if near(i) {
            if skipped > 0 {
                out.push(DiffLine::Unchanged(skipped));
                skipped = 0;
            }
            out.push(DiffLine::Text(line));
        } else {
            skipped += 1;
        }
    }
    if skipped > 0 {
        out.push(DiffLine::Unchanged(skipped));
    }
    out
}

/// The pieces written out with `[-removed-]` and `{+added+}` marks, for
/// tests to compare a diff with what a reader would see.
#[cfg(test)]
pub(super) fn marked(pieces: &[Piece]) -> String {
    pieces
        .iter()
        .map(|p| match p {
            Piece::Same(t) => t.clone(),
            Piece::Removed(t) => format!("[-{t}-]"),
            Piece::Added(t) => format!("{{+{t}+}}"),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prompt_diff_marks_the_words_changed_and_keeps_the_rest() {
        let pieces = word_diff(
            "List every object in the scene.",
            "List every small object in the kitchen.",
        );
        assert_eq!(
            marked(&pieces),
            "List every {+small +}object in the [-scene.-]{+kitchen.+}"
        );
        assert_eq!(
            word_diff("same words", "same words"),
            vec![Piece::Same("same words".into())]
        );
    }

    #[test]
    fn only_changed_lines_and_their_context_are_shown() {
        let old = "a\nb\nc\nd\ne\nf\ng";
        let new = "a\nb\nc\nD\ne\nf\ng";
        let lines = changed_lines(&word_diff(old, new), 1);
        let shown: Vec<String> = lines
            .iter()
            .map(|l| match l {
                DiffLine::Text(p) => marked(p),
                DiffLine::Unchanged(n) => format!("({n})"),
            })
            .collect();
        assert_eq!(shown, ["(2)", "c", "[-d-]{+D+}", "e", "(2)"]);
    }
}
