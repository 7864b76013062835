//! What every part of the workbench shares and that depends on no other
//! part of it: how important a status message is, the clock, the one-line
//! editor. A leaf module, so that sharing these never makes an import
//! circle.

use ratatui::buffer::{Buffer, CellDiffOption};
use ratatui_textarea::TextArea;

/// How important a status message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// For information.
    Info,
    /// Something needs the user.
    Warn,
    /// Something failed.
    Error,
}

/// A status message as the message log (`M`) keeps it: how long after the
/// workbench started it came, and how important it was.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogEntry {
    /// Since the workbench started.
    pub at: std::time::Duration,
    /// The message.
    pub text: String,
    /// How important it was.
    pub severity: Severity,
}

/// The most messages the log keeps (the oldest go first): a workbench left
/// running with retries for days stays small.
pub const LOG_MAX: usize = 2000;

/// A one-line editor holding `text`, the cursor at its end: what every
/// field of a form, the search and the step editor start from.
pub fn single_line_editor(text: &str) -> TextArea<'static> {
    let mut editor = TextArea::new(vec![text.to_string()]);
    editor.move_cursor(ratatui_textarea::CursorMove::End);
    editor
}

/// Calls `stop` when the process gets SIGINT, SIGQUIT, SIGTERM or SIGHUP
/// (`kill`, a closed SSH session; in raw mode Ctrl-C is a key, not a
/// signal): each screen then quits through its own loop, so the terminal is
/// restored and the work saved, where the default would leave it raw on the
/// alternate screen. Needs a Tokio runtime.
pub fn spawn_signal_watch(stop: impl Fn() + Clone + Send + 'static) {
    use tokio::signal::unix::{signal, SignalKind};
    for kind in [
        SignalKind::interrupt(),
        SignalKind::quit(),
        SignalKind::terminate(),
        SignalKind::hangup(),
    ] {
        let stop = stop.clone();
        if let Ok(mut stream) = signal(kind) {
            tokio::spawn(async move {
                if stream.recv().await.is_some() {
                    stop();
                }
            });
        }
    }
}

/// The seconds since the Unix epoch (0 on a clock set before it): when a
/// run or a corruption happened, as the session keeps it.
pub fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Folds every drawn character of `buffer` to ASCII ([`crate::locale::ascii_of`])
/// for a locale that cannot show UTF-8, leaving the cells a picture is made
/// of alone: those holding a graphics protocol's escape sequence, the cells
/// it covers, and kitty's placeholder characters.
pub fn fold_to_ascii(buffer: &mut Buffer) {
    /// The character kitty's Unicode placement draws a picture with.
    const KITTY_PLACEHOLDER: char = '\u{10eeee}';
    for cell in &mut buffer.content {
        let symbol = cell.symbol();
        if cell.diff_option == CellDiffOption::Skip
            || symbol.is_ascii()
            || symbol.starts_with(KITTY_PLACEHOLDER)
        {
            continue;
        }
        let folded: String = symbol
            .chars()
            .take(1)
            .map(crate::locale::ascii_of)
            .collect();
        cell.set_symbol(&folded);
    }
}
