//! What the user's locale lets mapvlm print: UTF-8, or only ASCII.
//!
//! Under `LANG=C` (or any locale whose character set is not UTF-8) a
//! terminal shows box drawing, arrows and `✓` as mojibake or question
//! marks, so the workbench, the annotation screen and the text reports fold
//! what they draw to ASCII instead: lines to `-`, `|` and `+`, arrows to
//! `>` `<` `^` `v`, marks to letters. Text in files (tables, records) stays
//! UTF-8: it is data, read by programs, not by this terminal.

use std::borrow::Cow;

/// Whether the locale in the environment is UTF-8, read as the C library
/// does: the first of `LC_ALL`, `LC_CTYPE` and `LANG` that is set and not
/// empty decides. None set is taken as UTF-8: that is how terminals are
/// nearly always set up when the variables are simply not passed on (a
/// container, `ssh` without `SendEnv`), where folding would only lose text.
pub fn utf8_locale() -> bool {
    let value = ["LC_ALL", "LC_CTYPE", "LANG"]
        .iter()
        .find_map(|name| std::env::var(name).ok().filter(|v| !v.is_empty()));
    value.is_none_or(|v| is_utf8_locale(&v))
}

/// Whether one locale name (`en_GB.UTF-8`, `C.utf8`, `C`, `POSIX`,
/// `de_DE.ISO-8859-1`) has UTF-8 as its character set.
pub fn is_utf8_locale(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.contains("utf-8") || lower.contains("utf8")
}

/// `text` as the locale can show it: unchanged under UTF-8, else folded to
/// ASCII by [`ascii_of`] character by character.
pub fn for_locale(text: &str, utf8: bool) -> Cow<'_, str> {
    if utf8 || text.is_ascii() {
        return Cow::Borrowed(text);
    }
    Cow::Owned(text.chars().map(ascii_of).collect())
}

/// The ASCII stand-in for one character: itself when ASCII, a line, arrow
/// or mark of the same meaning for the glyphs mapvlm draws, `?` for the
/// rest (a letter no ASCII terminal can show). Always one column, so a
/// folded screen keeps its layout.
pub fn ascii_of(c: char) -> char {
    if c.is_ascii() {
        return c;
    }
    match c {
        // Box drawing: the horizontal lines, the vertical ones, the rest
        // (corners, tees, crosses) as a cross.
        '─' | '━' | '═' | '╌' | '╍' | '┄' | '┅' | '┈' | '┉' | '╴' | '╶' | '╸' | '╺' => {
            '-'
        }
        '│' | '┃' | '║' | '╎' | '╏' | '┆' | '┇' | '┊' | '┋' | '╵' | '╷' | '╹' | '╻' => {
            '|'
        }
        '\u{2500}'..='\u{257f}' => '+',
        // Half and full blocks: the half-block picture keeps its colours in
        // the cell's background, a full block is a solid mark.
        '▀' | '▄' | '▌' | '▐' => ' ',
        '█' | '▓' => '#',
        '▒' | '░' => ':',
        '→' | '▶' | '►' | '▸' | '⟶' | '⇒' | '❯' | '›' | '»' => '>',
        '←' | '◀' | '◄' | '◂' | '⟵' | '⇐' | '‹' | '«' => '<',
        '↑' | '▲' | '▴' | '⇡' => '^',
        '↓' | '▼' | '▾' | '⇣' => 'v',
        '↔' | '⇄' | '↕' => '-',
        '·' | '•' | '●' | '∙' | '◦' | '○' => '*',
        '…' => '~',
        '×' | '✗' | '✘' => 'x',
        '✓' | '✔' => '+',
        '±' => '~',
        '–' | '—' | '‐' | '−' => '-',
        '‘' | '’' | '′' => '\'',
        '“' | '”' | '″' => '"',
        '≥' => '>',
        '≤' => '<',
        '≈' | '∼' => '~',
        '≠' => '#',
        '\u{a0}' | '\u{2000}'..='\u{200a}' | '\u{202f}' => ' ',
        _ => '?',
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locale_names_are_read_by_their_character_set() {
        for name in ["en_GB.UTF-8", "C.UTF-8", "C.utf8", "de_DE.utf8@euro"] {
            assert!(is_utf8_locale(name), "{name}");
        }
        for name in ["C", "POSIX", "de_DE.ISO-8859-1", "en_US"] {
            assert!(!is_utf8_locale(name), "{name}");
        }
    }

    #[test]
    fn folded_text_is_ascii_one_column_a_character_and_keeps_its_meaning() {
        let text = "┌─ Plan ─┐ │ ✓ 1 → 2 · 0.900 ±0.010 ✗ café … ▶ mug ╰─╯ ≥ 0.5";
        let folded = for_locale(text, false);
        assert!(folded.is_ascii(), "{folded}");
        assert_eq!(folded.chars().count(), text.chars().count());
        assert_eq!(
            folded,
            "+- Plan -+ | + 1 > 2 * 0.900 ~0.010 x caf? ~ > mug +-+ > 0.5"
        );
        assert_eq!(for_locale(text, true), text);
    }
}
