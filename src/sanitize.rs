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
    escape_unsafe(s, |cp| format!("\\u{{{cp:x}}}"))
}

/// `s` as one line of a message: [`for_terminal`], with each line break
/// shown as `\n`, so that a path, a body or an answer quoted in an error
/// can neither split the line nor fake another one.
pub fn one_line(s: &str) -> String {
    for_terminal(s).replace('\n', "\\n")
}

/// One CSV field as RFC 4180 writes it: quoted, with its quotes doubled,
/// when it holds a comma, a quote or a line break; as it is otherwise.
pub fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// A CSV field of free text from people (notes, labels): [`csv_field`],
/// with a leading `'` when it starts with `=`, `+`, `-`, `@`, a tab or a
/// carriage return, so that a spreadsheet shows it as text instead of
/// running it as a formula (notes may come from crowd workers; OWASP's
/// advice on CSV injection). Not for numbers, whose `-` must stay.
pub fn csv_text_field(text: &str) -> String {
    if text.starts_with(['=', '+', '-', '@', '\t', '\r']) {
        csv_field(&format!("'{text}"))
    } else {
        csv_field(text)
    }
}

/// `s` with every [`is_unsafe`] code point replaced by `escape` of its
/// number: the one loop behind the terminal and the JSON escaping.
fn escape_unsafe(s: &str, escape: impl Fn(u32) -> String) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if is_unsafe(c) {
            out.push_str(&escape(c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

/// Returns `text` with the credentials of every URL in it replaced by `***`
/// (`http://user:sk-…@host/v1` → `http://***@host/v1`), so that a key given
/// in a base URL never reaches a message, a log, a record or `--json`.
/// Works on a URL alone and on any text quoting URLs (an error message);
/// text without `scheme://…@` is returned as it is.
pub fn redact_url_credentials(text: &str) -> String {
    static USERINFO: std::sync::LazyLock<Option<regex::Regex>> = std::sync::LazyLock::new(|| {
        regex::Regex::new(r"(?i)\b([a-z][a-z0-9+.\-]*://)[^/?#@\s]*@").ok()
    });
    match USERINFO.as_ref() {
        Some(userinfo) => userinfo.replace_all(text, "${1}***@").into_owned(),
        None => text.to_string(),
    }
}

/// What is printed for a body that is not text (a gzip body, an image, a
/// truncated UTF-8 sequence): its size, never its bytes.
pub fn body_text(body: &[u8]) -> String {
    if body.starts_with(&[0x1f, 0x8b]) {
        return format!("binary body, {} bytes", body.len());
    }
    match std::str::from_utf8(body) {
        Ok(text) => for_terminal(text),
        // A text body cut inside its last character (a bounded read).
        Err(cut) if cut.error_len().is_none() => {
            for_terminal(&String::from_utf8_lossy(&body[..cut.valid_up_to()]))
        }
        Err(_) => format!("binary body, {} bytes", body.len()),
    }
}

/// Writes `value` as pretty JSON whose strings escape every [`is_unsafe`]
/// code point as `\uXXXX` (serde_json escapes only C0 controls), so that
/// `--json` output is exactly the data and still safe on a terminal. Such
/// a code point can only stand inside a string of serde_json's output (the
/// rest is ASCII), and each is below U+FFFF, so escaping it there is exact.
pub fn write_json_pretty<W: std::io::Write, T: serde::Serialize + ?Sized>(
    mut writer: W,
    value: &T,
) -> serde_json::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let out = escape_unsafe(&text, |cp| format!("\\u{cp:04x}"));
    writer
        .write_all(out.as_bytes())
        .map_err(serde_json::Error::io)
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
    fn one_line_shows_line_breaks_so_nothing_splits_the_line() {
        let line = one_line("image a\nmapvlm: fake.png\r\n\tdone");
        assert_eq!(line, "image a\\nmapvlm: fake.png\\u{d}\\n\tdone");
        assert_eq!(line.lines().count(), 1);
    }

    #[test]
    fn url_credentials_are_redacted_in_urls_and_in_text() {
        assert_eq!(
            redact_url_credentials("http://user:sk-abc@host:8000/v1?x=a@b"),
            "http://***@host:8000/v1?x=a@b"
        );
        assert_eq!(
            redact_url_credentials(
                "error sending request for url (HTTPS://sk-1@h/v1/chat): refused"
            ),
            "error sending request for url (HTTPS://***@h/v1/chat): refused"
        );
        assert_eq!(
            redact_url_credentials("http://host/v1 mail a@b"),
            "http://host/v1 mail a@b"
        );
    }

    #[test]
    fn a_binary_body_is_named_by_its_size() {
        assert_eq!(body_text(&[0x1f, 0x8b, 8, 0, 1, 2]), "binary body, 6 bytes");
        assert_eq!(body_text(b"bad\xff"), "binary body, 4 bytes");
        assert_eq!(body_text("no \x1b[2J".as_bytes()), "no \\u{1b}[2J");
    }

    #[test]
    fn json_escapes_every_unsafe_code_point_and_reads_back_the_same() {
        let text = "a\u{9b}6n\u{202e}b\x7f\x1b]52;c;x\x07 é";
        let mut out = Vec::new();
        write_json_pretty(&mut out, &serde_json::json!({ "k": [text] })).unwrap();
        let printed = String::from_utf8(out).unwrap();
        assert!(!printed.chars().any(is_unsafe), "{printed}");
        assert!(
            printed.contains("\\u009b") && printed.contains("\\u202e"),
            "{printed}"
        );
        let back: serde_json::Value = serde_json::from_str(&printed).unwrap();
        assert_eq!(back["k"][0], text);
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
