//! Graphics through tmux: the DCS pass-through wrapper that carries an
//! escape sequence to the terminal tmux runs in, and the pane option
//! (`allow-passthrough`) tmux needs to let it through, turned on only with
//! a word to the user and put back as it was on exit.
//!
//! Inside the wrapper (`ESC P tmux; … ESC \`) tmux ends the wrapper at the
//! first `ESC \` it sees, so every ESC of the wrapped sequence is doubled,
//! its own terminator's included, and the wrapper has one terminator.
//! (ratatui-image 11 doubles the ESC of a sixel's introducer but not of its
//! terminator, so tmux ends the wrapper early and the outer terminal shows
//! the rest as text: its issue 192.)

use std::process::{Command, Stdio};

/// The bytes that open tmux's pass-through wrapper.
pub const START: &str = "\x1bPtmux;";
/// The bytes that close it (the one undoubled `ESC \`).
pub const END: &str = "\x1b\\";

/// `sequence` wrapped for tmux to pass through to the outer terminal: every
/// ESC in it doubled, inside one `ESC P tmux;` … `ESC \`.
pub fn wrap(sequence: &str) -> String {
    let mut out = String::with_capacity(sequence.len() + sequence.len() / 16 + 16);
    out.push_str(START);
    for c in sequence.chars() {
        if c == '\x1b' {
            out.push('\x1b');
        }
        out.push(c);
    }
    out.push_str(END);
    out
}

/// Splits `bytes` into the sequences inside its pass-through wrappers, in
/// order, when `bytes` is nothing but well-formed wrappers (each opened by
/// `ESC P tmux;`, every ESC inside doubled, one terminator); otherwise says
/// where it is not.
pub fn unwrap_all(bytes: &str) -> Result<Vec<String>, WrapperError> {
    let mut rest = bytes;
    let mut inner = Vec::new();
    while !rest.is_empty() {
        let Some(body) = rest.strip_prefix(START) else {
            let at = bytes.len() - rest.len();
            return Err(WrapperError::NotAWrapper(at));
        };
        let mut seq = String::new();
        let mut chars = body.char_indices();
        let end = loop {
            match chars.next() {
                None => return Err(WrapperError::NotClosed),
                Some((_, '\x1b')) => match chars.next() {
                    Some((_, '\x1b')) => seq.push('\x1b'),
                    Some((i, '\\')) => break i + 1,
                    _ => return Err(WrapperError::SingleEsc),
                },
                Some((_, c)) => seq.push(c),
            }
        };
        inner.push(seq);
        rest = &body[end..];
    }
    Ok(inner)
}

/// Where bytes are not well-formed tmux pass-through wrappers: what the
/// tests that check every image the workbench sends inside tmux report.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WrapperError {
    /// Bytes outside any wrapper, at this offset.
    #[error("byte {0}: not a tmux pass-through wrapper")]
    NotAWrapper(usize),
    /// A wrapper without its terminator.
    #[error("a wrapper is not closed")]
    NotClosed,
    /// An ESC inside a wrapper that is not doubled.
    #[error("an ESC inside a wrapper is not doubled")]
    SingleEsc,
}

/// Whether this process runs inside tmux (tmux sets `TMUX` in its panes).
pub fn inside(env: &dyn Fn(&str) -> Option<String>) -> bool {
    env("TMUX").is_some_and(|v| !v.is_empty())
        || env("TERM_PROGRAM").is_some_and(|v| v == "tmux")
        || env("TERM").is_some_and(|v| v.starts_with("tmux"))
}

/// The pane's `allow-passthrough`, turned on by the workbench: put back as
/// it was (its own value, or inherited) when dropped.
#[derive(Debug)]
pub struct Passthrough {
    pane: Option<String>,
    /// The pane's own value before it was set; `None` when it inherited.
    previous: Option<String>,
}

impl Drop for Passthrough {
    fn drop(&mut self) {
        let mut args = vec!["set-option", "-p"];
        if let Some(pane) = &self.pane {
            args.extend(["-t", pane.as_str()]);
        }
        match &self.previous {
            Some(value) => args.extend(["allow-passthrough", value.as_str()]),
            None => args.extend(["-u", "allow-passthrough"]),
        }
        let _ = tmux(&args);
    }
}

/// What asking tmux to let graphics through came to.
#[derive(Debug)]
pub enum Allowed {
    /// The pane already lets them through: nothing was changed.
    Already,
    /// The workbench turned `allow-passthrough` on; the guard puts it back.
    TurnedOn(Passthrough),
    /// tmux could not be asked or refused: no graphics through it.
    No(String),
}

/// Makes sure tmux lets escape sequences through to the outer terminal in
/// this pane (`TMUX_PANE`, from `env`), turning `allow-passthrough` on when
/// it is off; the caller says so to the user.
pub fn allow_passthrough(env: &dyn Fn(&str) -> Option<String>) -> Allowed {
    let pane = env("TMUX_PANE").filter(|p| !p.is_empty());
    let target: Vec<&str> = pane.as_deref().map_or(Vec::new(), |p| vec!["-t", p]);
    let show = |flags: &str| {
        let mut args = vec!["show-options", flags];
        args.extend(&target);
        args.push("allow-passthrough");
        tmux(&args)
    };
    let effective = match show("-pvA") {
        Ok(value) => value,
        Err(e) => return Allowed::No(e),
    };
    if effective == "on" || effective == "all" {
        return Allowed::Already;
    }
    let previous = show("-pv").ok().filter(|v| !v.is_empty());
    let mut args = vec!["set-option", "-p"];
    args.extend(&target);
    args.extend(["allow-passthrough", "on"]);
    match tmux(&args) {
        Ok(_) => Allowed::TurnedOn(Passthrough { pane, previous }),
        Err(e) => Allowed::No(e),
    }
}

/// Runs `tmux ARGS` and returns what it printed, trimmed, or why it failed.
fn tmux(args: &[&str]) -> Result<String, String> {
    let out = Command::new("tmux")
        .args(args)
        .stdin(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| format!("tmux cannot be run ({e})"))?;
    if !out.status.success() {
        let why = String::from_utf8_lossy(&out.stderr);
        return Err(format!("tmux {}: {}", args.join(" "), why.trim()));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wrapped_sequence_doubles_every_esc_and_has_one_terminator() {
        let sixel = "\x1b[3X\x1bPq#0;2;0;0;0~-\x1b\\";
        let wrapped = wrap(sixel);
        assert_eq!(
            wrapped,
            "\x1bPtmux;\x1b\x1b[3X\x1b\x1bPq#0;2;0;0;0~-\x1b\x1b\\\x1b\\"
        );
        assert_eq!(unwrap_all(&wrapped), Ok(vec![sixel.to_string()]));
    }

    #[test]
    fn an_undoubled_terminator_inside_is_not_well_formed() {
        // What ratatui-image 11 writes for a sixel in tmux.
        let early = "\x1bPtmux;\x1b\x1bPq~-\x1b\\\x1b\\";
        assert!(unwrap_all(early).is_err());
        assert!(unwrap_all("\x1bPtmux;\x1b\x1bPq").is_err());
        assert!(unwrap_all("x\x1bPtmux;\x1b\\").is_err());
    }

    #[test]
    fn inside_tmux_by_its_variable_or_terminal_name() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |k: &str| {
                pairs
                    .iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| v.to_string())
            }
        };
        assert!(inside(&env(&[("TMUX", "/tmp/tmux-0/default,1,0")])));
        assert!(inside(&env(&[("TERM", "tmux-256color")])));
        assert!(!inside(&env(&[("TERM", "xterm-256color")])));
        assert!(!inside(&env(&[("TMUX", "")])));
    }
}
