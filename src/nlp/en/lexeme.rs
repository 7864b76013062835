//! Lexical attributes of a word as spaCy computes them (`lang/lex_attrs.py`),
//! with Python's `str` character classes.

use std::collections::HashMap;

use super::strings::string_id;

/// spaCy's `BASE_NORMS`: norms that hold in every language, consulted after
/// the model's own `lexeme_norm` table.
const BASE_NORMS: [(&str, &str); 45] = [
    ("'s", "'s"),
    ("'S", "'s"),
    ("’s", "'s"),
    ("’S", "'s"),
    ("’", "'"),
    ("‘", "'"),
    ("´", "'"),
    ("`", "'"),
    ("”", "\""),
    ("“", "\""),
    ("''", "\""),
    ("``", "\""),
    ("´´", "\""),
    ("„", "\""),
    ("»", "\""),
    ("«", "\""),
    ("‘‘", "\""),
    ("’’", "\""),
    ("？", "?"),
    ("！", "!"),
    ("，", ","),
    ("；", ";"),
    ("：", ":"),
    ("。", "."),
    ("।", "."),
    ("…", "..."),
    ("—", "-"),
    ("–", "-"),
    ("--", "-"),
    ("---", "-"),
    ("——", "-"),
    ("€", "$"),
    ("£", "$"),
    ("¥", "$"),
    ("฿", "$"),
    ("US$", "$"),
    ("C$", "$"),
    ("A$", "$"),
    ("₺", "$"),
    ("₹", "$"),
    ("৳", "$"),
    ("₩", "$"),
    ("Mex$", "$"),
    ("₣", "$"),
    ("E£", "$"),
];

/// Python's `str.isspace` for one character.
pub fn py_isspace(c: char) -> bool {
    c.is_whitespace() || ('\u{1c}'..='\u{1f}').contains(&c)
}

/// Python's `str.isspace` for a string (false when empty).
pub fn py_str_isspace(text: &str) -> bool {
    !text.is_empty() && text.chars().all(py_isspace)
}

fn py_isdigit(c: char) -> bool {
    c.is_ascii_digit() || (!c.is_ascii() && c.is_numeric())
}

/// spaCy's `word_shape`: letters to `x`/`X`, digits to `d`, other characters
/// kept, runs cut after four.
pub fn word_shape(text: &str) -> String {
    if text.chars().count() >= 100 {
        return "LONG".to_string();
    }
    let mut shape = String::new();
    let mut last: Option<char> = None;
    let mut seq = 0;
    for c in text.chars() {
        let shape_char = if c.is_alphabetic() {
            if c.is_uppercase() {
                'X'
            } else {
                'x'
            }
        } else if py_isdigit(c) {
            'd'
        } else {
            c
        };
        if Some(shape_char) == last {
            seq += 1;
        } else {
            seq = 0;
            last = Some(shape_char);
        }
        if seq < 4 {
            shape.push(shape_char);
        }
    }
    shape
}

/// The first character (spaCy's PREFIX).
pub fn prefix(text: &str) -> &str {
    match text.char_indices().nth(1) {
        Some((end, _)) => &text[..end],
        None => text,
    }
}

/// The last three characters (spaCy's SUFFIX).
pub fn suffix(text: &str) -> &str {
    match text.char_indices().rev().nth(2) {
        Some((start, _)) => &text[start..],
        None => text,
    }
}

/// The norm table of the vocabulary: the model's `lexeme_norm` lookups
/// (keyed by string id), then `BASE_NORMS`, then lowercase.
#[derive(Debug, Default)]
pub struct Norms {
    table: HashMap<u64, String>,
}

impl Norms {
    /// Wraps the model's `lexeme_norm` table.
    pub fn new(table: HashMap<u64, String>) -> Self {
        Self { table }
    }

    /// The norm of a word as a fresh lexeme gets it.
    pub fn norm(&self, text: &str) -> String {
        if let Some(norm) = self.table.get(&string_id(text)) {
            return norm.clone();
        }
        if let Some((_, norm)) = BASE_NORMS.iter().find(|(word, _)| *word == text) {
            return (*norm).to_string();
        }
        text.to_lowercase()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_follow_spacy() {
        assert_eq!(word_shape("Apple"), "Xxxxx");
        assert_eq!(word_shape("1999s"), "ddddx");
        assert_eq!(word_shape("199999s"), "ddddx");
        assert_eq!(word_shape("C-3PO"), "X-dXX");
        assert_eq!(word_shape("aaaaaaa"), "xxxx");
    }

    #[test]
    fn affixes_count_characters() {
        assert_eq!(prefix("éa"), "é");
        assert_eq!(suffix("bathtub"), "tub");
        assert_eq!(suffix("ab"), "ab");
        assert_eq!(suffix("naïve"), "ïve");
    }
}
