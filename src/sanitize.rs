//! Making text from outside (model answers, server error bodies) safe to print.
//!
//! Text that reaches a terminal can carry control sequences: OSC 52 writes the
//! clipboard, CSI 6n and DECRQSS make the terminal type a reply into our stdin,
//! a bare `\r` or backspaces overwrite what was printed, and bidi overrides
//! reorder what the user reads. Such text is data, so every forbidden code
//! point is shown visibly as a `\u{..}` escape instead of being interpreted.

/// Whether `c` must not reach a terminal as is: C0 controls other than `\n`
/// and `\t`, DEL, C1 controls (U+0080–U+009F) and bidi/invisible format
/// characters (U+200B–U+200F, U+202A–U+202E, U+2066–U+2069).
pub fn is_unsafe(c: char) -> bool {
    matches!(c,
        '\u{0}'..='\u{8}' | '\u{b}'..='\u{1f}' | '\u{7f}'..='\u{9f}'
        | '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// Returns `s` with every [`is_unsafe`] code point replaced by its Rust-style
/// escape (`\u{1b}`), so that the text prints as data and a bare `\r` cannot
/// fake a line. A backslash is left alone, so the output is for reading, not
/// for parsing back.
pub fn for_terminal(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if is_unsafe(c) {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_controls_and_keeps_newline_tab() {
        let s = "a\x1b]52;c;Zm9v\x07b\r\nc\td\u{9b}6n\u{202e}x\x7f";
        assert_eq!(
            for_terminal(s),
            "a\\u{1b}]52;c;Zm9v\\u{7}b\\u{d}\nc\td\\u{9b}6n\\u{202e}x\\u{7f}"
        );
    }

    #[test]
    fn output_never_contains_unsafe_code_points() {
        for cp in 0u32..0x3000 {
            if let Some(c) = char::from_u32(cp) {
                let s: String = [c, 'x', c].iter().collect();
                assert!(!for_terminal(&s).chars().any(is_unsafe), "{cp:x}");
            }
        }
    }
}
