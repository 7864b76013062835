//! Where the binary's `tracing` events go. Headless commands write them to
//! stderr, one line an event, so a warning (a cache that cannot be written,
//! a model that fell back) reaches the user; while a screen is open
//! (workbench, annotate) nothing may be written over it, so events go to
//! `--log FILE` or nowhere. Every line passes through the one terminal
//! sanitiser, since events quote paths, servers and models.

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::Context;
use clap::Args;
use tracing_subscriber::EnvFilter;

use crate::sanitize;

/// The logging flags every command shares.
#[derive(Debug, Args)]
pub struct LogArgs {
    /// Also show notices (`mapvlm=info`); RUST_LOG, when set, decides instead.
    #[arg(long, global = true)]
    pub verbose: bool,
    /// Append the log to FILE (the only place it goes while a screen is open).
    #[arg(long, global = true, value_name = "FILE")]
    pub log: Option<PathBuf>,
}

/// Installs the subscriber: the filter is `RUST_LOG` when set and not empty, else
/// `mapvlm=info` with `--verbose`, else `mapvlm=warn`. `screen` says whether
/// the command draws a screen, in which case nothing goes to stderr.
pub fn install(args: &LogArgs, screen: bool) -> anyhow::Result<()> {
    let fallback = if args.verbose {
        "mapvlm=info"
    } else {
        "mapvlm=warn"
    };
    let filter = match std::env::var("RUST_LOG") {
        Ok(spec) if !spec.trim().is_empty() => EnvFilter::try_new(&spec)
            .with_context(|| format!("RUST_LOG={spec:?} is not a filter: use e.g. mapvlm=debug"))?,
        _ => EnvFilter::new(fallback),
    };
    let sink = match &args.log {
        Some(path) => {
            let file = OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .with_context(|| {
                    format!(
                        "cannot open the log file {}: give a writable path to --log",
                        sanitize::for_terminal(&path.display().to_string())
                    )
                })?;
            Sink::File(Arc::new(Mutex::new(file)))
        }
        None if screen => return Ok(()),
        None => Sink::Stderr,
    };
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(false)
        .with_target(false)
        .log_internal_errors(false)
        .without_time()
        .with_writer(move || SanitizedWriter(sink.clone()))
        .try_init()
        .map_err(|e| anyhow::anyhow!("cannot install the log: {e}"))
}

/// Where the lines go.
#[derive(Clone)]
enum Sink {
    Stderr,
    File(Arc<Mutex<File>>),
}

/// Writes what it is given through the terminal sanitiser, so an event that
/// quotes a model's answer or a path cannot move the cursor or set the title.
struct SanitizedWriter(Sink);

impl SanitizedWriter {
    /// Runs `act` on the sink's writer: stderr, or the log file under its lock.
    fn with_sink(&self, act: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> io::Result<()> {
        match &self.0 {
            Sink::Stderr => act(&mut io::stderr()),
            Sink::File(file) => act(&mut *file
                .lock()
                .map_err(|_| io::Error::other("the log file's lock is poisoned"))?),
        }
    }
}

impl Write for SanitizedWriter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let text = sanitize::for_terminal(&String::from_utf8_lossy(buf));
        self.with_sink(|out| out.write_all(text.as_bytes()))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.with_sink(|out| out.flush())
    }
}
