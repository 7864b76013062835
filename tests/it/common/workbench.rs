//! A user of the tests: a home folder of their own (config, cache and state
//! under a temporary folder, no API key or base URL from the test's
//! environment) with a config file, and the real workbench in tmux.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use super::server::LocalServer;
use super::tmux::Tmux;

/// The tmux session the workbench runs in.
pub const SESSION: &str = "workbench";

/// The model the config file names for the local server.
pub const LOCAL_MODEL: &str = "local-test-model";

/// The provider variables a test's own environment might hold; the user's
/// programs never see them.
const PROVIDER_VARIABLES: [&str; 4] = [
    "OPENAI_API_KEY",
    "OPENAI_BASE_URL",
    "ANTHROPIC_API_KEY",
    "ANTHROPIC_BASE_URL",
];

/// A home folder with `XDG_CONFIG_HOME`, `XDG_CACHE_HOME` and
/// `XDG_STATE_HOME` inside it; removed when dropped.
pub struct UserHome {
    dir: tempfile::TempDir,
}

impl Default for UserHome {
    fn default() -> Self {
        Self::new()
    }
}

impl UserHome {
    /// An empty home: no config file, empty caches.
    pub fn new() -> UserHome {
        UserHome {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    /// The home folder.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// `$XDG_CONFIG_HOME`.
    pub fn config_home(&self) -> PathBuf {
        self.path().join("config")
    }

    /// The config file mapvlm reads by default.
    pub fn config_file(&self) -> PathBuf {
        self.config_home().join("mapvlm").join("config.toml")
    }

    /// The session file the workbench is started with.
    pub fn session_file(&self) -> PathBuf {
        self.path().join("session.json")
    }

    /// Writes `toml` as the config file and returns its path.
    pub fn write_config(&self, toml: &str) -> PathBuf {
        let file = self.config_file();
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(&file, toml).unwrap();
        file
    }

    /// Writes a config file whose defaults send every agent to `server`
    /// (OpenAI protocol, [`LOCAL_MODEL`], no key) and returns its path.
    pub fn point_at(&self, server: &LocalServer) -> PathBuf {
        self.write_config(&format!(
            "[defaults]\nprovider = \"openai\"\nbase_url = \"{}\"\nmodel = \"{LOCAL_MODEL}\"\n",
            server.base_url()
        ))
    }

    /// The environment of the user's programs.
    pub fn env(&self) -> Vec<(&'static str, PathBuf)> {
        vec![
            ("HOME", self.path().to_path_buf()),
            ("XDG_CONFIG_HOME", self.config_home()),
            ("XDG_CACHE_HOME", self.path().join("cache")),
            ("XDG_STATE_HOME", self.path().join("state")),
            ("MAPVLM_MODELS", super::pack_dir()),
        ]
    }

    /// The real `mapvlm` binary in this home.
    pub fn command(&self) -> Command {
        self.command_program(env!("CARGO_BIN_EXE_mapvlm"))
    }

    /// `program` (a wrapper that runs the real binary, such as `setsid`)
    /// with the environment of [`UserHome::command`].
    pub fn command_program(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        command.envs(self.env());
        for name in PROVIDER_VARIABLES {
            command.env_remove(name);
        }
        command
    }

    /// The shell line that runs `mapvlm ARGS` in this home as a user would
    /// in a terminal, writing its exit status to `status` in the home.
    pub fn shell_line(&self, args: &[&str]) -> String {
        let quote = |s: &str| format!("'{}'", s.replace('\'', r"'\''"));
        let unset: String = PROVIDER_VARIABLES
            .iter()
            .map(|v| format!("-u {v} "))
            .collect();
        let env: String = self
            .env()
            .iter()
            .map(|(k, v)| format!("{k}={} ", quote(&v.display().to_string())))
            .collect();
        let args: Vec<String> = args.iter().map(|a| quote(a)).collect();
        format!(
            "env -u NO_COLOR {unset}TERM=xterm-256color {env}{} {}; echo $? > {}",
            quote(env!("CARGO_BIN_EXE_mapvlm")),
            args.join(" "),
            quote(&self.path().join("status").display().to_string()),
        )
    }
}

/// The workbench running in tmux for a [`UserHome`].
pub struct Workbench {
    tmux: Tmux,
    status: PathBuf,
}

impl Workbench {
    /// Starts `mapvlm ARGS` (a workbench: no subcommand) in a fresh tmux
    /// server of its own, `width`×`height`, in `home`, with the session
    /// file [`UserHome::session_file`] and half-block images.
    pub fn start(label: &str, home: &UserHome, size: (u16, u16), args: &[&str]) -> Workbench {
        let session = home.session_file().display().to_string();
        let mut all = vec!["--halfblocks", "--session", &session];
        all.extend_from_slice(args);
        let tmux = Tmux::new(label);
        tmux.open(SESSION, size.0, size.1, &home.shell_line(&all));
        Workbench {
            tmux,
            status: home.path().join("status"),
        }
    }

    /// Starts the workbench on alfred30 at 200×60 in `home` and waits
    /// until its first task shows with every agent on the configured local
    /// provider ([`LOCAL_MODEL`]).
    pub fn start_on_alfred30(label: &str, home: &UserHome) -> Workbench {
        let dataset = super::shared().join("data/alfred30").display().to_string();
        let workbench = Workbench::start(label, home, (200, 60), &["--dataset", &dataset]);
        let configured = format!("SKM·GKM·Planner openai/{LOCAL_MODEL}");
        workbench.wait_for("the dataset task on the configured provider", |s| {
            s.contains("Place a wet sponge inside the bathtub") && s.contains(&configured)
        });
        workbench
    }

    /// The text on the screen.
    pub fn screen(&self) -> String {
        self.tmux.screen(SESSION)
    }

    /// Sends `keys` (tmux `send-keys` arguments).
    pub fn keys(&self, keys: &[&str]) {
        self.tmux.keys(SESSION, keys);
    }

    /// Waits until the screen satisfies `ok` and returns it; fails after
    /// 30 s with the last screen.
    pub fn wait_for(&self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        self.tmux.wait_for(SESSION, what, ok)
    }

    /// Presses `q` and returns the exit status; fails when mapvlm has not
    /// quit within 10 s.
    pub fn quit(&self) -> String {
        self.keys(&["q"]);
        let start = Instant::now();
        loop {
            if let Ok(text) = std::fs::read_to_string(&self.status) {
                if text.ends_with('\n') {
                    return text.trim().to_string();
                }
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "mapvlm did not quit; screen:\n{}",
                self.screen()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// The value of score `name` on `screen` (e.g. `KAS 0.512` gives
/// `0.512`), as the Scores pane shows it.
pub fn score_on(screen: &str, name: &str) -> Option<String> {
    let (zero, one) = (format!("{name} 0."), format!("{name} 1."));
    screen.lines().find_map(|line| {
        let at = line.find(&zero).or_else(|| line.find(&one))? + name.len() + 1;
        let value = line.get(at..at + 5)?;
        value[2..]
            .chars()
            .all(|c| c.is_ascii_digit())
            .then(|| value.to_string())
    })
}
