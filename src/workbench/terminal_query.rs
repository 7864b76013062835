//! Asks the terminal which graphics it can draw, without taking a key from
//! the user.
//!
//! ratatui-image's own query (`Picker::from_query_stdio`) reads the answer on
//! a thread of its own through the buffered `std::io::stdin()`. When the
//! terminal does not answer before the timeout (tmux with no outer terminal
//! answering the pass-through query, a slow SSH link), that thread stays
//! blocked in `read`: the user's first key goes to it and is dropped, and
//! crossterm's reader, woken by the same key, then blocks in its own `read`
//! until the next key, so a resize is not drawn either. Here the answer is
//! read on the calling thread, straight from the file descriptor with
//! `poll(2)` and a deadline, before any other reader of stdin exists; nothing
//! reads stdin once [`query_picker`] has returned, and keys typed while it
//! waited are handed back.

use std::io::Write;
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui_image::picker::cap_parser::{Parser, QueryStdioOptions, Response};
use ratatui_image::picker::{Picker, ProtocolType};
use ratatui_image::FontSize;
use rustix::event::{PollFd, PollFlags, Timespec};

/// How long the terminal has to answer the graphics query.
pub const QUERY_TIMEOUT: Duration = Duration::from_millis(400);

/// What the terminal's answer (or its silence) tells.
pub struct Probe {
    /// How to draw images on this terminal.
    pub picker: Picker,
    /// Keys the user typed while the answer was awaited, in order.
    pub typed: Vec<KeyEvent>,
}

/// Sends the graphics query and reads the answer for at most `timeout`.
/// Call it in raw mode, before anything else reads stdin.
pub fn query_picker(timeout: Duration) -> Probe {
    // Also detects tmux (and lets it pass queries through to the terminal).
    let fallback = Picker::halfblocks();
    let stdin = rustix::stdio::stdin();
    if !rustix::termios::isatty(stdin) {
        return Probe {
            picker: fallback,
            typed: Vec::new(),
        };
    }
    let query = Parser::query(fallback.tmux_detected(), QueryStdioOptions::default());
    let mut stdout = std::io::stdout();
    if stdout
        .write_all(query.as_bytes())
        .and_then(|()| stdout.flush())
        .is_err()
    {
        return Probe {
            picker: fallback,
            typed: Vec::new(),
        };
    }
    let mut answer = Answer::default();
    let deadline = Instant::now() + timeout;
    let mut buf = [0u8; 256];
    while !answer.complete {
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
            Ok(n) => answer.push(&buf[..n]),
        }
    }
    Probe {
        picker: answer.picker(fallback),
        typed: keys_of(&answer.typed),
    }
}

/// The terminal's replies and the user's keystrokes, told apart as they come.
#[derive(Default)]
struct Answer {
    parser: Parser,
    /// Replies start with ESC; bytes before the first one are keystrokes.
    replying: bool,
    responses: Vec<Response>,
    typed: Vec<u8>,
    /// The closing status report came: the terminal said all it will say.
    complete: bool,
}

impl Answer {
    fn push(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            if self.complete {
                self.typed.push(byte);
                continue;
            }
            if !self.replying && byte != 0x1b {
                self.typed.push(byte);
                continue;
            }
            self.replying = true;
            for response in self.parser.push(char::from(byte)) {
                match response {
                    Response::Status => self.complete = true,
                    other => self.responses.push(other),
                }
            }
        }
    }

    /// The picker the replies call for: kitty over sixel over what the
    /// environment suggests, sized by the reported cell size (or the
    /// window's pixel size), half-blocks when no size is known.
    fn picker(&self, fallback: Picker) -> Picker {
        let cell = self.responses.iter().find_map(|r| match r {
            Response::CellSize(Some((w, h))) => Some(FontSize::new(*w, *h)),
            _ => None,
        });
        let Some(font_size) = cell.or_else(font_size_from_window) else {
            return fallback;
        };
        let has = |wanted: &Response| self.responses.iter().any(|r| r == wanted);
        // `from_fontsize` is the one public constructor taking a font size;
        // it is deprecated only in favour of the query this module replaces.
        #[allow(deprecated)]
        let mut picker = Picker::from_fontsize(font_size);
        if has(&Response::Kitty) {
            picker.set_protocol_type(ProtocolType::Kitty);
        } else if has(&Response::Sixel) {
            picker.set_protocol_type(ProtocolType::Sixel);
        }
        picker
    }
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

/// The keys in bytes a terminal sent in raw mode: text, Enter, Tab,
/// Backspace, Esc and Ctrl+letter (what a user types in the first moments).
fn keys_of(bytes: &[u8]) -> Vec<KeyEvent> {
    String::from_utf8_lossy(bytes)
        .chars()
        .map(|c| match c {
            '\r' | '\n' => KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE),
            '\t' => KeyEvent::new(KeyCode::Tab, KeyModifiers::NONE),
            '\u{7f}' | '\u{8}' => KeyEvent::new(KeyCode::Backspace, KeyModifiers::NONE),
            '\u{1b}' => KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE),
            c @ '\u{1}'..='\u{1a}' => KeyEvent::new(
                KeyCode::Char(char::from(b'a' + (c as u8) - 1)),
                KeyModifiers::CONTROL,
            ),
            c => KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_typed_before_the_reply_are_kept_and_the_reply_is_parsed() {
        let mut answer = Answer::default();
        answer.push(b"q?");
        answer.push(b"\x1b_Gi=31;OK\x1b\\\x1b[?62;4c\x1b[6;20;10t");
        assert!(!answer.complete);
        answer.push(b"\x1b[0n");
        assert!(answer.complete);
        assert_eq!(
            answer.responses,
            vec![
                Response::Kitty,
                Response::Sixel,
                Response::CellSize(Some((10, 20)))
            ]
        );
        let keys = keys_of(&answer.typed);
        assert_eq!(
            keys,
            vec![
                KeyEvent::new(KeyCode::Char('q'), KeyModifiers::NONE),
                KeyEvent::new(KeyCode::Char('?'), KeyModifiers::NONE),
            ]
        );
        let picker = answer.picker(Picker::halfblocks());
        assert_eq!(picker.protocol_type(), ProtocolType::Kitty);
        assert_eq!(picker.font_size().width, 10);
        assert_eq!(picker.font_size().height, 20);
    }

    #[test]
    fn sixel_without_kitty_and_keys_after_the_status_report() {
        let mut answer = Answer::default();
        answer.push(b"\x1b[?62;4c\x1b[6;16;8t\x1b[0n\r\x03x");
        assert!(answer.complete);
        let picker = answer.picker(Picker::halfblocks());
        assert_eq!(picker.protocol_type(), ProtocolType::Sixel);
        assert_eq!(
            keys_of(&answer.typed),
            vec![
                KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE),
                KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL),
                KeyEvent::new(KeyCode::Char('x'), KeyModifiers::NONE),
            ]
        );
    }
}
