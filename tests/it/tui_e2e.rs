//! End to end: the real binary in tmux, driven with keys and read from the
//! screen, as a person would use it.

use crate::common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::pty::Pty;
use common::tmux::Tmux;
use mapvlm::workbench::keymap::{self, Context};

/// The tmux session each test runs mapvlm in.
const E2E: &str = "e2e";

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

/// Starts mapvlm on the demo in a fresh tmux server (200×60) with the
/// half-block picker. Fails when tmux is missing: `.ci/run` installs it.
fn start(name: &str, dir: &Path, session: &Path) -> Tmux {
    start_with(name, dir, session, "--halfblocks")
}

/// Starts mapvlm with `flags` as a user would in tmux: TERM=xterm-256color,
/// and its exit status written to `dir/status` when it ends.
fn start_with(name: &str, dir: &Path, session: &Path, flags: &str) -> Tmux {
    let tmux = Tmux::new(name);
    tmux.open(E2E, 200, 60, &workbench_command(dir, session, flags));
    tmux
}

/// The shell command that runs mapvlm with `flags` as a user would
/// (TERM=xterm-256color, its home and caches in `dir`) and writes its exit
/// status to `dir/status` when it ends.
fn workbench_command(dir: &Path, session: &Path, flags: &str) -> String {
    format!(
        "env -u NO_COLOR TERM=xterm-256color HOME={home} XDG_CACHE_HOME={home}/.cache MAPVLM_MODELS={} {} {flags} --replay-delay 1 --session {}; echo $? > {home}/status",
        common::pack_dir().display(),
        env!("CARGO_BIN_EXE_mapvlm"),
        session.display(),
        home = dir.display(),
    )
}

/// Waits for the exit status `start_with` writes, and returns it.
fn exit_status(dir: &Path) -> String {
    let path = dir.join("status");
    let start = Instant::now();
    loop {
        if let Ok(text) = std::fs::read_to_string(&path) {
            if text.ends_with('\n') {
                return text.trim().to_string();
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "mapvlm did not quit within 30 s"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The first frame is on screen: the title bar and the panes.
fn first_frame(screen: &str) -> bool {
    screen.contains(" mapvlm │ demo │") && screen.contains("Plan")
}

#[test]
fn q_as_the_first_key_quits_without_halfblocks() {
    let dir = tempfile::tempdir().unwrap();
    let tmux = start_with("first-q", dir.path(), &dir.path().join("s.json"), "");
    tmux.wait_for(E2E, "the first frame", first_frame);
    tmux.keys(E2E, &["q"]);
    assert_eq!(exit_status(dir.path()), "0");
}

#[test]
fn help_as_the_first_key_and_a_resize_drawn_at_once_without_halfblocks() {
    let dir = tempfile::tempdir().unwrap();
    let tmux = start_with("first-help", dir.path(), &dir.path().join("s.json"), "");
    tmux.wait_for(E2E, "the first frame", first_frame);
    tmux.keys(E2E, &["?"]);
    // The help's keys, as its title and the status bar show them.
    let help_keys = keymap::hints(Context::Help);
    tmux.wait_for(E2E, "the help", |s| s.contains(&help_keys));
    tmux.cmd(&["resize-window", "-t", E2E, "-x", "120", "-y", "40"]);
    // Redrawn for 120 columns: the rightmost pane closes in the last column.
    let start = Instant::now();
    loop {
        let screen = tmux.screen(E2E);
        let redrawn = screen
            .lines()
            .nth(1)
            .is_some_and(|l| l.chars().count() == 120 && l.ends_with('┐'));
        if redrawn {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(3),
            "the resize was not drawn; screen:\n{screen}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Esc and q sent together would read as Alt-q: wait for the help to close.
    tmux.keys(E2E, &["Escape"]);
    tmux.wait_for(E2E, "the help to close", |s| !s.contains(&help_keys));
    tmux.keys(E2E, &["q"]);
    assert_eq!(exit_status(dir.path()), "0");
}

#[test]
fn demo_ground_truth_switch_step_edit_and_quit_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let tmux = start("e2e", dir.path(), &session);
    let screen = tmux.wait_for(E2E, "the demo's plan and scores", |s| {
        s.contains("run 1 finished") && kas_on(s).is_some() && score_on(s, "PG2S").is_some()
    });
    assert!(screen.contains("Grounded Description (GKM)"));
    assert!(screen.contains("7. Place the mug on the drip tray under the spout."));
    let first = kas_on(&screen).unwrap();

    tmux.keys(E2E, &["g"]);
    tmux.wait_for(E2E, "the ground-truth picker", |s| {
        s.contains("annotator B's ground truth")
    });
    tmux.keys(E2E, &["Down", "Enter"]);
    let screen = tmux.wait_for(E2E, "annotator B's scores", |s| {
        s.contains("demo annotator B") && kas_on(s).is_some_and(|k| k != first)
    });
    let second = kas_on(&screen).unwrap();

    tmux.keys(E2E, &["Enter"]);
    tmux.wait_for(E2E, "the step editor", |s| s.contains("EDIT step"));
    tmux.keys(E2E, &["End"]);
    tmux.keys(E2E, &["-l", " Then wave."]);
    tmux.keys(E2E, &["Enter"]);
    tmux.wait_for(E2E, "the edited step and a new score", |s| {
        s.contains("under the window. Then wave.")
            && !s.contains("EDIT step")
            && kas_on(s).is_some_and(|k| k != second)
    });

    tmux.keys(E2E, &["q"]);
    let start = Instant::now();
    while tmux.cmd(&["list-sessions"]).contains(E2E) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "mapvlm did not quit within 30 s"
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
    let tmux = start("kill", dir.path(), &session);
    tmux.wait_for(E2E, "the demo's plan", |s| s.contains("run 1 finished"));
    tmux.keys(E2E, &["Enter"]);
    tmux.wait_for(E2E, "the step editor", |s| s.contains("EDIT step"));
    tmux.keys(E2E, &["End"]);
    tmux.keys(E2E, &["-l", " typed before the kill"]);
    tmux.wait_for(E2E, "the typed text", |s| {
        s.contains("typed before the kill")
    });
    // The draft reaches the file while the editor is still open (the pacing
    // itself, at most a second, is checked by `snapshot`'s unit test): wait
    // for it, bounded, rather than sleep a guess.
    let draft_of = |session: &Path| -> Option<String> {
        let text = std::fs::read_to_string(session).ok()?;
        let json: serde_json::Value = serde_json::from_str(&text).ok()?;
        json["draft"]["text"].as_str().map(str::to_string)
    };
    let typed = |draft: &Option<String>| {
        draft
            .as_deref()
            .is_some_and(|d| d.ends_with("typed before the kill"))
    };
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut draft = draft_of(&session);
    while !typed(&draft) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
        draft = draft_of(&session);
    }
    assert!(
        typed(&draft),
        "the draft was not saved while typing: {draft:?}"
    );
    let pid = tmux.cmd(&["display-message", "-p", "-t", E2E, "#{pane_pid}"]);
    let status = Command::new("kill")
        .args(["-KILL", pid.trim()])
        .status()
        .unwrap();
    assert!(status.success());
    let after = draft_of(&session);
    assert!(typed(&after), "the file after the kill: {after:?}");
}

/// A kitty-like answer to ratatui-image's query: graphics, sixels, a cell
/// size, then the status report that ends it.
const KITTY_ANSWER: &[u8] = b"\x1b_Gi=31;OK\x1b\\\x1b[?62;4c\x1b[6;20;10t\x1b[0n";

#[test]
fn a_terminal_that_answers_the_graphics_query_gets_the_first_key() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start(dir.path());
    pty.wait_for("the graphics query", "\x1b[5n");
    pty.send(KITTY_ANSWER);
    pty.wait_for("the first frame", "mapvlm");
    pty.send(b"?");
    // The raw bytes hold only the cells that changed: the title's start.
    pty.wait_for("the help", "Keys (");
    pty.send(b"q");
    std::thread::sleep(Duration::from_millis(100));
    pty.send(b"q");
    assert_eq!(pty.exit_code(), Some(0));
}

#[test]
fn a_key_typed_before_a_slow_answer_counts() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start(dir.path());
    pty.wait_for("the graphics query", "\x1b[5n");
    pty.send(b"q");
    std::thread::sleep(Duration::from_millis(50));
    pty.send(KITTY_ANSWER);
    assert_eq!(pty.exit_code(), Some(0));
}

#[test]
fn a_terminal_that_never_answers_still_gets_the_first_key() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start(dir.path());
    pty.wait_for("the graphics query", "\x1b[5n");
    std::thread::sleep(Duration::from_millis(800));
    pty.send(b"q");
    assert_eq!(pty.exit_code(), Some(0));
}

/// With `RUST_LOG=trace` and an embedding cache that cannot be written (its
/// folder is a plain file, so scoring the demo warns), the workbench writes
/// nothing to the terminal: neither to stderr nor over the screen. The same
/// warning reaches `--log FILE`, which shows the event was raised.
#[test]
fn rust_log_trace_writes_nothing_over_the_screen_and_events_go_to_the_log_file() {
    let warning = "cannot store embeddings";
    for with_log in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join(".cache/mapvlm")).unwrap();
        std::fs::write(dir.path().join(".cache/mapvlm/embeddings"), b"not a folder").unwrap();
        let log = dir.path().join("events.log");
        let stderr = dir.path().join("stderr");
        let log_flag = if with_log {
            format!("--log {}", log.display())
        } else {
            String::new()
        };
        let tmux = Tmux::new("trace");
        let command = format!(
            "env -u NO_COLOR RUST_LOG=trace TERM=xterm-256color HOME={home} XDG_CACHE_HOME={home}/.cache MAPVLM_MODELS={} {} --halfblocks --replay-delay 1 --session {home}/s.json {log_flag} 2>{}; echo $? > {home}/status",
            common::pack_dir().display(),
            env!("CARGO_BIN_EXE_mapvlm"),
            stderr.display(),
            home = dir.path().display(),
        );
        tmux.open(E2E, 200, 60, &command);
        let screen = tmux.wait_for(E2E, "the demo's scores", |s| {
            s.contains("run 1 finished") && score_on(s, "PG2S").is_some()
        });
        if with_log {
            common::tmux::wait("the warning in the log file", || {
                let text = std::fs::read_to_string(&log).unwrap_or_default();
                if text.contains(warning) {
                    Ok(())
                } else {
                    Err(format!("log file so far:\n{text}"))
                }
            });
        }
        for noise in [warning, "TRACE", "DEBUG", " WARN "] {
            assert!(
                !screen.contains(noise),
                "{noise:?} on the screen (--log {with_log}):\n{screen}"
            );
        }
        tmux.keys(E2E, &["q"]);
        assert_eq!(exit_status(dir.path()), "0");
        let written = std::fs::read_to_string(&stderr).unwrap();
        assert!(
            written.is_empty(),
            "the workbench wrote to stderr (--log {with_log}):\n{written}"
        );
    }
}

#[test]
fn the_workbench_weighs_pg2s_with_the_alpha_flag() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let tmux = start_with("pg2s-flags", dir.path(), &session, "--halfblocks --alpha 1");
    let screen = tmux.wait_for(E2E, "the demo's scores", |s| {
        s.contains("run 1 finished")
            && ["PG2S", "S_plan", "S_goal"]
                .iter()
                .all(|name| score_on(s, name).is_some())
    });
    let (pg2s, s_plan, s_goal) = (
        score_on(&screen, "PG2S"),
        score_on(&screen, "S_plan"),
        score_on(&screen, "S_goal"),
    );
    assert_ne!(s_plan, s_goal, "the weight matters for the demo:\n{screen}");
    assert_eq!(
        pg2s, s_goal,
        "with --alpha 1, PG2S is S_goal alone:\n{screen}"
    );
    tmux.keys(E2E, &["q"]);
    assert_eq!(exit_status(dir.path()), "0");
}

/// The holder line of the session's lock (`PID N on HOST (mapvlm
/// workbench)`) once the workbench has taken it, and the PID in it.
fn session_holder(session: &Path) -> (String, u32) {
    let lock = session.with_file_name("session.json.lock");
    common::tmux::wait("the workbench to take the session's lock", || {
        let line = std::fs::read_to_string(&lock).map_err(|e| e.to_string())?;
        let pid = line
            .strip_prefix("PID ")
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|pid| pid.parse().ok())
            .ok_or(format!("lock file: {line:?}"))?;
        Ok((line.trim().to_string(), pid))
    })
}

#[test]
fn a_second_workbench_on_one_session_is_refused_naming_the_first_until_it_is_killed() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let first = start("lock-first", dir.path(), &session);
    first.wait_for(E2E, "the first frame", first_frame);
    let (holder, pid) = session_holder(&session);
    let comm = std::fs::read_to_string(format!("/proc/{pid}/comm")).unwrap();
    assert_eq!(comm.trim(), "mapvlm", "the lock names the workbench's PID");

    let second = common::mapvlm_command()
        .args(["--session", session.to_str().unwrap()])
        .env("HOME", dir.path())
        .output()
        .unwrap();
    common::assert_one_line_failure(&second, "open in another workbench");
    let said = common::stderr(&second);
    assert!(said.contains(&holder), "names the holder: {said}");
    assert!(
        said.contains("--session"),
        "says how to open a second: {said}"
    );
    assert_eq!(
        session_holder(&session).0,
        holder,
        "the refused one wrote nothing"
    );

    let killed = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(exit_status(dir.path()), "137");
    std::fs::remove_file(dir.path().join("status")).unwrap();
    let again = start("lock-again", dir.path(), &session);
    again.wait_for(E2E, "a new workbench on the same session", first_frame);
    let (_, new_pid) = session_holder(&session);
    assert_ne!(new_pid, pid);
    again.keys(E2E, &["q"]);
    assert_eq!(exit_status(dir.path()), "0");
}

#[test]
fn every_signal_that_stops_the_workbench_restores_the_terminal_and_saves() {
    for signal in ["INT", "QUIT", "TERM", "HUP"] {
        let dir = tempfile::tempdir().unwrap();
        let home = dir.path();
        let session = home.join("session.json");
        let tmux = Tmux::new(&format!("signal-{signal}"));
        let command = Tmux::bracketed(home, &workbench_command(home, &session, "--halfblocks"));
        tmux.open(E2E, 160, 50, &command);
        tmux.wait_for(E2E, "the demo's plan", |s| s.contains("run 1 finished"));
        // S: a change the session must hold after the signal.
        tmux.keys(E2E, &["S"]);
        tmux.wait_for(E2E, "samples set to 3", |s| {
            s.contains("samples per run: 3")
        });
        let (_, pid) = session_holder(&session);
        let sent = Command::new("kill")
            .args([&format!("-{signal}"), &pid.to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        exit_status(home);
        tmux.assert_restored(E2E, home, &format!("SIG{signal}"));
        let saved: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&session).unwrap()).unwrap();
        assert_eq!(saved["samples"], 3, "SIG{signal}: the session was saved");
    }
}

#[test]
fn a_start_that_cannot_work_is_one_line_and_opens_no_screen() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.json");
    let folder = dir.path().to_str().unwrap().to_string();
    let items = dir.path().join("items.jsonl");
    std::fs::write(
        &items,
        "{\"id\": \"a\", \"gt\": [\"A.\"], \"pred\": [\"B.\"]}\n",
    )
    .unwrap();
    let items = items.to_str().unwrap();
    // The arguments, the environment added, and what the one line names.
    type Case<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a str);
    let cases: [Case; 7] = [
        (
            &["--dataset", "/nonexistent/alfred"],
            &[],
            "/nonexistent/alfred",
        ),
        (
            &["--theme", "neon"],
            &[],
            "--theme neon: there is no such theme",
        ),
        (&["--session", &folder], &[], "is a folder"),
        (
            &["annotate", items, "--annotator", "ana", "--theme", "neon"],
            &[],
            "--theme neon",
        ),
        (
            &["annotate", items, "--annotator", "ana"],
            &[],
            "annotate needs a terminal",
        ),
        // No terminal on either side: `mapvlm < /dev/null > out`.
        (&[], &[], "standard input is not a terminal"),
        (&[], &[("TERM", "dumb")], "TERM is dumb"),
    ];
    for (args, env, needle) in cases {
        let mut command = common::mapvlm_command();
        let default_session = ["--session", session.to_str().unwrap()];
        command.args(args).env("HOME", dir.path());
        if !args.contains(&"--session") && !args.contains(&"annotate") {
            command.args(default_session);
        }
        for (name, value) in env {
            command.env(name, value);
        }
        let out = command.output().unwrap();
        common::assert_one_line_failure(&out, needle);
        assert!(out.stdout.is_empty(), "{args:?}: drew nothing");
        assert!(!session.exists(), "{args:?}: wrote no session");
    }
}
