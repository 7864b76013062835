//! mapvlm on a pseudo-terminal of `script`'s, whose other side the test
//! plays: it reads every byte mapvlm writes and types, or answers, as a
//! terminal would.

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The running program and what it has written so far.
pub struct Pty {
    child: std::process::Child,
    stdin: std::process::ChildStdin,
    output: Arc<Mutex<Vec<u8>>>,
    cols: u16,
}

/// The terminal's rows.
const ROWS: u16 = 40;

impl Pty {
    /// mapvlm on the demo in a 120×40 terminal (`TERM=xterm-256color`,
    /// outside tmux, colour allowed), its session and caches in `dir`.
    pub fn start(dir: &Path) -> Pty {
        Pty::start_with(dir, "", &[])
    }

    /// The same with `flags` added to the command line and `env` set.
    pub fn start_with(dir: &Path, flags: &str, env: &[(&str, &str)]) -> Pty {
        Pty::start_wide(dir, flags, env, 120)
    }

    /// The same in a terminal `cols` columns wide (a header with room for
    /// every field). Fails when `script` (util-linux) is missing.
    pub fn start_wide(dir: &Path, flags: &str, env: &[(&str, &str)], cols: u16) -> Pty {
        let found = Command::new("script").arg("--version").output();
        assert!(
            found.is_ok_and(|o| o.status.success()),
            "script (util-linux) is not installed: install it to run this test"
        );
        let command = format!(
            "stty rows {ROWS} cols {cols}; exec {} {flags} --replay-delay 1 --session {}",
            env!("CARGO_BIN_EXE_mapvlm"),
            dir.join("session.json").display()
        );
        let mut command_line = Command::new("script");
        command_line
            .args(["-q", "-e", "-c", &command, "/dev/null"])
            .env_remove("TMUX")
            .env_remove("TMUX_PANE")
            .env_remove("STY")
            .env_remove("TERM_PROGRAM")
            .env_remove("NO_COLOR")
            .env("TERM", "xterm-256color")
            .env("HOME", dir)
            .env("XDG_CONFIG_HOME", dir.join(".config"))
            .env("XDG_CACHE_HOME", dir.join(".cache"))
            .env("MAPVLM_MODELS", super::pack_dir());
        for (name, value) in env {
            command_line.env(name, value);
        }
        let mut child = command_line
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("script starts");
        let stdin = child.stdin.take().unwrap();
        let mut stdout = child.stdout.take().unwrap();
        let output = Arc::new(Mutex::new(Vec::new()));
        let sink = output.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = stdout.read(&mut buf) {
                if n == 0 {
                    return;
                }
                sink.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        });
        Pty {
            child,
            stdin,
            output,
            cols,
        }
    }

    /// Types (or answers) `bytes`.
    pub fn send(&mut self, bytes: &[u8]) {
        self.stdin.write_all(bytes).unwrap();
        self.stdin.flush().unwrap();
    }

    /// Everything written so far.
    pub fn output(&self) -> Vec<u8> {
        self.output.lock().unwrap().clone()
    }

    /// Waits until `text` has been written (30 s at most); returns where
    /// it starts in the output.
    pub fn wait_for(&self, what: &str, text: &str) -> usize {
        self.wait_for_after(what, text, 0)
    }

    /// Waits until `text` has been written after byte `from` (30 s at
    /// most); returns where it starts.
    pub fn wait_for_after(&self, what: &str, text: &str, from: usize) -> usize {
        let start = Instant::now();
        loop {
            let found = {
                let out = self.output.lock().unwrap();
                out.get(from..)
                    .and_then(|tail| tail.windows(text.len()).position(|w| w == text.as_bytes()))
            };
            if let Some(at) = found {
                return from + at;
            }
            if start.elapsed() > Duration::from_secs(30) {
                let out = self.output();
                let tail = String::from_utf8_lossy(&out[out.len().saturating_sub(3000)..])
                    .escape_debug()
                    .to_string();
                panic!("timed out waiting for {what}; the last bytes written:\n{tail}");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The text on the screen the output has drawn so far: cursor
    /// positioning and text followed, every other sequence (colours,
    /// graphics) left out.
    pub fn screen(&self) -> String {
        screen_of(&self.output(), usize::from(self.cols), usize::from(ROWS))
    }

    /// Waits until the screen satisfies `ok` (30 s at most) and returns it.
    pub fn wait_screen(&self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        super::tmux::wait(what, || {
            let screen = self.screen();
            ok(&screen).then_some(screen.clone()).ok_or(screen)
        })
    }

    /// Waits for the program to end (10 s at most) and returns its exit code.
    pub fn exit_code(&mut self) -> Option<i32> {
        let start = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status.code();
            }
            if start.elapsed() > Duration::from_secs(10) {
                let _ = self.child.kill();
                panic!("mapvlm did not quit");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// A test that fails before mapvlm quits takes it down with it: `script`
/// killed, its terminal hangs up, and mapvlm (which saves and exits on the
/// hangup) does not outlive the test holding half a gigabyte.
impl Drop for Pty {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// The text `bytes` leaves on a `width`×`height` screen (see [`Pty::screen`]).
pub fn screen_of(bytes: &[u8], width: usize, height: usize) -> String {
    use unicode_width::UnicodeWidthChar;
    let text = String::from_utf8_lossy(bytes);
    let mut grid = vec![vec![' '; width]; height];
    let (mut row, mut col) = (0usize, 0usize);
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\x1b' => match chars.next() {
                Some('[') => {
                    let mut params = String::new();
                    let mut last = None;
                    for c in chars.by_ref() {
                        if ('\u{40}'..='\u{7e}').contains(&c) {
                            last = Some(c);
                            break;
                        }
                        params.push(c);
                    }
                    let n: Vec<usize> = params.split(';').map(|p| p.parse().unwrap_or(1)).collect();
                    match last {
                        Some('H') => {
                            row = n.first().copied().unwrap_or(1).saturating_sub(1);
                            col = n.get(1).copied().unwrap_or(1).saturating_sub(1);
                        }
                        Some('J') if params == "2" => {
                            grid = vec![vec![' '; width]; height];
                        }
                        _ => {}
                    }
                }
                // Strings (DCS, APC, OSC): up to ESC \ or BEL.
                Some('P' | '_' | ']') => {
                    while let Some(c) = chars.next() {
                        if c == '\u{7}' || (c == '\x1b' && chars.next_if_eq(&'\\').is_some()) {
                            break;
                        }
                    }
                }
                _ => {}
            },
            '\r' => col = 0,
            '\n' => row += 1,
            c if c.is_control() => {}
            c => {
                let w = c.width().unwrap_or(0);
                if w == 0 {
                    continue;
                }
                if let Some(cell) = grid.get_mut(row).and_then(|r| r.get_mut(col)) {
                    *cell = c;
                }
                col += w;
            }
        }
    }
    grid.into_iter()
        .map(|r| r.into_iter().collect::<String>().trim_end().to_string())
        .collect::<Vec<_>>()
        .join("\n")
}
