//! The keys of a row as the table writes them, in a small notation read
//! when the crate compiles (a typo is a compile error, never a key that
//! silently does nothing), and the same keys as the help and the status
//! bar show them, made from the parsed keys so that the two cannot differ.
//!
//! The notation: keys separated by spaces; a printable character stands
//! for itself (`l`, `O`, `?`, `[`); a named key is written in angle
//! brackets, as yazi's keymap does: `<Tab>`, `<S-Tab>`, `<Enter>`, `<Esc>`,
//! `<Backspace>`, `<Delete>`, `<Up>`, `<Down>`, `<Left>`, `<Right>`,
//! `<Home>`, `<End>`, `<PgUp>`, `<PgDn>`, `<Space>`, `<F1>` to `<F12>`,
//! and Ctrl with a letter `<C-r>`.

use std::fmt;

use crossterm::event::KeyCode;

use super::Key;

/// The most keys one row binds: a row is one action, which a handful of
/// keys at most reach.
const MAX_KEYS: usize = 4;

/// The keys of one row, parsed from the table's notation, in the order
/// written (the first is the one a status-bar hint names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Keys {
    list: [Key; MAX_KEYS],
    len: usize,
}

impl Keys {
    /// The keys `notation` names (see the module's documentation). Called
    /// in constants, so that a notation it cannot read stops the build.
    pub(super) const fn parse(notation: &str) -> Keys {
        let bytes = notation.as_bytes();
        let unused = Key {
            code: KeyCode::Null,
            ctrl: false,
        };
        let mut keys = Keys {
            list: [unused; MAX_KEYS],
            len: 0,
        };
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] == b' ' {
                i += 1;
                continue;
            }
            let start = i;
            while i < bytes.len() && bytes[i] != b' ' {
                i += 1;
            }
            let (head, _) = bytes.split_at(i);
            let (_, token) = head.split_at(start);
            assert!(keys.len < MAX_KEYS, "more keys in one row than MAX_KEYS");
            keys.list[keys.len] = key_of(token);
            keys.len += 1;
        }
        assert!(keys.len > 0, "a row of the key table without a key");
        keys
    }

    /// The keys, in the order written.
    pub(super) fn as_slice(&self) -> &[Key] {
        &self.list[..self.len.min(MAX_KEYS)]
    }
}

/// The named keys of the notation (without their brackets).
const NAMED: [(&str, KeyCode); 16] = [
    ("Tab", KeyCode::Tab),
    ("S-Tab", KeyCode::BackTab),
    ("Enter", KeyCode::Enter),
    ("Esc", KeyCode::Esc),
    ("Backspace", KeyCode::Backspace),
    ("Delete", KeyCode::Delete),
    ("Insert", KeyCode::Insert),
    ("Up", KeyCode::Up),
    ("Down", KeyCode::Down),
    ("Left", KeyCode::Left),
    ("Right", KeyCode::Right),
    ("Home", KeyCode::Home),
    ("End", KeyCode::End),
    ("PgUp", KeyCode::PageUp),
    ("PgDn", KeyCode::PageDown),
    ("Space", KeyCode::Char(' ')),
];

/// The key one token of the notation names.
const fn key_of(token: &[u8]) -> Key {
    if let [c] = token {
        assert!(
            c.is_ascii_graphic(),
            "a key of one character is a printable ASCII one"
        );
        return plain(KeyCode::Char(*c as char));
    }
    let [b'<', name @ .., b'>'] = token else {
        panic!("a named key is written in angle brackets, as <Tab>");
    };
    if let [b'C', b'-', c] = name {
        assert!(
            c.is_ascii_lowercase(),
            "Ctrl goes with a small letter: <C-r>"
        );
        return Key {
            code: KeyCode::Char(*c as char),
            ctrl: true,
        };
    }
    if let [b'F', digits @ ..] = name {
        let n = match digits {
            [d @ b'1'..=b'9'] => *d - b'0',
            [b'1', d @ b'0'..=b'2'] => 10 + *d - b'0',
            _ => panic!("a function key is <F1> to <F12>"),
        };
        return plain(KeyCode::F(n));
    }
    let mut i = 0;
    while i < NAMED.len() {
        if same(name, NAMED[i].0.as_bytes()) {
            return plain(NAMED[i].1);
        }
        i += 1;
    }
    panic!("a key name the notation does not know");
}

/// Whether `a` and `b` are the same bytes (`==` on slices is not `const`).
const fn same(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// `code` without Ctrl.
const fn plain(code: KeyCode) -> Key {
    Key { code, ctrl: false }
}

/// How the help and the status bar show a key: `Tab`, `Shift-Tab`, `→`,
/// `Ctrl-R`, `PgUp`, `space`, `F5`, a character as itself.
impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ctrl {
            f.write_str("Ctrl-")?;
        }
        match self.code {
            KeyCode::Char(' ') => f.write_str("space"),
            KeyCode::Char(c) if self.ctrl => write!(f, "{}", c.to_ascii_uppercase()),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::BackTab => f.write_str("Shift-Tab"),
            KeyCode::Up => f.write_str("↑"),
            KeyCode::Down => f.write_str("↓"),
            KeyCode::Left => f.write_str("←"),
            KeyCode::Right => f.write_str("→"),
            KeyCode::PageUp => f.write_str("PgUp"),
            KeyCode::PageDown => f.write_str("PgDn"),
            KeyCode::Delete => f.write_str("Delete"),
            KeyCode::Backspace => f.write_str("Backspace"),
            KeyCode::F(n) => write!(f, "F{n}"),
            other => write!(f, "{other}"),
        }
    }
}

/// `keys` as one label: separated by spaces, an arrow right after an
/// arrow joined to it (`↑↓`), and three or more digits in a row written
/// as a range (`1–5`).
pub(super) fn label(keys: &[Key]) -> String {
    let mut out = String::new();
    let mut i = 0;
    while let Some(key) = keys.get(i) {
        let run = digit_run(&keys[i..]);
        let joined = i > 0 && is_arrow(key) && keys.get(i - 1).is_some_and(is_arrow);
        if i > 0 && !joined {
            out.push(' ');
        }
        if run >= 3 {
            out.push_str(&format!("{key}–{}", keys[i + run - 1]));
            i += run;
        } else {
            out.push_str(&key.to_string());
            i += 1;
        }
    }
    out
}

/// Whether `key` is an arrow key.
fn is_arrow(key: &Key) -> bool {
    matches!(
        key.code,
        KeyCode::Up | KeyCode::Down | KeyCode::Left | KeyCode::Right
    ) && !key.ctrl
}

/// How many keys at the start of `keys` are plain digits, each one more
/// than the one before.
fn digit_run(keys: &[Key]) -> usize {
    let digit = |k: &Key| match k.code {
        KeyCode::Char(c) if !k.ctrl => c.to_digit(10),
        _ => None,
    };
    let Some(first) = keys.first().and_then(digit) else {
        return 0;
    };
    keys.iter()
        .zip(first..)
        .take_while(|(k, n)| digit(k) == Some(*n))
        .count()
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The keys a label shows, read back: the inverse of [`label`], so a
    /// test can hold a label to the keys it was made from.
    pub(in crate::workbench::keymap) fn read_label(label: &str) -> Vec<Key> {
        let mut keys = Vec::new();
        for word in label.split(' ') {
            if let Some((a, b)) = word.split_once('–') {
                let (Ok(a), Ok(b)) = (a.parse::<u8>(), b.parse::<u8>()) else {
                    panic!("a range that is not digits: {word}");
                };
                keys.extend((a..=b).map(|d| plain(KeyCode::Char(char::from(b'0' + d)))));
                continue;
            }
            if word.chars().all(|c| "↑↓←→".contains(c)) && word.chars().count() > 1 {
                keys.extend(word.chars().map(|c| read_key(&c.to_string())));
                continue;
            }
            keys.push(read_key(word));
        }
        keys
    }

    /// The key one word of a label shows.
    fn read_key(word: &str) -> Key {
        if let Some(rest) = word.strip_prefix("Ctrl-") {
            let key = read_key(&rest.to_lowercase());
            return Key { ctrl: true, ..key };
        }
        let code = match word {
            "space" => KeyCode::Char(' '),
            "Shift-Tab" => KeyCode::BackTab,
            "↑" => KeyCode::Up,
            "↓" => KeyCode::Down,
            "←" => KeyCode::Left,
            "→" => KeyCode::Right,
            "PgUp" => KeyCode::PageUp,
            "PgDn" => KeyCode::PageDown,
            "Tab" => KeyCode::Tab,
            "Enter" => KeyCode::Enter,
            "Esc" => KeyCode::Esc,
            "Backspace" => KeyCode::Backspace,
            "Delete" => KeyCode::Delete,
            "Insert" => KeyCode::Insert,
            "Home" => KeyCode::Home,
            "End" => KeyCode::End,
            f if f.starts_with('F') && f.len() > 1 => {
                KeyCode::F(f[1..].parse().unwrap_or_else(|e| panic!("{f}: {e}")))
            }
            c if c.chars().count() == 1 => KeyCode::Char(c.chars().next().unwrap_or(' ')),
            other => panic!("a label word that is no key: {other:?}"),
        };
        plain(code)
    }

    #[test]
    fn the_notation_names_each_key() {
        assert_eq!(Keys::parse(" <Tab>  <S-Tab> l ").as_slice().len(), 3);
        let all = [
            "<Tab>", "<S-Tab>", "<Right>", "<C-r>", "<F5>", "<F12>", "<PgUp>", "<Space>", "l", "O",
            "?",
        ]
        .map(|n| Keys::parse(n).as_slice()[0]);
        assert_eq!(
            all.map(|k| k.to_string()),
            [
                "Tab",
                "Shift-Tab",
                "→",
                "Ctrl-R",
                "F5",
                "F12",
                "PgUp",
                "space",
                "l",
                "O",
                "?"
            ]
        );
        assert_eq!(all[3].code, KeyCode::Char('r'));
        assert!(all[3].ctrl);
        assert_eq!(all[6].code, KeyCode::PageUp);
    }

    #[test]
    fn a_label_joins_arrows_and_ranges_digits_and_reads_back() {
        let keys = |n| Keys::parse(n).as_slice().to_vec();
        let cases = [
            ("<Up> <Down> k j", "↑↓ k j"),
            ("<Left> h <Backspace>", "← h Backspace"),
            ("1 2 3 4", "1–4"),
            ("1 2 0", "1 2 0"),
            ("<Esc> q <Enter>", "Esc q Enter"),
            ("<C-r> <F5>", "Ctrl-R F5"),
        ];
        for (notation, shown) in cases {
            assert_eq!(label(&keys(notation)), shown);
            assert_eq!(read_label(shown), keys(notation), "{shown}");
        }
    }
}
