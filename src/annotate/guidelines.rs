//! The guidelines an annotator judges by: a text whose lines `1:` to `5:`
//! give the wording of the rating scale, shown on screen, and whose other
//! lines say what to judge, shown in the help.

use std::path::Path;

use crate::dataset::{read_text, DatasetError};

/// The built-in guidelines, used without `--guidelines`.
pub const BUILT_IN: &str = "\
Judge how well the plan would achieve the task if a robot carried it out, step by step, in the scene shown.
Judge the plan as a whole; then label the steps that are wrong, one label a step.
1: Useless: the plan would not achieve the task at all, or would do harm.
2: Poor: big mistakes; the task fails unless much is changed.
3: Fair: the main idea is right, but a step is wrong, missing or out of order.
4: Good: the task would be achieved; small flaws, such as a needless or vague step.
5: Excellent: correct, complete and in a sensible order.
";

/// Guidelines as read: the scale's wording and the rest of the text.
#[derive(Debug, Clone, PartialEq)]
pub struct Guidelines {
    /// The wording of ratings 1 to 5 (index 0 is rating 1).
    pub scale: [String; 5],
    /// The lines that are not part of the scale, in order.
    pub introduction: Vec<String>,
    /// A short hash of the whole text, written with every judgement.
    pub hash: String,
}

/// Why a guidelines file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum GuidelinesError {
    /// Missing, unreadable or not UTF-8 (the message is the reader's, whole:
    /// not also a source, so an error chain does not say it twice).
    #[error("guidelines: {0}")]
    Read(DatasetError),
    /// Valid UTF-8 that is still not text (a NUL or other control byte).
    #[error("guidelines {origin}: not a text file (control byte at offset {offset}); give a plain text file")]
    NotText {
        /// The file.
        origin: String,
        /// Where the first control byte is.
        offset: usize,
    },
    /// A rating of the scale has no wording.
    #[error("guidelines {origin}: no wording for rating {rating}; add a line `{rating}: …` for each rating 1 to 5")]
    MissingRating {
        /// The file.
        origin: String,
        /// The first rating without a line.
        rating: u8,
    },
}

impl Guidelines {
    /// The built-in guidelines.
    pub fn built_in() -> Guidelines {
        // The built-in text has all five ratings (tested).
        Guidelines::parse(BUILT_IN, "built-in").unwrap_or_else(|_| Guidelines {
            scale: Default::default(),
            introduction: vec![],
            hash: super::guidelines_hash(BUILT_IN),
        })
    }

    /// Reads a guidelines file.
    pub fn load(path: &Path) -> Result<Guidelines, GuidelinesError> {
        let text = read_text(path).map_err(GuidelinesError::Read)?;
        Guidelines::parse(&text, &path.display().to_string())
    }

    /// Parses guidelines text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Guidelines, GuidelinesError> {
        if let Some(offset) = text
            .char_indices()
            .find(|(_, c)| c.is_control() && !matches!(c, '\n' | '\r' | '\t'))
            .map(|(i, _)| i)
        {
            return Err(GuidelinesError::NotText {
                origin: origin.to_string(),
                offset,
            });
        }
        let mut scale: [Option<String>; 5] = Default::default();
        let mut introduction = Vec::new();
        for line in text.lines() {
            match scale_line(line) {
                Some((rating, wording)) => scale[usize::from(rating - 1)] = Some(wording),
                None if line.trim().is_empty() => {}
                None => introduction.push(line.trim().to_string()),
            }
        }
        let mut words: [String; 5] = Default::default();
        for (i, wording) in scale.into_iter().enumerate() {
            words[i] = wording.ok_or_else(|| GuidelinesError::MissingRating {
                origin: origin.to_string(),
                rating: i as u8 + 1,
            })?;
        }
        Ok(Guidelines {
            scale: words,
            introduction,
            hash: super::guidelines_hash(text),
        })
    }
}

/// `3: Fair …` (or `3.`, `3 =`, `3 -`) → (3, "Fair …").
fn scale_line(line: &str) -> Option<(u8, String)> {
    let line = line.trim();
    let digit = line.chars().next()?.to_digit(10)?;
    if !(1..=5).contains(&digit) {
        return None;
    }
    let rest = line[1..].trim_start();
    let wording = rest.strip_prefix([':', '.', '=', '-', ')'])?.trim();
    (!wording.is_empty()).then(|| (digit as u8, wording.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_guidelines_have_every_rating_and_no_telltale_words() {
        let g = Guidelines::parse(BUILT_IN, "built-in").unwrap_or_else(|e| panic!("{e}"));
        assert!(g.scale[0].starts_with("Useless"));
        assert!(g.scale[4].starts_with("Excellent"));
        assert_eq!(g.introduction.len(), 2);
        assert_eq!(Guidelines::built_in(), g);
        let lower = BUILT_IN.to_lowercase();
        for word in [
            "corrupt", "swap", "pg2s", "kas", "s_plan", "s_goal", "score",
        ] {
            assert!(!lower.contains(word), "{word}");
        }
    }

    #[test]
    fn a_file_without_a_rating_or_not_text_is_refused_with_one_line() {
        let missing = Guidelines::parse("1: a\n2: b\n4 = d\n5. e\n", "g.txt");
        let text = missing.err().map(|e| e.to_string()).unwrap_or_default();
        assert_eq!(
            text,
            "guidelines g.txt: no wording for rating 3; add a line `3: …` for each rating 1 to 5"
        );
        let binary = Guidelines::parse("1: a\0\u{1}", "g.bin").err();
        assert!(matches!(
            binary,
            Some(GuidelinesError::NotText { offset: 4, .. })
        ));
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let png = dir.path().join("g.png");
        std::fs::write(&png, [0x89, b'P', b'N', b'G', 0xff, 0xfe])
            .unwrap_or_else(|e| panic!("{e}"));
        let err = Guidelines::load(&png)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("not UTF-8 text"), "{err}");
        assert!(!err.contains('\n'));
    }

    #[test]
    fn scale_lines_take_several_separators_and_the_hash_follows_the_text() {
        let a = Guidelines::parse(
            "Intro.\n1) one\n2 - two\n3: three\n4. four\n5 = five\n",
            "g",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a.scale[1], "two");
        assert_eq!(a.introduction, ["Intro."]);
        let b = Guidelines::parse("1) one\n2 - two\n3: three\n4. four\n5 = five\n", "g")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_ne!(a.hash, b.hash);
    }
}
