//! Provider settings per agent, layered: built-in defaults, then the config
//! file (`$XDG_CONFIG_HOME/mapvlm/config.toml`), then the environment
//! (`OPENAI_API_KEY`, `OPENAI_BASE_URL`, `ANTHROPIC_API_KEY`,
//! `ANTHROPIC_BASE_URL`), then flags; later layers override earlier ones.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::images::DEFAULT_MAX_EDGE;
use super::provider::HttpSettings;
use super::{AgentRole, ProviderKind, Secret};

/// What one model costs, in US dollars per million tokens, as written in
/// the config file under `[prices.PROVIDER."MODEL"]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Price {
    /// Dollars per million input tokens.
    pub input_per_million: f64,
    /// Dollars per million output tokens.
    pub output_per_million: f64,
    /// Dollars per million input tokens sent in a provider batch (default:
    /// half of `input_per_million`, as both providers charge).
    pub batch_input_per_million: Option<f64>,
    /// Dollars per million output tokens written in a provider batch
    /// (default: half of `output_per_million`).
    pub batch_output_per_million: Option<f64>,
}

/// A configuration that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The config file could not be read or parsed.
    #[error("config file {path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What was wrong (with the line, for syntax errors).
        message: String,
    },
    /// A flag or value is wrong.
    #[error("{0}")]
    Invalid(String),
}

/// One layer of settings for an agent: whatever it sets overrides the
/// layers before it.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgentLayer {
    /// `openai`, `anthropic` or `replay` (the demo's recording).
    pub provider: Option<ProviderKind>,
    /// The endpoint's base URL.
    pub base_url: Option<String>,
    /// The model name.
    pub model: Option<String>,
    /// The API key (config file or environment only).
    #[serde(default, deserialize_with = "secret_field")]
    pub api_key: Option<Secret>,
    /// Sampling temperature (checked against [`TEMPERATURE_RANGE`] once
    /// the layers are merged; kept wide so a refusal names the value given).
    pub temperature: Option<f64>,
    /// Most tokens to write.
    pub max_tokens: Option<u32>,
    /// Whether to stream the answer.
    pub stream: Option<bool>,
    /// Whether to ask for JSON-schema output where the agent has a schema.
    pub json_output: Option<bool>,
}

fn secret_field<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Secret>, D::Error> {
    Ok(Option::<String>::deserialize(d)?.and_then(Secret::new))
}

impl AgentLayer {
    /// `self` with every field `over` sets replaced.
    pub fn then(mut self, over: &AgentLayer) -> AgentLayer {
        macro_rules! take {
            ($($field:ident),*) => { $( if over.$field.is_some() { self.$field = over.$field.clone(); } )* };
        }
        take!(
            provider,
            base_url,
            model,
            api_key,
            temperature,
            max_tokens,
            stream,
            json_output
        );
        self
    }

    /// Sets one field from a `name=value` flag.
    pub fn set(&mut self, field: &str, value: &str) -> Result<(), ConfigError> {
        let bad = |what: &str| ConfigError::Invalid(format!("`{field}={value}`: {what}"));
        match field.replace('-', "_").as_str() {
            "provider" => self.provider = Some(value.parse().map_err(|e: String| bad(&e))?),
            "base_url" => self.base_url = Some(value.to_string()),
            "model" => self.model = Some(value.to_string()),
            "temperature" => {
                self.temperature = Some(value.parse().map_err(|_| bad("not a number"))?)
            }
            "max_tokens" => {
                self.max_tokens = Some(value.parse().map_err(|_| bad("not a whole number"))?)
            }
            "stream" => self.stream = Some(value.parse().map_err(|_| bad("use true or false"))?),
            "json_output" => {
                self.json_output = Some(value.parse().map_err(|_| bad("use true or false"))?)
            }
            _ => return Err(bad(
                "unknown setting: use provider, base_url, model, temperature, max_tokens, stream or json_output (keys come from the environment or the config file)",
            )),
        }
        Ok(())
    }
}

/// The config file's contents.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    /// Settings for every agent.
    #[serde(default)]
    pub defaults: AgentLayer,
    /// Settings for one agent (`skm`, `gkm`, `planner`, `single`).
    #[serde(default)]
    pub agents: BTreeMap<String, AgentLayer>,
    /// Longest image edge sent, in pixels.
    pub max_image_edge: Option<u32>,
    /// Longest wait for a whole answer, in seconds.
    pub timeout_secs: Option<f64>,
    /// Longest wait for a connection, in seconds.
    pub connect_timeout_secs: Option<f64>,
    /// Retries after 429 or 5xx.
    pub max_retries: Option<u32>,
    /// Prices per provider and model for the cost ledger:
    /// `[prices.openai."gpt-4o"]` with `input_per_million` and
    /// `output_per_million` in US dollars (and, optionally, the batch prices).
    #[serde(default)]
    pub prices: BTreeMap<String, BTreeMap<String, Price>>,
    /// Seconds between two polls of a provider batch (`eval --batch`).
    pub batch_poll_secs: Option<f64>,
    /// How the workbench draws the scene image (`--graphics`'s values:
    /// auto, sixel, kitty, iterm2, halfblocks, none).
    pub graphics: Option<String>,
}

impl ConfigFile {
    /// The default location: `$XDG_CONFIG_HOME/mapvlm/config.toml`, else
    /// `$HOME/.config/mapvlm/config.toml`.
    pub fn default_path(env: &dyn Fn(&str) -> Option<String>) -> Option<PathBuf> {
        env("XDG_CONFIG_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| env("HOME").map(|home| PathBuf::from(home).join(".config")))
            .map(|base| base.join("mapvlm").join("config.toml"))
    }

    /// Reads `path`; a missing file is an empty config unless `required`.
    pub fn load(path: &Path, required: bool) -> Result<Self, ConfigError> {
        let text = match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(err) if err.kind() == std::io::ErrorKind::NotFound && !required => {
                return Ok(Self::default())
            }
            Err(err) => {
                return Err(ConfigError::File {
                    path: path.to_path_buf(),
                    message: err.to_string(),
                })
            }
        };
        let config: Self = toml::from_str(&text).map_err(|err| ConfigError::File {
            path: path.to_path_buf(),
            message: err.to_string().trim().replace('\n', " "),
        })?;
        if let Some(name) = config
            .agents
            .keys()
            .find(|n| n.parse::<AgentRole>().is_err())
        {
            return Err(ConfigError::File {
                path: path.to_path_buf(),
                message: format!("[agents.{name}]: use skm, gkm, planner or single"),
            });
        }
        if config.holds_key() {
            if let Some(warning) = loose_key_file(path) {
                warn_once(warning);
            }
        }
        Ok(config)
    }

    /// Whether any layer of the file sets an API key.
    fn holds_key(&self) -> bool {
        self.defaults.api_key.is_some() || self.agents.values().any(|a| a.api_key.is_some())
    }
}

/// The warning for a file holding an API key that users other than its
/// owner may read or write (as ssh warns of a private key), naming the mode
/// and the fix; `None` when only the owner may.
pub fn loose_key_file(path: &Path) -> Option<String> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).ok()?.permissions().mode() & 0o777;
        if mode & 0o077 == 0 {
            return None;
        }
        let shown = crate::sanitize::for_terminal(&path.display().to_string());
        let who = match (mode & 0o044 != 0, mode & 0o022 != 0) {
            (true, true) => "read and change",
            (false, true) => "change",
            _ => "read",
        };
        Some(format!(
            "permissions {mode:04o} for config file {shown} are too open: it holds an API key that others may {who}; run chmod 600 {shown}"
        ))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// Logs `warning` as a warning once a run, however often the file is read.
fn warn_once(warning: String) {
    static SAID: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    if let Ok(mut said) = SAID.lock() {
        if said.contains(&warning) {
            return;
        }
        said.push(warning.clone());
    }
    tracing::warn!("{warning}");
}

/// The settings from flags: for all agents, and per agent.
#[derive(Debug, Clone, Default)]
pub struct FlagLayers {
    /// `--provider`, `--base-url`, `--model` and the like: every agent.
    pub all: AgentLayer,
    /// `--agent ROLE.FIELD=VALUE`: one agent.
    pub per_agent: BTreeMap<AgentRole, AgentLayer>,
    /// `--max-image-edge`.
    pub max_image_edge: Option<u32>,
    /// `--timeout` in seconds.
    pub timeout_secs: Option<f64>,
}

impl FlagLayers {
    /// Applies one `ROLE.FIELD=VALUE` flag.
    pub fn set_agent(&mut self, spec: &str) -> Result<(), ConfigError> {
        let bad = || {
            ConfigError::Invalid(format!(
                "`--agent {spec}`: write ROLE.FIELD=VALUE, e.g. planner.model=gpt-4"
            ))
        };
        let (target, value) = spec.split_once('=').ok_or_else(bad)?;
        let (role, field) = target.split_once('.').ok_or_else(bad)?;
        let role: AgentRole = role.parse().map_err(ConfigError::Invalid)?;
        self.per_agent.entry(role).or_default().set(field, value)
    }
}

/// The resolved settings of one agent: what a run uses, what the workbench
/// shows and saves in its session, and what every record keeps. The API key
/// is never written: it is skipped when saving and comes back from the
/// config file or the environment when settings are resolved again.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentSettings {
    /// Where the answers come from.
    pub provider: ProviderKind,
    /// The endpoint's base URL.
    pub base_url: String,
    /// The model name.
    pub model: String,
    /// The API key, if any (local servers often need none); never saved.
    #[serde(skip)]
    pub api_key: Option<Secret>,
    /// Sampling temperature (the paper used 0).
    pub temperature: f32,
    /// Most tokens to write.
    pub max_tokens: u32,
    /// Whether to stream the answer.
    pub stream: bool,
    /// Whether to ask for JSON-schema output where the agent has a schema.
    pub json_output: bool,
}

impl AgentSettings {
    /// `provider` with `model`, `temperature` and `max_tokens`, and the
    /// provider's defaults for the rest (no key).
    pub fn new(provider: ProviderKind, model: &str, temperature: f32, max_tokens: u32) -> Self {
        Self {
            provider,
            base_url: provider.default_base_url().to_string(),
            model: model.to_string(),
            api_key: None,
            temperature,
            max_tokens,
            stream: true,
            json_output: true,
        }
    }

    /// The settings the demo's answers were recorded with: the agents of the
    /// demo start with them and replay its recording.
    pub fn demo_recording() -> Self {
        Self::new(
            ProviderKind::Replay,
            super::DEMO_MODEL,
            0.0,
            DEFAULT_MAX_TOKENS,
        )
    }

    /// Whether the demo's recording can answer an agent with these
    /// settings: the recording, at the model, temperature and token limit it
    /// was made with (the parts of a request key settings decide).
    pub fn is_demo_recording(&self) -> bool {
        let demo = Self::demo_recording();
        self.provider == demo.provider
            && self.model == demo.model
            && self.temperature == demo.temperature
            && self.max_tokens == demo.max_tokens
    }

    /// The same settings without the API key, to keep or show.
    pub fn without_key(&self) -> Self {
        Self {
            api_key: None,
            ..self.clone()
        }
    }

    /// These settings as records, sessions and `--json` keep them: no key,
    /// and credentials in the base URL replaced by `***`.
    pub fn for_record(&self) -> Self {
        Self {
            api_key: None,
            base_url: crate::sanitize::redact_url_credentials(&self.base_url),
            ..self.clone()
        }
    }
}

/// Everything the agents need to reach their models.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Per agent.
    pub agents: BTreeMap<AgentRole, AgentSettings>,
    /// Timeouts and retries.
    pub http: HttpSettings,
    /// Longest image edge sent, in pixels.
    pub max_image_edge: u32,
}

impl Settings {
    /// The settings of `role`.
    pub fn agent(&self, role: AgentRole) -> &AgentSettings {
        &self.agents[&role]
    }

    /// Layers `file`, the environment `env` and `flags`.
    pub fn resolve(
        file: &ConfigFile,
        env: &dyn Fn(&str) -> Option<String>,
        flags: &FlagLayers,
    ) -> Result<Self, ConfigError> {
        let mut agents = BTreeMap::new();
        for role in AgentRole::ALL {
            let from_file = file.agents.get(role.name()).cloned().unwrap_or_default();
            let from_flags = flags.per_agent.get(&role).cloned().unwrap_or_default();
            let provider = from_flags
                .provider
                .or(flags.all.provider)
                .or(from_file.provider)
                .or(file.defaults.provider)
                .unwrap_or(ProviderKind::Openai);
            let (default_url, default_model) =
                (provider.default_base_url(), provider.default_model());
            let from_env = AgentLayer {
                api_key: provider.key_variable().and_then(env).and_then(Secret::new),
                base_url: provider
                    .base_url_variable()
                    .and_then(env)
                    .filter(|v| !v.trim().is_empty()),
                ..AgentLayer::default()
            };
            let merged = file
                .defaults
                .clone()
                .then(&from_file)
                .then(&from_env)
                .then(&flags.all)
                .then(&from_flags);
            let temperature = check_temperature(
                &format!("{role}: temperature"),
                merged.temperature.unwrap_or(0.0),
            )?;
            let base_url = merged.base_url.unwrap_or_else(|| default_url.to_string());
            check_base_url(role, &base_url)?;
            let max_tokens = check_max_tokens(
                &format!("{role}: max_tokens"),
                u64::from(merged.max_tokens.unwrap_or(DEFAULT_MAX_TOKENS)),
            )?;
            let model = merged.model.unwrap_or_else(|| default_model.to_string());
            if model.trim().is_empty() {
                return Err(ConfigError::Invalid(format!(
                    "{role}: the model name is empty; give one with --model NAME, --agent {role}.model=NAME or model = \"NAME\" in the config file"
                )));
            }
            agents.insert(
                role,
                AgentSettings {
                    provider,
                    base_url,
                    model,
                    api_key: merged.api_key,
                    temperature,
                    max_tokens,
                    stream: merged.stream.unwrap_or(true),
                    json_output: merged.json_output.unwrap_or(true),
                },
            );
        }
        let mut http = HttpSettings::default();
        if let Some(secs) = flags.timeout_secs.or(file.timeout_secs) {
            http.total_timeout = seconds(secs, "timeout")?;
        }
        if let Some(secs) = file.connect_timeout_secs {
            http.connect_timeout = seconds(secs, "connect_timeout_secs")?;
        }
        if let Some(retries) = file.max_retries {
            if retries > MAX_RETRIES {
                return Err(ConfigError::Invalid(format!(
                    "max_retries {retries} is more than {MAX_RETRIES}"
                )));
            }
            http.max_retries = retries;
        }
        let max_image_edge = flags
            .max_image_edge
            .or(file.max_image_edge)
            .unwrap_or(DEFAULT_MAX_EDGE);
        if !(MIN_IMAGE_EDGE..=MAX_IMAGE_EDGE).contains(&max_image_edge) {
            return Err(ConfigError::Invalid(format!(
                "max image edge {max_image_edge} is outside {MIN_IMAGE_EDGE}..={MAX_IMAGE_EDGE} pixels"
            )));
        }
        Ok(Self {
            agents,
            http,
            max_image_edge,
        })
    }
}

/// The temperatures a user may set: what the providers accept.
pub const TEMPERATURE_RANGE: std::ops::RangeInclusive<f64> = 0.0..=2.0;
/// The token limits a user may set: at least one token, and no more than a
/// million (more than any model writes in one answer).
pub const MAX_TOKENS_RANGE: std::ops::RangeInclusive<u32> = 1..=1_000_000;
/// The token limit when none is set.
pub const DEFAULT_MAX_TOKENS: u32 = 1024;

/// Checks a sampling temperature, naming it as `what` when it is refused.
pub fn check_temperature(what: &str, value: f64) -> Result<f32, ConfigError> {
    if !TEMPERATURE_RANGE.contains(&value) {
        return Err(ConfigError::Invalid(format!(
            "{what} {value:?} is outside {}..={}: give a sampling temperature in that range",
            TEMPERATURE_RANGE.start(),
            TEMPERATURE_RANGE.end()
        )));
    }
    // In range, so exactly the f32 nearest the value.
    Ok(value as f32)
}

/// Checks a token limit, naming it as `what` when it is refused.
pub fn check_max_tokens(what: &str, value: u64) -> Result<u32, ConfigError> {
    u32::try_from(value)
        .ok()
        .filter(|n| MAX_TOKENS_RANGE.contains(n))
        .ok_or_else(|| {
            ConfigError::Invalid(format!(
                "{what} {value} is outside {}..={}: give a number of tokens in that range",
                MAX_TOKENS_RANGE.start(),
                MAX_TOKENS_RANGE.end()
            ))
        })
}

/// The longest wait for an answer a user may set: a day.
pub const MAX_TIMEOUT_SECS: f64 = 86_400.0;
/// The most retries a config file may ask for.
pub const MAX_RETRIES: u32 = 20;
/// The smallest image edge sent: below it a scene shows nothing.
pub const MIN_IMAGE_EDGE: u32 = 16;
/// The largest image edge sent: above it no provider accepts the image.
pub const MAX_IMAGE_EDGE: u32 = 8_192;

fn seconds(value: f64, name: &str) -> Result<Duration, ConfigError> {
    let bad = || {
        ConfigError::Invalid(format!(
            "{name} {value}: give a number of seconds above 0 and at most {MAX_TIMEOUT_SECS}"
        ))
    };
    if !(value > 0.0 && value <= MAX_TIMEOUT_SECS) {
        return Err(bad());
    }
    Duration::try_from_secs_f64(value).map_err(|_| bad())
}

/// Refuses a base URL that is not an absolute `http` or `https` URL with a
/// host, before any request is made (the config file, the environment and
/// the workbench's model form all check by it).
pub fn check_base_url(role: AgentRole, url: &str) -> Result<(), ConfigError> {
    let bad = |why: String| {
        ConfigError::Invalid(format!(
            "{role}: base URL `{}` {why}; give one like http://localhost:8000/v1",
            crate::sanitize::redact_url_credentials(url)
        ))
    };
    let parsed =
        reqwest::Url::parse(url.trim()).map_err(|err| bad(format!("is not a URL ({err})")))?;
    if !matches!(parsed.scheme(), "http" | "https") {
        return Err(bad(format!(
            "uses `{}:`, not http or https",
            parsed.scheme()
        )));
    }
    if parsed.host_str().is_none_or(str::is_empty) {
        return Err(bad("has no host".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn later_layers_override_earlier_ones() {
        let file: ConfigFile = toml::from_str(
            r#"
            [defaults]
            base_url = "http://file/v1"
            model = "file-model"
            api_key = "sk-file"
            temperature = 0.5
            [agents.planner]
            model = "file-planner"
            "#,
        )
        .unwrap();
        let env = |name: &str| (name == "OPENAI_API_KEY").then(|| "sk-env".to_string());
        let mut flags = FlagLayers::default();
        flags.all.model = Some("flag-model".into());
        flags.set_agent("gkm.temperature=0.2").unwrap();
        let settings = Settings::resolve(&file, &env, &flags).unwrap();
        let skm = settings.agent(AgentRole::Skm);
        assert_eq!(skm.model, "flag-model");
        assert_eq!(skm.base_url, "http://file/v1");
        assert_eq!(skm.api_key, Secret::new("sk-env"));
        assert_eq!(skm.temperature, 0.5);
        assert_eq!(settings.agent(AgentRole::Gkm).temperature, 0.2);
        assert_eq!(settings.agent(AgentRole::Planner).model, "flag-model");
        assert!(!format!("{settings:?}").contains("sk-env"));
    }

    #[test]
    fn provider_flag_picks_that_providers_environment() {
        let env = |name: &str| match name {
            "ANTHROPIC_API_KEY" => Some("ak".to_string()),
            "ANTHROPIC_BASE_URL" => Some("http://local".to_string()),
            _ => None,
        };
        let mut flags = FlagLayers::default();
        flags.all.provider = Some(ProviderKind::Anthropic);
        let settings = Settings::resolve(&ConfigFile::default(), &env, &flags).unwrap();
        let single = settings.agent(AgentRole::Single);
        assert_eq!(single.base_url, "http://local");
        assert_eq!(single.api_key, Secret::new("ak"));
        assert!(flags.clone().set_agent("skm.colour=red").is_err());
    }
}
