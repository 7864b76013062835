//! The cost ledger: tokens and US dollars per agent, from the usage each
//! provider reports and the price table of the config file; and the rough
//! estimate made before anything is sent, so that `--max-cost` can refuse a
//! run before its first request.
//!
//! The estimate counts about [`CHARS_PER_TOKEN`] characters a token for the
//! prompts, [`TOKENS_PER_IMAGE`] tokens for each image
//! ([`ChatRequest::estimated_usage`](super::provider::ChatRequest::estimated_usage)), and every agent's
//! `max_tokens` as its output: an upper bound on the output, a rough figure
//! for the input (tokenisers differ by model and by language).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::config::{ConfigError, Price};
use super::pipeline::{AgentRecord, PlanInput, PlanRecord, Runner};
use super::provider::{CHARS_PER_TOKEN, TOKENS_PER_IMAGE};
use super::{AgentRole, Approach, ProviderKind, Usage};

/// How an answer was paid for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Billing {
    /// Asked one request at a time, at the provider's interactive price.
    Interactive,
    /// Asked in a provider batch, at the batch price.
    Batch,
    /// Taken from the response cache or a recording: nothing paid.
    Cached,
}

/// The price of every model the config file names, by provider and model.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PriceTable {
    prices: BTreeMap<(ProviderKind, String), Price>,
}

impl PriceTable {
    /// The table of the config file's `[prices]` section; a provider other
    /// than `openai` or `anthropic`, or a price that is negative or not a
    /// number, is an error naming it.
    pub fn from_config(
        section: &BTreeMap<String, BTreeMap<String, Price>>,
    ) -> Result<Self, ConfigError> {
        let mut prices = BTreeMap::new();
        for (provider, models) in section {
            let kind: ProviderKind = provider.parse().map_err(|err: String| {
                ConfigError::Invalid(format!("[prices.{provider}]: {err}"))
            })?;
            for (model, price) in models {
                let figures = [
                    Some(price.input_per_million),
                    Some(price.output_per_million),
                    price.batch_input_per_million,
                    price.batch_output_per_million,
                ];
                if figures
                    .into_iter()
                    .flatten()
                    .any(|v| !(v.is_finite() && v >= 0.0))
                {
                    return Err(ConfigError::Invalid(format!(
                        "[prices.{provider}.\"{model}\"]: every price must be a number of dollars per million tokens, 0 or more"
                    )));
                }
                prices.insert((kind, model.clone()), *price);
            }
        }
        Ok(Self { prices })
    }

    /// The price of `model` at `provider`, if the config file gives one.
    pub fn price(&self, provider: ProviderKind, model: &str) -> Option<&Price> {
        self.prices.get(&(provider, model.to_string()))
    }

    /// What `usage` costs on `model` when paid as `billing`: nothing when
    /// cached, `None` when the model has no price.
    pub fn cost(
        &self,
        provider: ProviderKind,
        model: &str,
        usage: Usage,
        billing: Billing,
    ) -> Option<f64> {
        let price = match billing {
            Billing::Cached => return Some(0.0),
            _ => self.price(provider, model)?,
        };
        let (input, output) = match billing {
            Billing::Batch => (
                price
                    .batch_input_per_million
                    .unwrap_or(price.input_per_million / 2.0),
                price
                    .batch_output_per_million
                    .unwrap_or(price.output_per_million / 2.0),
            ),
            _ => (price.input_per_million, price.output_per_million),
        };
        Some((usage.input_tokens as f64 * input + usage.output_tokens as f64 * output) / 1e6)
    }
}

/// One agent's answer as the ledger counted it: kept in each task's JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentCost {
    /// The agent.
    pub role: AgentRole,
    /// Its provider.
    pub provider: ProviderKind,
    /// Its model.
    pub model: String,
    /// The tokens the provider reported for the answer.
    pub usage: Usage,
    /// How the answer was paid for.
    pub billing: Billing,
    /// What it cost in US dollars (`None`: the model has no price).
    pub usd: Option<f64>,
}

/// A plan's answers as the ledger counted them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanCost {
    /// Each agent that answered.
    pub agents: Vec<AgentCost>,
    /// The sum in US dollars (`None` when some model has no price).
    pub usd: Option<f64>,
}

/// The answers of one agent on one model, added up.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LedgerLine {
    /// The agent.
    pub role: AgentRole,
    /// Its provider.
    pub provider: ProviderKind,
    /// Its model.
    pub model: String,
    /// Answers paid for.
    pub paid: u64,
    /// Answers from the cache, costing nothing.
    pub cached: u64,
    /// The tokens of the answers paid for.
    pub usage: Usage,
    /// The tokens the cached answers had when they were first paid for.
    pub cached_usage: Usage,
    /// The cost in US dollars (`None` when the model has no price).
    pub usd: Option<f64>,
}

/// Adds up tokens and cost per agent and model over a run: `eval` and
/// `plan` feed it every plan they make and print [`Ledger::table`].
#[derive(Debug, Clone, Default)]
pub struct Ledger {
    prices: PriceTable,
    lines: BTreeMap<(AgentRole, ProviderKind, String), LedgerLine>,
}

impl Ledger {
    /// An empty ledger pricing with `prices`.
    pub fn new(prices: PriceTable) -> Self {
        Self {
            prices,
            lines: BTreeMap::new(),
        }
    }

    /// The price table.
    pub fn prices(&self) -> &PriceTable {
        &self.prices
    }

    /// Counts one agent's answer paid as `billing` (an agent that failed
    /// before answering counts nothing) and returns what it cost.
    pub fn add_agent(&mut self, agent: &AgentRecord, billing: Billing) -> Option<AgentCost> {
        agent.output.as_ref()?;
        Some(self.add_answer(
            agent.role,
            agent.settings.provider,
            &agent.settings.model,
            agent.usage,
            billing,
        ))
    }

    /// Counts one answer of `role` on `model` with `usage`, paid as
    /// `billing` (e.g. a batch answer whose plan could not be made yet), and
    /// returns what it cost.
    pub fn add_answer(
        &mut self,
        role: AgentRole,
        provider: ProviderKind,
        model: &str,
        usage: Usage,
        billing: Billing,
    ) -> AgentCost {
        let usd = self.prices.cost(provider, model, usage, billing);
        let line = self
            .lines
            .entry((role, provider, model.to_string()))
            .or_insert_with(|| LedgerLine {
                role,
                provider,
                model: model.to_string(),
                paid: 0,
                cached: 0,
                usage: Usage::default(),
                cached_usage: Usage::default(),
                usd: Some(0.0),
            });
        let (count, tokens) = match billing {
            Billing::Cached => (&mut line.cached, &mut line.cached_usage),
            _ => (&mut line.paid, &mut line.usage),
        };
        *count += 1;
        tokens.input_tokens += usage.input_tokens;
        tokens.output_tokens += usage.output_tokens;
        line.usd = line.usd.zip(usd).map(|(sum, one)| sum + one);
        AgentCost {
            role,
            provider,
            model: model.to_string(),
            usage,
            billing,
            usd,
        }
    }

    /// Counts every agent of `record`: answers that came from the cache as
    /// cached, the others as `paid` (interactive or batch).
    pub fn add_plan(&mut self, record: &PlanRecord, paid: Billing) -> PlanCost {
        let agents: Vec<AgentCost> = record
            .agents
            .iter()
            .filter_map(|agent| {
                let billing = if agent.cached { Billing::Cached } else { paid };
                self.add_agent(agent, billing)
            })
            .collect();
        let usd = agents.iter().try_fold(0.0, |sum, a| a.usd.map(|v| sum + v));
        PlanCost { agents, usd }
    }

    /// Every line, by agent, provider and model.
    pub fn lines(&self) -> impl Iterator<Item = &LedgerLine> {
        self.lines.values()
    }

    /// The sum of every line: answers paid and cached, tokens, dollars
    /// (`None` when some model has no price).
    pub fn total(&self) -> (u64, u64, Usage, Option<f64>) {
        self.lines().fold(
            (0, 0, Usage::default(), Some(0.0)),
            |(paid, cached, usage, usd), line| {
                (
                    paid + line.paid,
                    cached + line.cached,
                    Usage {
                        input_tokens: usage.input_tokens + line.usage.input_tokens,
                        output_tokens: usage.output_tokens + line.usage.output_tokens,
                    },
                    usd.zip(line.usd).map(|(a, b)| a + b),
                )
            },
        )
    }

    /// A plain-text table, one line per agent and model and a total, for
    /// stderr; empty when nothing was counted.
    pub fn table(&self) -> String {
        if self.lines.is_empty() {
            return String::new();
        }
        let mut out = format!(
            "{:<8} {:<28} {:>6} {:>6} {:>12} {:>12} {:>10}\n",
            "agent", "model", "paid", "cached", "tokens in", "tokens out", "USD"
        );
        for line in self.lines() {
            let model = format!("{}/{}", line.provider.name(), line.model);
            let _ = writeln!(
                out,
                "{:<8} {:<28} {:>6} {:>6} {:>12} {:>12} {:>10}",
                line.role.name(),
                model,
                line.paid,
                line.cached,
                line.usage.input_tokens,
                line.usage.output_tokens,
                dollars(line.usd)
            );
        }
        let (paid, cached, usage, usd) = self.total();
        let _ = writeln!(
            out,
            "{:<8} {:<28} {:>6} {:>6} {:>12} {:>12} {:>10}",
            "total",
            "",
            paid,
            cached,
            usage.input_tokens,
            usage.output_tokens,
            dollars(usd)
        );
        out
    }
}

/// Dollars with enough digits for a test run, or `no price`.
pub fn dollars(usd: Option<f64>) -> String {
    usd.map_or_else(|| "no price".to_string(), |v| format!("{v:.4}"))
}

/// What a run is expected to cost, made before anything is sent.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Estimate {
    /// Requests that will be paid for.
    pub requests: u64,
    /// Requests whose answer is already cached.
    pub cached: u64,
    /// The estimated tokens of the requests paid for.
    pub usage: Usage,
    /// The estimated cost of the priced models, in US dollars.
    pub usd: f64,
    /// `provider/model` of each model without a price.
    pub unpriced: BTreeSet<String>,
}

impl Estimate {
    /// Counts one request of `model`: `usage` paid as `billing`, or nothing
    /// when `cached`.
    pub fn add(
        &mut self,
        prices: &PriceTable,
        provider: ProviderKind,
        model: &str,
        usage: Usage,
        billing: Billing,
    ) {
        if billing == Billing::Cached {
            self.cached += 1;
            return;
        }
        self.requests += 1;
        self.usage.input_tokens += usage.input_tokens;
        self.usage.output_tokens += usage.output_tokens;
        match prices.cost(provider, model, usage, billing) {
            Some(usd) => self.usd += usd,
            None => {
                self.unpriced.insert(format!("{}/{model}", provider.name()));
            }
        }
    }

    fn unpriced_names(&self) -> String {
        let names: Vec<&str> = self.unpriced.iter().map(String::as_str).collect();
        names.join(", ")
    }

    /// ` plus the unpriced MODELS (add … to the config file)`, or nothing
    /// when every model to be paid for has a price: what an estimate's
    /// dollars leave out, wherever the estimate is shown.
    pub fn unpriced_suffix(&self) -> String {
        if self.unpriced.is_empty() {
            return String::new();
        }
        format!(
            " plus the unpriced {} (add [prices.PROVIDER.\"MODEL\"] to the config file)",
            self.unpriced_names()
        )
    }

    /// One line for stderr that says it is an estimate and how it was made.
    pub fn line(&self) -> String {
        let mut line = format!(
            "estimate (rough: ~{CHARS_PER_TOKEN} characters a token, {TOKENS_PER_IMAGE} tokens an image, output at max_tokens): {} requests to send, {} cached; ~{} tokens in, at most {} out; ~${:.4}",
            self.requests, self.cached, self.usage.input_tokens, self.usage.output_tokens, self.usd
        );
        line.push_str(&self.unpriced_suffix());
        line
    }

    /// Refuses the run when `max_cost` is given and the estimate exceeds it,
    /// or cannot be known because a model to be paid for has no price.
    pub fn check(&self, max_cost: Option<f64>) -> Result<(), CostError> {
        let Some(limit) = max_cost else {
            return Ok(());
        };
        if self.requests > 0 && !self.unpriced.is_empty() {
            return Err(CostError::Unpriced {
                limit,
                models: self.unpriced_names(),
            });
        }
        if self.usd > limit {
            return Err(CostError::Exceeds {
                estimate: self.usd,
                limit,
            });
        }
        Ok(())
    }
}

/// Why a run is refused before anything is sent: `--max-cost` is not a
/// price, or the run would cost more than it, or cannot be bounded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CostError {
    /// `--max-cost` is negative or not a number.
    #[error("--max-cost {0}: give a number of US dollars, 0 or more")]
    BadLimit(f64),
    /// A model to be paid for has no price.
    #[error("--max-cost {limit}: no price for {models} in the config file, so the cost cannot be bounded; add [prices.PROVIDER.\"MODEL\"] with input_per_million and output_per_million; nothing was sent")]
    Unpriced {
        /// The limit given.
        limit: f64,
        /// The models without a price, as the estimate names them.
        models: String,
    },
    /// The estimate is past the limit.
    #[error("the estimate ~${estimate:.4} exceeds --max-cost {limit}; nothing was sent (raise --max-cost, or run fewer tasks or approaches)")]
    Exceeds {
        /// The estimated cost in US dollars.
        estimate: f64,
        /// The limit given.
        limit: f64,
    },
}

/// The estimate of making each of `plans` (approach, input, sample) with
/// `runner`, the requests not cached paid as `paid`: every sample counts. A
/// plan whose input is unusable is left out: it fails before sending
/// anything.
pub fn estimate_plans<'a>(
    runner: &Runner,
    plans: impl IntoIterator<Item = (Approach, &'a PlanInput, u32)>,
    paid: Billing,
    prices: &PriceTable,
) -> Estimate {
    let mut estimate = Estimate::default();
    for (approach, input, sample) in plans {
        let Ok(stage) = runner.next_stage(approach, input, sample) else {
            continue;
        };
        for pending in &stage.requests {
            let billing = if pending.free { Billing::Cached } else { paid };
            let usage = pending.request.estimated_usage();
            estimate.add(
                prices,
                pending.provider,
                &pending.request.model,
                usage,
                billing,
            );
        }
        if let Some((provider, model, usage)) = &stage.planner_later {
            estimate.add(prices, *provider, model, *usage, paid);
        }
    }
    estimate
}

/// Checks a `--max-cost` value: a number of dollars, 0 or more.
pub fn check_max_cost(value: Option<f64>) -> Result<(), CostError> {
    match value {
        Some(v) if !(v.is_finite() && v >= 0.0) => Err(CostError::BadLimit(v)),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::provider::ChatRequest;

    fn table() -> PriceTable {
        let section: BTreeMap<String, BTreeMap<String, Price>> = toml::from_str(
            r#"
            [openai."gpt-4o"]
            input_per_million = 2.5
            output_per_million = 10.0
            [anthropic."claude"]
            input_per_million = 3.0
            output_per_million = 15.0
            batch_output_per_million = 6.0
            "#,
        )
        .unwrap();
        PriceTable::from_config(&section).unwrap()
    }

    #[test]
    fn batch_costs_half_unless_configured() {
        let prices = table();
        let usage = Usage {
            input_tokens: 1_000_000,
            output_tokens: 100_000,
        };
        let openai = |billing| prices.cost(ProviderKind::Openai, "gpt-4o", usage, billing);
        assert_eq!(openai(Billing::Interactive), Some(2.5 + 1.0));
        assert_eq!(openai(Billing::Batch), Some(1.25 + 0.5));
        assert_eq!(openai(Billing::Cached), Some(0.0));
        let claude = prices.cost(ProviderKind::Anthropic, "claude", usage, Billing::Batch);
        assert_eq!(claude, Some(1.5 + 0.6));
        assert_eq!(
            prices.cost(ProviderKind::Openai, "other", usage, Billing::Interactive),
            None
        );
    }

    #[test]
    fn bad_prices_are_refused_with_their_name() {
        let section: BTreeMap<String, BTreeMap<String, Price>> =
            toml::from_str("[mistral.\"m\"]\ninput_per_million = 1.0\noutput_per_million = 1.0\n")
                .unwrap();
        let err = PriceTable::from_config(&section).unwrap_err().to_string();
        assert!(err.contains("[prices.mistral]"), "{err}");
        let section: BTreeMap<String, BTreeMap<String, Price>> =
            toml::from_str("[openai.\"m\"]\ninput_per_million = -1.0\noutput_per_million = 1.0\n")
                .unwrap();
        let err = PriceTable::from_config(&section).unwrap_err().to_string();
        assert!(err.contains("[prices.openai.\"m\"]"), "{err}");
    }

    #[test]
    fn an_estimate_over_the_limit_or_unpriced_is_refused() {
        let prices = table();
        let usage = Usage {
            input_tokens: 400_000,
            ..Usage::default()
        };
        let mut estimate = Estimate::default();
        estimate.add(
            &prices,
            ProviderKind::Openai,
            "gpt-4o",
            usage,
            Billing::Interactive,
        );
        estimate.add(
            &prices,
            ProviderKind::Openai,
            "gpt-4o",
            usage,
            Billing::Cached,
        );
        assert_eq!((estimate.requests, estimate.cached), (1, 1));
        assert!((estimate.usd - 1.0).abs() < 1e-12);
        assert!(estimate.check(Some(1.5)).is_ok());
        assert!(estimate
            .check(Some(0.5))
            .unwrap_err()
            .to_string()
            .contains("exceeds"));
        estimate.add(
            &prices,
            ProviderKind::Openai,
            "mystery",
            usage,
            Billing::Batch,
        );
        let err = estimate.check(Some(100.0)).unwrap_err().to_string();
        assert!(err.contains("openai/mystery"), "{err}");
        assert!(estimate.line().starts_with("estimate (rough"));
        assert!(check_max_cost(Some(-1.0)).is_err());
    }

    #[test]
    fn estimates_count_characters_images_and_the_token_limit() {
        let request = ChatRequest {
            model: "m".into(),
            system: "abcd".into(),
            user: "é".repeat(9),
            images: Vec::new(),
            temperature: 0.0,
            max_tokens: 300,
            stream: false,
            json_schema: None,
        };
        let usage = request.estimated_usage();
        assert_eq!(usage.input_tokens, 1 + 3);
        assert_eq!(usage.output_tokens, 300);
    }
}
