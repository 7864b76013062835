//! A tmux driver for the end-to-end tests: the real binary in a terminal of
//! its own, driven with keys and read from the screen as a person would.
//! Each driver has its own `-L` socket, so parallel runs never collide.

use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// How long a wait lasts before it fails the test with the last state seen.
const WAIT_LIMIT: Duration = Duration::from_secs(30);

/// One tmux server of a test, killed when the driver is dropped.
pub struct Tmux {
    socket: String,
}

impl Tmux {
    /// A tmux server on the socket `mapvlm-LABEL-PID-N` (N counts the
    /// drivers of this process, since every test shares one binary); fails
    /// the test when tmux is missing (`.ci/run` installs it).
    pub fn new(label: &str) -> Tmux {
        static DRIVERS: AtomicUsize = AtomicUsize::new(0);
        let version = Command::new("tmux").arg("-V").output();
        assert!(
            version.is_ok_and(|o| o.status.success()),
            "tmux is not installed: install it to run the end-to-end tests (.ci/run does)"
        );
        Tmux {
            socket: format!(
                "mapvlm-{label}-{}-{}",
                std::process::id(),
                DRIVERS.fetch_add(1, Ordering::Relaxed)
            ),
        }
    }

    /// The server's socket name (`tmux -L NAME`), for a client of its own.
    pub fn socket(&self) -> &str {
        &self.socket
    }

    /// Runs `tmux ARGS` on this server and returns what it printed.
    pub fn cmd(&self, args: &[&str]) -> String {
        let out = Command::new("tmux")
            .arg("-L")
            .arg(&self.socket)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("tmux {args:?}: {e}"));
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// Opens session `name`, `width`×`height`, running the shell `command`.
    pub fn open(&self, name: &str, width: u16, height: u16, command: &str) {
        let (width, height) = (width.to_string(), height.to_string());
        self.cmd(&[
            "new-session",
            "-d",
            "-s",
            name,
            "-x",
            &width,
            "-y",
            &height,
            command,
        ]);
    }

    /// The text on session `name`'s screen.
    pub fn screen(&self, name: &str) -> String {
        self.cmd(&["capture-pane", "-p", "-t", name])
    }

    /// Sends `keys` (tmux `send-keys` arguments) to session `name`.
    pub fn keys(&self, name: &str, keys: &[&str]) {
        let mut args = vec!["send-keys", "-t", name];
        args.extend(keys);
        self.cmd(&args);
    }

    /// Wraps shell `command` so that the pane records the terminal's
    /// settings before and after it (`DIR/before`, `DIR/after`) and stays
    /// open, for [`Tmux::assert_restored`].
    pub fn bracketed(dir: &Path, command: &str) -> String {
        format!(
            "stty -g > {dir}/before; {command}; stty -g > {dir}/after; sleep 600",
            dir = dir.display()
        )
    }

    /// Asserts that the program run [`Tmux::bracketed`] in session `name`
    /// ended leaving the terminal as it found it: the same `stty -g`, the
    /// alternate screen and mouse reporting off. `what` names the case.
    pub fn assert_restored(&self, name: &str, dir: &Path, what: &str) {
        let after = wait("the terminal's settings after the run", || {
            std::fs::read_to_string(dir.join("after"))
                .ok()
                .filter(|text| text.ends_with('\n'))
                .ok_or_else(|| self.screen(name))
        });
        let before = std::fs::read_to_string(dir.join("before")).unwrap();
        assert_eq!(after, before, "{what}: stty -g after equals before");
        let modes = self.cmd(&[
            "display-message",
            "-p",
            "-t",
            name,
            "#{alternate_on} #{mouse_any_flag}",
        ]);
        assert_eq!(
            modes.trim(),
            "0 0",
            "{what}: alternate screen and mouse off"
        );
    }

    /// Waits until session `name`'s screen satisfies `ok` and returns it.
    pub fn wait_for(&self, name: &str, what: &str, ok: impl Fn(&str) -> bool) -> String {
        wait(what, || {
            let screen = self.screen(name);
            ok(&screen).then_some(screen.clone()).ok_or(screen)
        })
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        self.cmd(&["kill-server"]);
    }
}

/// Polls `probe` until it gives a value; fails with its last state after 30 s.
pub fn wait<T>(what: &str, probe: impl Fn() -> Result<T, String>) -> T {
    let start = Instant::now();
    loop {
        match probe() {
            Ok(v) => return v,
            Err(state) => assert!(
                start.elapsed() < WAIT_LIMIT,
                "timed out waiting for {what}; last state:\n{state}"
            ),
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}
