//! Asks the terminal what it can draw, without taking a key from the user,
//! and chooses how the scene image is drawn ([`Graphics`]).
//!
//! The query asks for kitty graphics, XTVERSION (the terminal's name and
//! version: kitty draws placeholders only from 0.28), XTSMGRAPHICS (the
//! largest sixel), the device attributes (sixel), the cell size, and ends
//! with a status report every terminal answers. Inside tmux it goes through
//! tmux's pass-through to the outer terminal (tmux would answer XTVERSION
//! itself), after `allow-passthrough` is made sure of ([`tmux`]).
//!
//! The answer is read on the calling thread, straight from the file
//! descriptor with `poll(2)` and a deadline, before any other reader of
//! stdin exists; nothing reads stdin once [`probe`] has returned. Whatever
//! the user typed meanwhile (letters, Tab, Enter, arrows and the other
//! cursor keys) is told apart from the replies and handed back in order.

use std::io::Write;
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui_image::FontSize;
use rustix::event::{PollFd, PollFlags, Timespec};

use super::graphics::tmux::{self, Allowed, Passthrough};
use super::graphics::{Graphics, Kind, Request, DEFAULT_FONT, DEFAULT_MAX_PIXELS};

/// How long the terminal has to answer the query by default (`--query-timeout`).
pub const QUERY_TIMEOUT: Duration = Duration::from_millis(400);

/// The query: kitty graphics, XTVERSION, XTSMGRAPHICS (sixel geometry),
/// device attributes, cell size, then the status report that ends it.
const QUERY: &str =
    "\x1b_Gi=31,s=1,v=1,a=q,t=d,f=24;AAAA\x1b\\\x1b[>0q\x1b[?2;1;0S\x1b[c\x1b[16t\x1b[5n";

/// How long after the deadline a late answer is still waited for (and
/// dropped) by [`Late::drain`].
pub const LATE_WINDOW: Duration = Duration::from_secs(3);

/// What the start-up found: how to draw, what was typed, and tmux's option
/// to put back on exit.
#[derive(Debug)]
pub struct Probe {
    /// How to draw images on this terminal, and why.
    pub graphics: Graphics,
    /// Keys the user typed while the answer was awaited, in order.
    pub typed: Vec<KeyEvent>,
    /// tmux's `allow-passthrough`, turned on by the workbench: dropping it
    /// puts the option back.
    pub passthrough: Option<Passthrough>,
    /// What the user must be told (a tmux option changed).
    pub notice: Option<String>,
    /// The answer had not come by the deadline: the input thread reads on
    /// until it has (or [`LATE_WINDOW`] is over), keeping the keys and
    /// dropping the replies, before it reads events.
    pub late: Option<Late>,
}

/// The rest of an answer that had not come by the deadline.
#[derive(Debug)]
pub struct Late {
    until: Instant,
    bytes: Vec<u8>,
}

impl Late {
    /// Reads stdin until the terminal's status report has come or the
    /// window is over, handing every key typed meanwhile to `key` and
    /// dropping the replies, so a late answer never reads as keys.
    pub fn drain(mut self, mut key: impl FnMut(KeyEvent)) {
        let mut deliver = |bytes: &mut Vec<u8>, at_end: bool| {
            let (tokens, used) = tokenize(bytes, at_end);
            bytes.drain(..used);
            let mut done = false;
            for token in tokens {
                match token {
                    Token::Key(k) => key(k),
                    Token::Reply(Reply::Status) => done = true,
                    Token::Reply(_) => {}
                }
            }
            done
        };
        if !deliver(&mut self.bytes, false) {
            read_until(self.until, &mut self.bytes, |bytes| deliver(bytes, false));
        }
        deliver(&mut self.bytes, true);
    }
}

/// Chooses how to draw images: what `request` asks, from what the terminal
/// answers within `timeout`, with luminance characters for text drawing
/// when `no_color`. Call it in raw mode, before anything else reads stdin.
pub fn probe(request: Request, timeout: Duration, no_color: bool) -> Probe {
    let env = |name: &str| std::env::var(name).ok();
    let mut found = Probe {
        graphics: Graphics::text(no_color, "asked for"),
        typed: Vec::new(),
        passthrough: None,
        notice: None,
        late: None,
    };
    match request {
        Request::None => {
            found.graphics.why = "image off (--graphics none); i shows it in characters".into();
            return found;
        }
        Request::Halfblocks => return found,
        _ => {}
    }
    let auto = request == Request::Auto;
    let in_tmux = tmux::inside(&env);
    if !in_tmux && env("STY").is_some_and(|s| !s.is_empty()) && auto {
        found.graphics.why = "GNU screen passes no graphics through".into();
        return found;
    }
    if in_tmux {
        match tmux::allow_passthrough(&env) {
            Allowed::Already => {}
            Allowed::TurnedOn(guard) => {
                found.passthrough = Some(guard);
                found.notice = Some(
                    "tmux: allow-passthrough turned on for this pane (for the scene image); put back on exit"
                        .into(),
                );
            }
            Allowed::No(why) if auto => {
                found.graphics.why = format!("tmux lets no graphics through ({why})");
                return found;
            }
            Allowed::No(_) => {}
        }
    }
    let stdin = rustix::stdio::stdin();
    if !rustix::termios::isatty(stdin) {
        found.graphics.why = "stdin is not a terminal".into();
        return found;
    }
    let query = if in_tmux {
        tmux::wrap(QUERY)
    } else {
        QUERY.to_string()
    };
    let mut stdout = std::io::stdout();
    if stdout
        .write_all(query.as_bytes())
        .and_then(|()| stdout.flush())
        .is_err()
    {
        found.graphics.why = "the terminal cannot be written to".into();
        return found;
    }
    let mut bytes = Vec::new();
    read_until(Instant::now() + timeout, &mut bytes, |bytes| {
        tokenize(bytes, false)
            .0
            .iter()
            .any(|t| matches!(t, Token::Reply(Reply::Status)))
    });
    let mut answers = Answers::default();
    let complete = tokenize(&bytes, false)
        .0
        .contains(&Token::Reply(Reply::Status));
    let (tokens, used) = tokenize(&bytes, complete);
    if !complete {
        found.late = Some(Late {
            until: Instant::now() + LATE_WINDOW,
            bytes: bytes[used..].to_vec(),
        });
    }
    for token in tokens {
        match token {
            Token::Key(key) => found.typed.push(key),
            Token::Reply(reply) => answers.note(reply),
        }
    }
    let env_hint = env("TERM_PROGRAM").filter(|p| {
        ["iTerm", "WezTerm", "mintty", "vscode", "rio"]
            .iter()
            .any(|n| p.contains(n))
    });
    found.graphics = choose(
        request,
        &answers,
        Context {
            timeout,
            tmux: in_tmux,
            no_color,
            window_cell: font_size_from_window(),
            iterm2_hint: env_hint,
        },
    );
    found
}

/// Reads what the terminal sends into `bytes` until `done` says so after a
/// read, or `deadline` has passed, whichever is first.
fn read_until(deadline: Instant, bytes: &mut Vec<u8>, mut done: impl FnMut(&mut Vec<u8>) -> bool) {
    let stdin = rustix::stdio::stdin();
    let mut buf = [0u8; 256];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        let wait = Timespec::try_from(left).unwrap_or(Timespec {
            tv_sec: 0,
            tv_nsec: 0,
        });
        let mut fds = [PollFd::new(&stdin, PollFlags::IN)];
        match rustix::event::poll(&mut fds, Some(&wait)) {
            Ok(0) => break,
            Ok(_) => {}
            Err(rustix::io::Errno::INTR) => continue,
            Err(_) => break,
        }
        match rustix::io::read(stdin, &mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => bytes.extend_from_slice(&buf[..n]),
        }
        // A cap on what a misbehaving terminal can make us keep.
        if bytes.len() > 64 * 1024 || done(bytes) {
            break;
        }
    }
}

/// One reply of the terminal to the query.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// kitty graphics answered the query image (`OK`, or an error).
    Kitty(bool),
    /// XTVERSION: the terminal's name and version, e.g. `kitty(0.35.0)`.
    Version(String),
    /// XTSMGRAPHICS: the largest sixel, width and height in pixels.
    MaxGraphic(u32, u32),
    /// Device attributes (4 means sixel).
    Attributes(Vec<u16>),
    /// A cell's size in pixels, width and height.
    CellSize(u16, u16),
    /// The status report that ends the answer.
    Status,
    /// Something else the terminal said.
    Other,
}

/// A keystroke or a reply, told apart in what the terminal sent.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Token {
    /// A key the user typed.
    Key(KeyEvent),
    /// A reply to the query.
    Reply(Reply),
}

/// The tokens in `bytes` and how many bytes they take; an unfinished
/// sequence at the end is left for more bytes, unless `at_end` (then a
/// lone ESC is the Esc key and an unfinished sequence is dropped).
pub fn tokenize(bytes: &[u8], at_end: bool) -> (Vec<Token>, usize) {
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        match sequence(&bytes[i..]) {
            Some((token, used)) => {
                tokens.extend(token);
                i += used;
            }
            None if at_end => {
                if bytes[i..] == [0x1b] {
                    tokens.push(Token::Key(key(KeyCode::Esc)));
                }
                i = bytes.len();
            }
            None => break,
        }
    }
    (tokens, i)
}

fn key(code: KeyCode) -> KeyEvent {
    KeyEvent::new(code, KeyModifiers::NONE)
}

/// The token at the start of `bytes` and its length; `None` when it is not
/// complete yet.
fn sequence(bytes: &[u8]) -> Option<(Option<Token>, usize)> {
    let first = *bytes.first()?;
    if first != 0x1b {
        return text_key(bytes);
    }
    let kind = *bytes.get(1)?;
    match kind {
        b'[' => {
            let end = bytes[2..].iter().position(|b| (0x40..=0x7e).contains(b))? + 2;
            let params = String::from_utf8_lossy(&bytes[2..end]).into_owned();
            Some((csi(&params, bytes[end]), end + 1))
        }
        b'O' => {
            let last = *bytes.get(2)?;
            let code = match last {
                b'P'..=b'S' => Some(KeyCode::F(last - b'P' + 1)),
                _ => cursor_key(last),
            };
            Some((code.map(|c| Token::Key(key(c))), 3))
        }
        b'P' | b'_' | b']' => {
            let body = &bytes[2..];
            let (len, term) = body.windows(2).position(|w| w == b"\x1b\\").map_or_else(
                || {
                    (kind == b']')
                        .then(|| body.iter().position(|b| *b == 0x07))
                        .flatten()
                        .map(|p| (p, 1))
                },
                |p| Some((p, 2)),
            )?;
            let text = String::from_utf8_lossy(&body[..len]);
            let reply = match kind {
                b'P' => text
                    .strip_prefix(">|")
                    .map_or(Reply::Other, |v| Reply::Version(v.to_string())),
                b'_' => match text.strip_prefix("Gi=31") {
                    Some(rest) => Reply::Kitty(rest.ends_with(";OK")),
                    None => Reply::Other,
                },
                _ => Reply::Other,
            };
            Some((Some(Token::Reply(reply)), 2 + len + term))
        }
        0x1b => Some((Some(Token::Key(key(KeyCode::Esc))), 1)),
        _ => {
            // ESC then a key: that key with Alt.
            let (token, used) = text_key(&bytes[1..])?;
            let token = match token {
                Some(Token::Key(mut k)) => {
                    k.modifiers |= KeyModifiers::ALT;
                    Some(Token::Key(k))
                }
                other => other,
            };
            Some((token, used + 1))
        }
    }
}

/// A CSI sequence (`params` then the final byte): a reply to the query or
/// a cursor key.
fn csi(params: &str, last: u8) -> Option<Token> {
    let numbers = |s: &str| -> Vec<u16> { s.split(';').filter_map(|n| n.parse().ok()).collect() };
    let reply = match (last, params.strip_prefix('?')) {
        (b'c', Some(list)) => Some(Reply::Attributes(numbers(list))),
        (b'S', Some(list)) => match numbers(list)[..] {
            [2, 0, w, h, ..] => Some(Reply::MaxGraphic(u32::from(w), u32::from(h))),
            _ => Some(Reply::Other),
        },
        (b'n', None) if params == "0" => Some(Reply::Status),
        (b't', None) => match numbers(params)[..] {
            [6, h, w] if w > 0 && h > 0 => Some(Reply::CellSize(w, h)),
            _ => Some(Reply::Other),
        },
        (b'R' | b'n' | b'y', _) => Some(Reply::Other),
        (_, Some(_)) => Some(Reply::Other),
        _ => None,
    };
    if let Some(reply) = reply {
        return Some(Token::Reply(reply));
    }
    let nums = numbers(params);
    let m = nums.get(1).copied().unwrap_or(1).saturating_sub(1);
    let mut modifiers = KeyModifiers::NONE;
    if m & 1 != 0 {
        modifiers |= KeyModifiers::SHIFT;
    }
    if m & 2 != 0 {
        modifiers |= KeyModifiers::ALT;
    }
    if m & 4 != 0 {
        modifiers |= KeyModifiers::CONTROL;
    }
    let code = match last {
        b'A' | b'B' | b'C' | b'D' | b'H' | b'F' => cursor_key(last)?,
        b'Z' => {
            return Some(Token::Key(KeyEvent::new(
                KeyCode::BackTab,
                KeyModifiers::SHIFT,
            )))
        }
        b'~' => match nums.first().copied() {
            Some(1 | 7) => KeyCode::Home,
            Some(2) => KeyCode::Insert,
            Some(3) => KeyCode::Delete,
            Some(4 | 8) => KeyCode::End,
            Some(5) => KeyCode::PageUp,
            Some(6) => KeyCode::PageDown,
            _ => return None,
        },
        _ => return None,
    };
    Some(Token::Key(KeyEvent::new(code, modifiers)))
}

/// The cursor key a CSI or SS3 sequence's final byte names.
fn cursor_key(last: u8) -> Option<KeyCode> {
    Some(match last {
        b'A' => KeyCode::Up,
        b'B' => KeyCode::Down,
        b'C' => KeyCode::Right,
        b'D' => KeyCode::Left,
        b'H' => KeyCode::Home,
        b'F' => KeyCode::End,
        _ => return None,
    })
}

/// A key that is text or a control character, at the start of `bytes`.
fn text_key(bytes: &[u8]) -> Option<(Option<Token>, usize)> {
    let len = match bytes.first()? {
        b if *b < 0x80 => 1,
        b if *b >= 0xf0 => 4,
        b if *b >= 0xe0 => 3,
        _ => 2,
    };
    if bytes.len() < len {
        return None;
    }
    let Ok(text) = std::str::from_utf8(&bytes[..len]) else {
        return Some((None, 1));
    };
    let c = text.chars().next()?;
    let event = match c {
        '\r' | '\n' => key(KeyCode::Enter),
        '\t' => key(KeyCode::Tab),
        '\u{7f}' | '\u{8}' => key(KeyCode::Backspace),
        '\u{1b}' => key(KeyCode::Esc),
        c @ '\u{1}'..='\u{1a}' => KeyEvent::new(
            KeyCode::Char(char::from(b'a' + (c as u8) - 1)),
            KeyModifiers::CONTROL,
        ),
        c if c.is_control() => return Some((None, len)),
        c => key(KeyCode::Char(c)),
    };
    Some((Some(Token::Key(event)), len))
}

/// What the replies said.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Answers {
    /// kitty graphics answered OK.
    pub kitty: bool,
    /// The device attributes name sixel.
    pub sixel: bool,
    /// A cell's size in pixels.
    pub cell: Option<(u16, u16)>,
    /// XTVERSION's answer.
    pub version: Option<String>,
    /// The largest sixel in pixels.
    pub max_graphic: Option<(u32, u32)>,
    /// The status report came: the terminal said all it will say.
    pub complete: bool,
}

impl Answers {
    fn note(&mut self, reply: Reply) {
        match reply {
            Reply::Kitty(ok) => self.kitty |= ok,
            Reply::Version(v) => self.version = Some(v),
            Reply::MaxGraphic(w, h) => self.max_graphic = Some((w, h)),
            Reply::Attributes(list) => self.sixel |= list.contains(&4),
            Reply::CellSize(w, h) => self.cell = Some((w, h)),
            Reply::Status => self.complete = true,
            Reply::Other => {}
        }
    }

    /// Whether the terminal is one whose kitty graphics take Unicode
    /// placeholders: kitty from 0.28, or ghostty.
    fn has_placeholders(&self) -> bool {
        let Some(version) = &self.version else {
            return false;
        };
        if version.starts_with("ghostty") {
            return true;
        }
        let Some(number) = version
            .strip_prefix("kitty(")
            .and_then(|v| v.strip_suffix(')'))
        else {
            return false;
        };
        let mut parts = number.split('.').map(|p| p.parse::<u32>().unwrap_or(0));
        let (major, minor) = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
        (major, minor) >= (0, 28)
    }
}

/// What besides the replies the choice depends on.
#[derive(Debug, Clone)]
pub struct Context {
    /// How long the terminal had to answer.
    pub timeout: Duration,
    /// Whether the bytes go through tmux.
    pub tmux: bool,
    /// Whether `NO_COLOR` is in force.
    pub no_color: bool,
    /// The cell size from the window's size in pixels, when known.
    pub window_cell: Option<FontSize>,
    /// `TERM_PROGRAM` when it names a terminal drawing iTerm2's images.
    pub iterm2_hint: Option<String>,
}

/// How to draw, from the request, the replies and the context: kitty (with
/// placeholders only where the version has them, else placed directly)
/// over sixel over iTerm2 over characters; what was asked for when not
/// `auto`; and why, in words.
pub fn choose(request: Request, answers: &Answers, context: Context) -> Graphics {
    let font = answers
        .cell
        .map(|(w, h)| FontSize::new(w, h))
        .or(context.window_cell);
    let max_pixels = answers.max_graphic.unwrap_or(DEFAULT_MAX_PIXELS);
    let graphics = |kind: Kind, why: String| Graphics {
        kind,
        font: font.unwrap_or(DEFAULT_FONT),
        tmux: context.tmux,
        max_pixels,
        why,
    };
    let text = |why: String| {
        let mut g = Graphics::text(context.no_color, why);
        g.font = font.unwrap_or(DEFAULT_FONT);
        g
    };
    let kitty = || {
        if answers.has_placeholders() {
            Kind::KittyPlaceholders
        } else {
            Kind::KittyDirect
        }
    };
    let version = answers.version.as_deref().unwrap_or("the terminal");
    let asked = |name: &str| format!("asked for (--graphics {name})");
    match request {
        Request::Sixel => return graphics(Kind::Sixel, asked("sixel")),
        Request::Kitty => return graphics(kitty(), asked("kitty")),
        Request::Iterm2 => return graphics(Kind::Iterm2, asked("iterm2")),
        Request::Halfblocks | Request::None => return text(asked("halfblocks")),
        Request::Auto => {}
    }
    if !answers.complete {
        return text(format!(
            "no answer from the terminal in {} ms (--graphics sixel forces)",
            context.timeout.as_millis()
        ));
    }
    if font.is_none() {
        return text("the terminal did not say its cell size".into());
    }
    if answers.kitty {
        return match kitty() {
            Kind::KittyPlaceholders => graphics(
                Kind::KittyPlaceholders,
                format!("{version} answered kitty graphics"),
            ),
            kind => graphics(
                kind,
                format!("{version} answered kitty graphics, without placeholders"),
            ),
        };
    }
    if answers.sixel {
        let limit = match answers.max_graphic {
            Some((w, h)) => format!("at most {w}×{h}"),
            None => format!(
                "at most {}×{} (assumed)",
                DEFAULT_MAX_PIXELS.0, DEFAULT_MAX_PIXELS.1
            ),
        };
        return graphics(Kind::Sixel, format!("{version} draws sixel, {limit}"));
    }
    if let Some(program) = &context.iterm2_hint {
        return graphics(Kind::Iterm2, format!("TERM_PROGRAM={program}"));
    }
    text(format!("{version} answered no graphics protocol"))
}

/// The cell size from the window's size in pixels, when the terminal says it.
fn font_size_from_window() -> Option<FontSize> {
    let size = rustix::termios::tcgetwinsize(rustix::stdio::stdout()).ok()?;
    if size.ws_xpixel == 0 || size.ws_ypixel == 0 || size.ws_col == 0 || size.ws_row == 0 {
        return None;
    }
    Some(FontSize::new(
        size.ws_xpixel / size.ws_col,
        size.ws_ypixel / size.ws_row,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(tokens: &[Token]) -> Vec<KeyEvent> {
        tokens
            .iter()
            .filter_map(|t| match t {
                Token::Key(k) => Some(*k),
                Token::Reply(_) => None,
            })
            .collect()
    }

    fn answers_of(bytes: &[u8]) -> Answers {
        let mut answers = Answers::default();
        for token in tokenize(bytes, true).0 {
            if let Token::Reply(r) = token {
                answers.note(r);
            }
        }
        answers
    }

    fn context() -> Context {
        Context {
            timeout: QUERY_TIMEOUT,
            tmux: false,
            no_color: false,
            window_cell: None,
            iterm2_hint: None,
        }
    }

    #[test]
    fn keys_typed_around_the_replies_arrows_included_are_kept_in_order() {
        let bytes = b"q\x1b[A\x1b_Gi=31;OK\x1b\\\x1bP>|kitty(0.35.0)\x1b\\\x1b[?2;0;1000;1000S\x1b[?62;4c\x1b[1;5B\x1b[6;20;10t\x1b[0n\tx\x1bOD";
        let (tokens, used) = tokenize(bytes, true);
        assert_eq!(used, bytes.len());
        assert_eq!(
            keys(&tokens),
            vec![
                key(KeyCode::Char('q')),
                key(KeyCode::Up),
                KeyEvent::new(KeyCode::Down, KeyModifiers::CONTROL),
                key(KeyCode::Tab),
                key(KeyCode::Char('x')),
                key(KeyCode::Left),
            ]
        );
        let answers = answers_of(bytes);
        assert_eq!(
            answers,
            Answers {
                kitty: true,
                sixel: true,
                cell: Some((10, 20)),
                version: Some("kitty(0.35.0)".into()),
                max_graphic: Some((1000, 1000)),
                complete: true,
            }
        );
    }

    #[test]
    fn an_unfinished_reply_waits_for_more_and_a_lone_esc_at_the_end_is_the_key() {
        let (tokens, used) = tokenize(b"a\x1b[?62;", false);
        assert_eq!((keys(&tokens), used), (vec![key(KeyCode::Char('a'))], 1));
        let (tokens, _) = tokenize(b"\x1b", true);
        assert_eq!(keys(&tokens), vec![key(KeyCode::Esc)]);
        let (tokens, _) = tokenize(b"\x1b\x1b[0n", true);
        assert_eq!(
            tokens,
            vec![Token::Key(key(KeyCode::Esc)), Token::Reply(Reply::Status)]
        );
    }

    #[test]
    fn kitty_before_0_28_is_placed_directly_and_from_0_28_with_placeholders() {
        let old = answers_of(b"\x1b_Gi=31;OK\x1b\\\x1bP>|kitty(0.26.5)\x1b\\\x1b[6;20;10t\x1b[0n");
        let g = choose(Request::Auto, &old, context());
        assert_eq!(g.kind, Kind::KittyDirect, "{}", g.summary());
        let new = answers_of(b"\x1b_Gi=31;OK\x1b\\\x1bP>|kitty(0.35.0)\x1b\\\x1b[6;20;10t\x1b[0n");
        assert_eq!(
            choose(Request::Auto, &new, context()).kind,
            Kind::KittyPlaceholders
        );
    }

    #[test]
    fn sixel_takes_the_terminals_largest_graphic_or_1000_square() {
        let said = answers_of(b"\x1b[?2;0;800;480S\x1b[?62;4c\x1b[6;16;8t\x1b[0n");
        let g = choose(Request::Auto, &said, context());
        assert_eq!((g.kind, g.max_pixels), (Kind::Sixel, (800, 480)));
        assert_eq!(g.font.width, 8);
        let silent = answers_of(b"\x1b[?62;4c\x1b[6;16;8t\x1b[0n");
        let g = choose(Request::Auto, &silent, context());
        assert_eq!(g.max_pixels, (1000, 1000));
        assert!(g.why.contains("assumed"), "{}", g.why);
    }

    #[test]
    fn no_answer_falls_back_to_characters_and_says_why_unless_a_protocol_is_asked_for() {
        let none = Answers::default();
        let g = choose(Request::Auto, &none, context());
        assert_eq!(g.kind, Kind::Halfblocks);
        assert_eq!(
            g.summary(),
            "halfblocks: no answer from the terminal in 400 ms (--graphics sixel forces)"
        );
        let g = choose(
            Request::Auto,
            &none,
            Context {
                no_color: true,
                ..context()
            },
        );
        assert_eq!(g.kind, Kind::Luminance);
        assert_eq!(choose(Request::Sixel, &none, context()).kind, Kind::Sixel);
    }
}
