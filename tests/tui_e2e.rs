//! End to end: the real binary in tmux, driven with keys and read from the
//! screen, as a person would use it.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

struct Tmux {
    socket: String,
}

impl Tmux {
    fn cmd(&self, args: &[&str]) -> String {
        let out = Command::new("tmux")
            .arg("-L")
            .arg(&self.socket)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("tmux {args:?}: {e}"));
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn screen(&self) -> String {
        self.cmd(&["capture-pane", "-p", "-t", "e2e"])
    }

    fn keys(&self, keys: &[&str]) {
        let mut args = vec!["send-keys", "-t", "e2e"];
        args.extend(keys);
        self.cmd(&args);
    }

    fn wait_for(&self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let screen = self.screen();
            if ok(&screen) {
                return screen;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "timed out waiting for {what}; screen:\n{screen}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        self.cmd(&["kill-server"]);
    }
}

/// The KAS shown in the Scores pane (three decimals).
fn kas_on(screen: &str) -> Option<String> {
    score_on(screen, "KAS")
}

/// The value of score `name` shown in the Scores pane (three decimals).
fn score_on(screen: &str, name: &str) -> Option<String> {
    let (zero, one) = (format!("{name} 0."), format!("{name} 1."));
    screen.lines().find_map(|line| {
        let at = line.find(&zero).or_else(|| line.find(&one))?;
        let at = at + name.len() + 1;
        let value = line.get(at..at + 5)?;
        (value.len() == 5 && value.chars().nth(4).is_some_and(|c| c.is_ascii_digit()))
            .then(|| value.to_string())
    })
}

/// Starts mapvlm on the demo in a fresh tmux server, or `None` without tmux.
fn start(name: &str, dir: &Path, session: &Path) -> Option<Tmux> {
    if Command::new("tmux").arg("-V").output().is_err() {
        eprintln!("SKIPPED: tmux is not installed; install it to run this test");
        return None;
    }
    let tmux = Tmux {
        socket: format!("mapvlm-{name}-{}", std::process::id()),
    };
    let command = format!(
        "env -u NO_COLOR HOME={} MAPVLM_MODELS={} {} --halfblocks --replay-delay 1 --session {}",
        dir.display(),
        mapvlm::models::models_dir(None).display(),
        env!("CARGO_BIN_EXE_mapvlm"),
        session.display()
    );
    tmux.cmd(&[
        "new-session",
        "-d",
        "-s",
        "e2e",
        "-x",
        "200",
        "-y",
        "60",
        &command,
    ]);
    Some(tmux)
}

#[test]
fn demo_ground_truth_switch_step_edit_and_quit_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let Some(tmux) = start("e2e", dir.path(), &session) else {
        return;
    };
    let screen = tmux.wait_for("the demo's plan and scores", |s| {
        s.contains("run 1 finished") && kas_on(s).is_some() && score_on(s, "PG2S").is_some()
    });
    assert!(screen.contains("Grounded Description (GKM)"));
    assert!(screen.contains("7. Place the mug on the drip tray under the spout."));
    let first = kas_on(&screen).unwrap();

    tmux.keys(&["g"]);
    tmux.wait_for("the ground-truth picker", |s| {
        s.contains("annotator B's ground truth")
    });
    tmux.keys(&["Down", "Enter"]);
    let screen = tmux.wait_for("annotator B's scores", |s| {
        s.contains("demo annotator B") && kas_on(s).is_some_and(|k| k != first)
    });
    let second = kas_on(&screen).unwrap();

    tmux.keys(&["Enter"]);
    tmux.wait_for("the step editor", |s| s.contains("EDIT step"));
    tmux.keys(&["End"]);
    tmux.keys(&["-l", " Then wave."]);
    tmux.keys(&["Enter"]);
    tmux.wait_for("the edited step and a new score", |s| {
        s.contains("under the window. Then wave.")
            && !s.contains("EDIT step")
            && kas_on(s).is_some_and(|k| k != second)
    });

    tmux.keys(&["q"]);
    let start = Instant::now();
    while tmux.cmd(&["list-sessions"]).contains("e2e") {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "mapvlm did not quit"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_session_holds_the_edit(&session);
}

fn assert_session_holds_the_edit(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let first_step = json["plan"][0].as_str().unwrap_or_default();
    assert!(first_step.ends_with("Then wave."), "{first_step}");
    assert_eq!(json["ground_truth_source"]["index"], 1, "{text}");
    assert_eq!(json["runs"].as_array().map(Vec::len), Some(1));
}

#[test]
fn a_kill_while_typing_loses_at_most_the_last_second() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let Some(tmux) = start("kill", dir.path(), &session) else {
        return;
    };
    tmux.wait_for("the demo's plan", |s| s.contains("run 1 finished"));
    tmux.keys(&["Enter"]);
    tmux.wait_for("the step editor", |s| s.contains("EDIT step"));
    tmux.keys(&["End"]);
    tmux.keys(&["-l", " typed before the kill"]);
    tmux.wait_for("the typed text", |s| s.contains("typed before the kill"));
    std::thread::sleep(Duration::from_millis(1000));
    let pid = tmux.cmd(&["display-message", "-p", "-t", "e2e", "#{pane_pid}"]);
    let status = Command::new("kill")
        .args(["-KILL", pid.trim()])
        .status()
        .unwrap();
    assert!(status.success());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&session).unwrap()).unwrap();
    let draft = json["draft"]["text"].as_str().unwrap_or_default();
    assert!(draft.ends_with("typed before the kill"), "{json}");
}
