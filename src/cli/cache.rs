//! `mapvlm cache stats|prune|clear`: the on-disk caches under
//! `$XDG_CACHE_HOME/mapvlm` (sentence embeddings and agents' responses).

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

use crate::store::{DiskStore, StoreStats};

/// Options of `mapvlm cache`.
#[derive(Debug, Args)]
pub struct CacheArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: CacheAction,
}

/// The actions on the caches.
#[derive(Debug, Subcommand)]
pub enum CacheAction {
    /// Show each cache's folder, entries and size.
    Stats {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Evict the least recently used embeddings until the cache fits in MB.
    Prune {
        /// The size to keep, in MB.
        #[arg(long, env = "MAPVLM_CACHE_MAX_MB", value_name = "MB", default_value_t = crate::store::DEFAULT_MAX_BYTES >> 20,
              value_parser = clap::value_parser!(u64).range(0..=crate::store::MAX_CACHE_MB))]
        max_mb: u64,
    },
    /// Remove every entry of a cache.
    Clear {
        /// Which cache (responses cost provider money to remake).
        #[arg(value_enum, default_value_t = Which::Embeddings)]
        which: Which,
    },
}

/// A cache `mapvlm cache clear` can empty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Which {
    /// Sentence embeddings.
    Embeddings,
    /// Agents' answers.
    Responses,
    /// Both.
    All,
}

impl Which {
    /// Whether the cache called `name` is among these.
    fn includes(self, name: &str) -> bool {
        match self {
            Self::Embeddings => name == "embeddings",
            Self::Responses => name == "responses",
            Self::All => true,
        }
    }
}

/// The caches by name, with their stores.
fn caches() -> [(&'static str, DiskStore); 2] {
    let root = crate::store::user_cache_root();
    [
        ("embeddings", super::embedding_store(u64::MAX)),
        (
            "responses",
            DiskStore::new(root.join("responses"), u64::MAX),
        ),
    ]
}

/// Runs `mapvlm cache ...`.
pub fn run(args: &CacheArgs) -> anyhow::Result<ExitCode> {
    let caches = caches();
    match &args.action {
        CacheAction::Stats { json } => {
            let mut report = serde_json::Map::new();
            for (name, store) in &caches {
                let stats = store.stats().with_context(|| in_cache(name, store))?;
                if *json {
                    report.insert(
                        (*name).into(),
                        json!({ "dir": store.dir(), "entries": stats.entries, "bytes": stats.bytes }),
                    );
                } else {
                    writeln!(
                        std::io::stdout(),
                        "{name:<11} {}  {}",
                        describe(stats),
                        store.dir().display()
                    )?;
                }
            }
            if *json {
                writeln!(std::io::stdout(), "{}", serde_json::Value::Object(report))?;
            }
        }
        CacheAction::Prune { max_mb } => {
            let (name, store) = &caches[0];
            let removed = store
                .prune(max_mb << 20)
                .with_context(|| in_cache(name, store))?;
            writeln!(std::io::stdout(), "{name}: removed {}", describe(removed))?;
        }
        CacheAction::Clear { which } => {
            for (name, store) in &caches {
                if which.includes(name) {
                    let removed = store.clear().with_context(|| in_cache(name, store))?;
                    writeln!(std::io::stdout(), "{name}: removed {}", describe(removed))?;
                }
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// What an error about the cache `name` is about: its folder.
fn in_cache(name: &str, store: &DiskStore) -> String {
    format!(
        "the {name} cache at {}",
        crate::sanitize::for_terminal(&store.dir().display().to_string())
    )
}

/// "N entries, X.Y MB".
fn describe(stats: StoreStats) -> String {
    format!(
        "{} entries, {:.1} MB",
        stats.entries,
        stats.bytes as f64 / 1e6
    )
}
