//! `mapvlm plan`: one plan from a task and an image or a table, with the
//! agents of the chosen approach; `--json` prints every agent's raw output,
//! the triples, the steps, usage and timings.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use anyhow::Context;
use clap::Args;
use tokio::sync::mpsc::unbounded_channel;
use tokio_util::sync::CancellationToken;

use crate::agents::cache::ResponseCache;
use crate::agents::config::{ConfigFile, FlagLayers, Settings};
use crate::agents::cost::{check_max_cost, estimate_plans, Billing, Estimate, Ledger, PriceTable};
use crate::agents::pipeline::{AgentEvent, PlanInput, PlanRecord, Runner, Source, MAX_SAMPLES};
use crate::agents::prompts::PromptSet;
use crate::agents::provider::Notifier;
use crate::agents::replay::{Pace, Recording};
use crate::agents::sink::OutputSink;
use crate::agents::{AgentRole, Approach, ProviderKind};
use crate::fsutil::check_writable;
use crate::sanitize;

/// Provider, prompt, cache and recording options shared by `plan` and `eval`.
#[derive(Debug, Args)]
pub struct AgentArgs {
    /// The config file (default: $XDG_CONFIG_HOME/mapvlm/config.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The provider of every agent: openai (any Chat Completions server) or anthropic.
    #[arg(long, value_name = "NAME")]
    pub provider: Option<ProviderKind>,
    /// The base URL of every agent (e.g. http://localhost:8000/v1).
    #[arg(long, value_name = "URL")]
    pub base_url: Option<String>,
    /// The model of every agent.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// The temperature of every agent (default 0, as in the paper).
    #[arg(long, allow_negative_numbers = true, value_name = "T")]
    pub temperature: Option<f64>,
    /// The token limit of every agent.
    #[arg(long, allow_negative_numbers = true, value_name = "N")]
    pub max_tokens: Option<u32>,
    /// One agent's setting, ROLE.FIELD=VALUE (roles: skm, gkm, planner, single;
    /// fields: provider, base_url, model, temperature, max_tokens, stream, json_output).
    #[arg(long = "agent", value_name = "ROLE.FIELD=VALUE")]
    pub agent: Vec<String>,
    /// Ask for whole answers instead of streams.
    #[arg(long)]
    pub no_stream: bool,
    /// Longest image edge sent, in pixels (default 1024).
    #[arg(long, allow_negative_numbers = true, value_name = "PIXELS")]
    pub max_image_edge: Option<u32>,
    /// Longest wait for one answer, in seconds (default 180).
    #[arg(long, allow_negative_numbers = true, value_name = "SECS")]
    pub timeout: Option<f64>,
    /// A folder of prompt templates overriding the shipped ones
    /// (default: $XDG_CONFIG_HOME/mapvlm/prompts).
    #[arg(long, value_name = "DIR")]
    pub prompts: Option<PathBuf>,
    /// The response cache folder (default: $XDG_CACHE_HOME/mapvlm/responses).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// Neither read nor write any cache: ask the models again, store no
    /// answer, and (in `eval`) embed every sentence anew.
    #[arg(long)]
    pub no_cache: bool,
    /// Write every answer received to FILE, for --replay.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Answer from a recording made with --record, with no network.
    #[arg(long, value_name = "FILE", conflicts_with = "record")]
    pub replay: Option<PathBuf>,
    /// With --replay, send everything at once instead of at the recorded pace.
    #[arg(long, requires = "replay")]
    pub instant: bool,
    /// Refuse to send anything when the estimated cost exceeds USD dollars
    /// (prices from [prices] in the config file).
    #[arg(long, allow_negative_numbers = true, value_name = "USD")]
    pub max_cost: Option<f64>,
    /// How many times each agent is asked (1 to 100): sample k is cached and
    /// recorded on its own, so a re-run asks only for samples not yet made.
    #[arg(long, default_value_t = 1, value_name = "N", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SAMPLES)))]
    pub samples: u32,
    /// How many plans (in `eval`) or samples are made at once.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 4,
        value_name = "N"
    )]
    pub concurrency: usize,
}

impl AgentArgs {
    /// The prompt templates these options name: `--prompts DIR`, else the
    /// user folder, over the shipped ones.
    pub fn prompt_set(&self) -> anyhow::Result<PromptSet> {
        let prompt_dir = self.prompts.clone().or_else(PromptSet::default_dir);
        Ok(PromptSet::load(prompt_dir.as_deref())?)
    }

    /// The runner these options describe, and the recording being made.
    /// A `--agent ROLE.…` for a role none of `approaches` runs is named
    /// once on stderr, as not used.
    pub fn runner(
        &self,
        approaches: &[Approach],
    ) -> anyhow::Result<(Runner, Option<Arc<Mutex<Recording>>>)> {
        if let Some(path) = &self.record {
            check_writable(path).with_context(|| {
                format!(
                    "--record {}: the recording could not be written, so nothing was asked of any model",
                    crate::sanitize::for_terminal(&path.display().to_string())
                )
            })?;
        }
        let env = |name: &str| std::env::var(name).ok();
        let file = self.config_file()?;
        let mut flags = FlagLayers {
            max_image_edge: self.max_image_edge,
            timeout_secs: self.timeout,
            ..FlagLayers::default()
        };
        flags.all.provider = self.provider;
        flags.all.base_url = self.base_url.clone();
        flags.all.model = self.model.clone();
        flags.all.temperature = self.temperature;
        flags.all.max_tokens = self.max_tokens;
        flags.all.stream = self.no_stream.then_some(false);
        for spec in &self.agent {
            flags.set_agent(spec)?;
        }
        let mut settings = Settings::resolve(&file, &env, &flags)?;
        // Said once the settings are known to be valid.
        for spec in &self.agent {
            let role = spec
                .split('.')
                .next()
                .and_then(|r| r.parse::<AgentRole>().ok());
            if let Some(role) = role.filter(|r| !approaches.iter().any(|a| a.roles().contains(r))) {
                let run: Vec<String> = approaches.iter().map(Approach::to_string).collect();
                eprintln!(
                    "mapvlm: --agent {}: {} runs no {role} agent, so this setting is not used",
                    sanitize::one_line(spec),
                    run.join(", ")
                );
            }
        }
        settings.http.notify = Some(Notifier(Arc::new(|notice| {
            eprintln!("mapvlm: {}", sanitize::for_terminal(&notice.to_string()))
        })));
        let prompts = self.prompt_set()?;
        let source = match &self.replay {
            Some(path) => {
                let pace = if self.instant {
                    Pace::Instant
                } else {
                    Pace::AsRecorded
                };
                Source::Replay(Arc::new(Recording::load(path)?), pace)
            }
            None => Source::Live,
        };
        // The command line shows no text as it streams.
        let mut runner = Runner::new(settings, prompts, source).without_token_events();
        if !self.no_cache {
            if let Some(dir) = self.cache_dir.clone().or_else(ResponseCache::default_dir) {
                runner = runner.with_cache(ResponseCache::new(dir));
            }
        }
        let recording = self
            .record
            .as_ref()
            .map(|_| Arc::new(Mutex::new(Recording::new("recorded by mapvlm"))));
        if let Some(recording) = &recording {
            runner = runner.with_recorder(recording.clone());
        }
        Ok((runner, recording))
    }

    /// The config file these options name, or the default one (a missing
    /// default file is an empty config).
    pub fn config_file(&self) -> anyhow::Result<ConfigFile> {
        let env = |name: &str| std::env::var(name).ok();
        Ok(match &self.config {
            Some(path) => ConfigFile::load(path, true)?,
            None => match ConfigFile::default_path(&env) {
                Some(path) => ConfigFile::load(&path, false)?,
                None => ConfigFile::default(),
            },
        })
    }

    /// An empty cost ledger with the config file's prices; `--max-cost`
    /// checked.
    pub fn ledger(&self) -> anyhow::Result<Ledger> {
        check_max_cost(self.max_cost)?;
        let prices = PriceTable::from_config(&self.config_file()?.prices)?;
        Ok(Ledger::new(prices))
    }

    /// Prints `estimate` on stderr (unless it counts no request: the input
    /// is unusable, and says so itself) and refuses the run, before any
    /// request, when it exceeds `--max-cost`.
    pub fn check_estimate(&self, estimate: &Estimate) -> anyhow::Result<()> {
        if estimate.requests + estimate.cached > 0 {
            eprintln!("mapvlm: {}", sanitize::for_terminal(&estimate.line()));
        }
        Ok(estimate.check(self.max_cost)?)
    }

    /// Writes the recording, if one was asked for, through the run's
    /// output sink.
    pub fn save_recording(
        &self,
        recording: Option<Arc<Mutex<Recording>>>,
        sink: &OutputSink,
    ) -> anyhow::Result<()> {
        if let (Some(path), Some(recording)) = (&self.record, recording) {
            let recording = recording
                .lock()
                .map_err(|_| anyhow::anyhow!("the recording was lost"))?
                .clone();
            recording.save_through(path, sink)?;
        }
        Ok(())
    }
}

/// Options of `mapvlm plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The task, in natural language.
    #[arg(long)]
    pub task: String,
    /// The scene image (image approaches).
    #[arg(long, value_name = "FILE")]
    pub image: Option<PathBuf>,
    /// The G-PlanET table of the scene (table approaches).
    #[arg(long, value_name = "FILE")]
    pub table: Option<PathBuf>,
    /// multi-image, single-image, multi-table or single-table.
    #[arg(long, default_value = "multi-image")]
    pub approach: Approach,
    /// Print the whole run as JSON.
    #[arg(long)]
    pub json: bool,
    /// Provider, prompt and cache options.
    #[command(flatten)]
    pub agents: AgentArgs,
}

/// Builds the async runtime the commands run on, with Ctrl-C, SIGTERM (a
/// scheduler's time limit, `scancel`, an eviction) and SIGHUP (a lost SSH
/// session) cancelling `cancel`: the run stops asking, and what was made is
/// written as after Ctrl-C. The handlers are in place when this returns.
pub fn runtime(cancel: &CancellationToken) -> anyhow::Result<tokio::runtime::Runtime> {
    use tokio::signal::unix::{signal, SignalKind};
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let (mut terminate, mut hangup) = {
        let _inside = runtime.enter();
        let listen = |kind| signal(kind).context("cannot listen for signals");
        (
            listen(SignalKind::terminate())?,
            listen(SignalKind::hangup())?,
        )
    };
    let on_signal = cancel.clone();
    runtime.spawn(async move {
        let interrupt = async {
            if tokio::signal::ctrl_c().await.is_err() {
                std::future::pending::<()>().await;
            }
        };
        tokio::select! {
            () = interrupt => {}
            _ = terminate.recv() => {}
            _ = hangup.recv() => {}
        }
        on_signal.cancel();
    });
    Ok(runtime)
}

/// The most plans or samples made at once: more only draws 429s from any
/// provider.
const MAX_CONCURRENCY: usize = 64;

/// Checks a `--concurrency` value.
pub(super) fn check_concurrency(concurrency: usize) -> anyhow::Result<()> {
    if !(1..=MAX_CONCURRENCY).contains(&concurrency) {
        anyhow::bail!("--concurrency {concurrency} is outside 1..={MAX_CONCURRENCY}");
    }
    Ok(())
}

/// What `plan --json` prints: the first sample's record at the top level,
/// as before samples existed, and every sample's record in `samples`.
#[derive(serde::Serialize)]
struct PlanOutput<'a> {
    #[serde(flatten)]
    first: &'a PlanRecord,
    samples: &'a [PlanRecord],
}

/// Runs `mapvlm plan`.
pub fn run(args: &PlanArgs) -> anyhow::Result<ExitCode> {
    check_concurrency(args.agents.concurrency)?;
    if args.task.trim().is_empty() {
        anyhow::bail!("--task is empty: give the task in words, e.g. --task \"Put a washed mug in the coffee machine\"");
    }
    for (flag, path) in [("--image", &args.image), ("--table", &args.table)] {
        if let Some(path) = path {
            crate::fsutil::utf8_path(flag, path)?;
        }
    }
    let samples = args.agents.samples;
    let mut ledger = args.agents.ledger()?;
    let (runner, recording) = args.agents.runner(&[args.approach])?;
    let input = PlanInput {
        task: args.task.clone(),
        image: args.image.clone(),
        table: args.table.clone(),
    };
    let estimate = estimate_plans(
        &runner,
        (0..samples).map(|sample| (args.approach, &input, sample)),
        Billing::Interactive,
        ledger.prices(),
    );
    args.agents.check_estimate(&estimate)?;
    let cancel = CancellationToken::new();
    let sink = OutputSink::new(cancel.clone());
    let runtime = runtime(&cancel)?;
    let (events, mut received) = unbounded_channel();
    let quiet = args.json;
    let printer = runtime.spawn(async move {
        while let Some((sample, event)) = received.recv().await {
            if !quiet {
                print_event(sample_label(sample, samples), &event);
            }
        }
    });
    let records = runtime.block_on(runner.plan_samples(
        args.approach,
        &input,
        0..samples,
        args.agents.concurrency,
        &events,
        &cancel,
    ));
    drop(events);
    let _ = runtime.block_on(printer);
    // A recording that cannot be written (a full disk) must not lose the
    // plans already paid for: they are printed first, then it is said.
    let saved = args.agents.save_recording(recording, &sink).map_err(|err| {
        let path = args.agents.record.clone().unwrap_or_default();
        err.context(format!(
            "--record {}: the recording could not be written (the plans made are printed all the same)",
            path.display()
        ))
    });
    let records = match records {
        Ok(records) => records,
        Err(err) => {
            if let Err(unsaved) = &saved {
                eprintln!("mapvlm: {}", sanitize::one_line(&format!("{unsaved:#}")));
            }
            return Err(err.into());
        }
    };
    for record in &records {
        ledger.add_plan(record, Billing::Interactive);
    }
    eprint!("{}", sanitize::for_terminal(&ledger.table()));
    let mut out = std::io::stdout().lock();
    let Some(first) = records.first() else {
        anyhow::bail!("no sample was made");
    };
    if args.json {
        let output = PlanOutput {
            first,
            samples: &records,
        };
        sanitize::write_json_pretty(&mut out, &output)?;
        writeln!(out)?;
    } else {
        for record in &records {
            if samples > 1 {
                writeln!(out, "Sample {} of {samples}:", record.sample + 1)?;
            }
            for (number, step) in record.steps.iter().enumerate() {
                writeln!(out, "{}. {}", number + 1, sanitize::for_terminal(step))?;
            }
        }
    }
    let mut failed = false;
    for record in &records {
        if let Some((role, error)) = record.first_error() {
            let label = sample_label(record.sample, samples);
            eprintln!(
                "mapvlm: {role}{label} failed: {}",
                sanitize::for_terminal(error)
            );
            failed = true;
        }
    }
    saved?;
    Ok(if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// What follows an agent's name in a line about sample `sample` of
/// `samples`: nothing for a run of one sample (its lines read as before).
fn sample_label(sample: u32, samples: u32) -> String {
    if samples > 1 {
        format!(" (sample {} of {samples})", sample + 1)
    } else {
        String::new()
    }
}

fn print_event(label: String, event: &AgentEvent) {
    match event {
        AgentEvent::Started { role } => eprintln!("{role}{label}: started"),
        // A retry's wait is printed by the notifier of the settings.
        AgentEvent::Token { .. } | AgentEvent::Sampled { .. } | AgentEvent::Retrying { .. } => {}
        AgentEvent::Finished {
            role,
            usage,
            elapsed_ms,
            cached,
        } => eprintln!(
            "{role}{label}: finished in {:.1} s, {} tokens in, {} out{}",
            *elapsed_ms as f64 / 1000.0,
            usage.input_tokens,
            usage.output_tokens,
            if *cached { " (cached)" } else { "" }
        ),
        AgentEvent::Failed { role, error, .. } => {
            eprintln!("{role}{label}: failed: {}", sanitize::for_terminal(error))
        }
    }
}
