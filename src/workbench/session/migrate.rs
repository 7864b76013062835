//! Session files saved by earlier versions, brought up to
//! [`SESSION_VERSION`] one version at a time on the JSON, so that an upgrade
//! keeps the user's run history.

use serde_json::{Map, Value};

use super::{DecodeError, SESSION_VERSION};
use crate::agents::prompts::{prompt_hash, template_name};
use crate::agents::{AgentRole, Approach, ProviderKind};

/// `value` brought up to [`SESSION_VERSION`]; a file from a newer version
/// is refused.
pub(super) fn migrate(mut value: Value) -> Result<Value, DecodeError> {
    let version = value.get("version").and_then(Value::as_u64);
    let Some(mut version) = version else {
        return Err(DecodeError::NoVersion);
    };
    if version > u64::from(SESSION_VERSION) {
        return Err(DecodeError::Newer(version));
    }
    while version < u64::from(SESSION_VERSION) {
        match version {
            1 => v1_to_v2(&mut value),
            2 => v2_to_v3(&mut value),
            3 => v3_to_v4(&mut value),
            4 => v4_to_v5(&mut value),
            // Version 6 adds the parked sources beside the one in use, which
            // stays where it was: an older file has none.
            5 => {}
            _ => return Err(DecodeError::TooOld(version)),
        }
        version += 1;
        value["version"] = version.into();
    }
    Ok(value)
}

/// Version 5 says what became of each run: `cancelled` becomes the state
/// `cancelled`; a run one of whose agents failed becomes `failed`, with
/// that failure as its error (its scores are kept in the file but no
/// longer count as a plan's); a run with a failed later sample becomes
/// `partial`; every other run is `finished`.
fn v4_to_v5(value: &mut Value) {
    for run in runs(value) {
        let cancelled = run.remove("cancelled").and_then(|c| c.as_bool()) == Some(true);
        let failure = agents(run).find_map(|agent| {
            let error = agent.get("error").and_then(Value::as_str)?.to_string();
            let role = agent.get("role").and_then(Value::as_str).unwrap_or("agent");
            Some(format!("{role}: {error}"))
        });
        let failed_samples = run
            .get("samples")
            .and_then(Value::as_array)
            .map_or(0, |s| s.iter().filter(|s| !s["error"].is_null()).count());
        let (state, reason) = if cancelled {
            ("cancelled", Some("cancelled".to_string()))
        } else if failure.is_some() {
            ("failed", Some("not scored".to_string()))
        } else if failed_samples > 0 {
            (
                "partial",
                Some(format!("{failed_samples} later samples failed")),
            )
        } else {
            ("finished", None)
        };
        sample_calls(run);
        run.insert("state".into(), state.into());
        if let Some(error) = failure {
            run.insert("error".into(), error.into());
        }
        if let Some(reason) = reason {
            run.insert("reason".into(), reason.into());
        }
    }
}

/// Version 5 keeps each later sample's calls as agent records where
/// version 4 kept their answers by agent: each answer becomes a record with
/// the settings and prompt of the run's own record of that agent, no time
/// and (but for a sample of one agent, which gets the sample's tokens) no
/// tokens; the sample's token total is kept as it was.
fn sample_calls(run: &mut Map<String, Value>) {
    let records: Vec<Map<String, Value>> = agents(run).map(|a| a.clone()).collect();
    let samples = run.get_mut("samples").and_then(Value::as_array_mut);
    for sample in samples
        .into_iter()
        .flatten()
        .filter_map(Value::as_object_mut)
    {
        let outputs = match sample.remove("outputs") {
            Some(Value::Object(outputs)) => outputs,
            _ => Map::new(),
        };
        let usage = sample.get("usage").cloned().unwrap_or(Value::Null);
        let one = outputs.len() == 1;
        let calls: Vec<Value> = outputs
            .into_iter()
            .map(|(role, output)| {
                let mut call = records
                    .iter()
                    .find(|r| r.get("role").and_then(Value::as_str) == Some(role.as_str()))
                    .or(records.first())
                    .cloned()
                    .unwrap_or_else(|| {
                        let mut blank = Map::new();
                        for (key, value) in [
                            ("provider", Value::from(ProviderKind::Replay.name())),
                            ("base_url", ProviderKind::Replay.default_base_url().into()),
                            ("model", "".into()),
                            ("temperature", 0.0.into()),
                            (
                                "max_tokens",
                                crate::agents::config::DEFAULT_MAX_TOKENS.into(),
                            ),
                            ("stream", true.into()),
                            ("json_output", true.into()),
                            ("prompt", "".into()),
                            ("prompt_hash", "".into()),
                        ] {
                            blank.insert(key.into(), value);
                        }
                        blank
                    });
                let tokens = if one {
                    usage.clone()
                } else {
                    serde_json::json!({"input_tokens": 0, "output_tokens": 0})
                };
                for (key, value) in [
                    ("role", Value::from(role)),
                    ("output", output),
                    ("error", Value::Null),
                    ("usage", tokens),
                    ("elapsed_ms", 0.into()),
                    ("cached", false.into()),
                    ("request_key", "".into()),
                ] {
                    call.insert(key.into(), value);
                }
                Value::Object(call)
            })
            .collect();
        sample.insert("agents".into(), calls.into());
    }
}

/// Version 4 keeps every sample of a run: each run gains its later samples
/// (none: an older run is one sample) and the session its samples setting
/// (1, as every older run was made).
fn v3_to_v4(value: &mut Value) {
    for run in runs(value) {
        run.insert("samples".into(), Value::Array(Vec::new()));
    }
    if let Some(session) = value.as_object_mut() {
        session.insert("samples".into(), 1.into());
    }
}

/// The runs of a session, as JSON objects.
fn runs(value: &mut Value) -> impl Iterator<Item = &mut Map<String, Value>> {
    value
        .get_mut("runs")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
        .filter_map(Value::as_object_mut)
}

/// The agent records of a run, as JSON objects.
fn agents(run: &mut Map<String, Value>) -> impl Iterator<Item = &mut Map<String, Value>> {
    run.get_mut("agents")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
        .filter_map(Value::as_object_mut)
}

/// Version 2 counts tokens as the providers do (`input_tokens`,
/// `output_tokens`), where version 1 had `input` and `output`.
fn v1_to_v2(value: &mut Value) {
    for run in runs(value) {
        for agent in agents(run) {
            if let Some(usage) = agent.get_mut("usage").and_then(Value::as_object_mut) {
                for (old, new) in [("input", "input_tokens"), ("output", "output_tokens")] {
                    if let Some(count) = usage.remove(old) {
                        usage.insert(new.to_string(), count);
                    }
                }
            }
        }
    }
}

/// Version 3 keeps the agents' own types: settings as
/// [`crate::agents::config::AgentSettings`] (a provider of `openai`,
/// `anthropic` or `replay`, with its base URL and the streaming and
/// JSON-output switches), and records as
/// [`crate::agents::pipeline::AgentRecord`] (`role`, `elapsed_ms`, the
/// settings beside the other fields, the template's name and hash), the
/// template texts kept by the run. A
/// provider name no version could run (typed into the model form) becomes
/// the recording, which asks for a provider when it is run.
fn v2_to_v3(value: &mut Value) {
    let settings = value.get_mut("settings").and_then(Value::as_object_mut);
    for agent in settings.into_iter().flat_map(|m| m.values_mut()) {
        upgrade_settings(agent);
    }
    let ran_with = value.get_mut("ran_with").and_then(Value::as_object_mut);
    for pair in ran_with.into_iter().flat_map(|m| m.values_mut()) {
        if let Some(agent) = pair.get_mut(1) {
            upgrade_settings(agent);
        }
    }
    for run in runs(value) {
        let approach = run
            .get("approach")
            .and_then(|a| serde_json::from_value::<Approach>(a.clone()).ok());
        let mut prompts = Map::new();
        for agent in agents(run) {
            for (old, new) in [("agent", "role"), ("duration_ms", "elapsed_ms")] {
                if let Some(field) = agent.remove(old) {
                    agent.insert(new.to_string(), field);
                }
            }
            let role = agent
                .get("role")
                .and_then(|r| serde_json::from_value::<AgentRole>(r.clone()).ok());
            let text = match agent.remove("prompt") {
                Some(Value::String(text)) => text,
                _ => String::new(),
            };
            let name = match (approach, role) {
                (Some(approach), Some(role)) => template_name(approach, role),
                _ => String::new(),
            };
            agent.insert("prompt".into(), name.into());
            agent.insert("prompt_hash".into(), prompt_hash(&text).into());
            agent.insert("request_key".into(), "".into());
            agent.entry("cached").or_insert(false.into());
            if let Some(mut settings) = agent.remove("settings") {
                upgrade_settings(&mut settings);
                if let Value::Object(fields) = settings {
                    agent.extend(fields);
                }
            }
            if let Some(role) = role {
                prompts.insert(role.name().to_string(), text.into());
            }
        }
        run.insert("prompts".into(), prompts.into());
    }
}

/// Version 2's settings (provider name, model, temperature, token limit)
/// with the provider's defaults for what version 3 adds.
fn upgrade_settings(settings: &mut Value) {
    let Some(settings) = settings.as_object_mut() else {
        return;
    };
    let provider = settings
        .get("provider")
        .and_then(Value::as_str)
        .and_then(|p| p.parse::<ProviderKind>().ok())
        .unwrap_or(ProviderKind::Replay);
    settings.insert("provider".into(), provider.name().into());
    settings
        .entry("base_url")
        .or_insert(provider.default_base_url().into());
    settings.entry("stream").or_insert(true.into());
    settings.entry("json_output").or_insert(true.into());
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::super::{restore, Restored, RunState, Session};
    use super::*;

    /// The fixture `name` restored from a copy, with its JSON as saved.
    fn restored(name: &str) -> (Session, Value) {
        let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures")
            .join(name);
        let old: Value = serde_json::from_str(&std::fs::read_to_string(&fixture).unwrap()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.json");
        std::fs::copy(&fixture, &path).unwrap();
        let Restored::Loaded { session, repaired } = restore(&path).unwrap() else {
            panic!("{name} was not loaded");
        };
        assert!(repaired.is_empty(), "{repaired:?}");
        assert!(path.exists(), "the file stays where it was");
        assert_eq!(session.version, SESSION_VERSION);
        assert_eq!(
            session.current.runs.len(),
            old["runs"].as_array().unwrap().len()
        );
        assert!(session.current.runs.len() >= 2);
        (*session, old)
    }

    /// Runs saved before version 4 are one finished sample each.
    fn assert_one_finished_sample(session: &Session) {
        for run in &session.current.runs {
            assert!(run.samples.is_empty(), "an older run is one sample");
            assert_eq!(run.state, RunState::Finished);
            let scores = run.sample_scores();
            assert_eq!(scores.len(), 1, "its one sample's scores");
            assert_eq!(Some(scores[0]), run.scores);
        }
        assert_eq!(session.samples, 1, "older runs were made with one sample");
    }

    #[test]
    fn a_session_saved_by_version_4_keeps_everything_and_says_what_became_of_each_run() {
        let (s, old) = restored("session-v4.json");
        assert_eq!(old["version"], 4);
        let old_runs = old["runs"].as_array().unwrap();
        for (run, old_run) in s.current.runs.iter().zip(old_runs) {
            assert_eq!(run.id, old_run["id"]);
            assert_eq!(
                run.plan,
                serde_json::from_value::<Vec<String>>(old_run["plan"].clone()).unwrap()
            );
            assert_eq!(
                run.agents.len(),
                old_run["agents"].as_array().unwrap().len()
            );
            assert_eq!(
                run.samples.len(),
                old_run["samples"].as_array().unwrap().len()
            );
            assert_eq!(
                run.scores,
                serde_json::from_value(old_run["scores"].clone()).unwrap(),
                "the scores stay in the file"
            );
            assert_eq!(run.total_ms(), old_run["agents"][0]["elapsed_ms"]);
        }
        let states: Vec<RunState> = s.current.runs.iter().map(|r| r.state).collect();
        assert_eq!(
            states,
            [
                RunState::Finished,
                RunState::Cancelled,
                RunState::Failed,
                RunState::Partial
            ]
        );
        assert_eq!(
            s.current.runs[2].error.as_deref(),
            Some("single: HTTP 500 Internal Server Error")
        );
        assert_eq!(
            s.current.runs[2].plan,
            ["Walk"],
            "the broken-off plan is kept"
        );
        let scored: Vec<usize> = s
            .current
            .runs
            .iter()
            .map(|r| r.sample_scores().len())
            .collect();
        assert_eq!(
            scored,
            [1, 0, 0, 2],
            "the failed and cancelled runs count for nothing, the partial one over its complete samples"
        );
        let sampled = &s.current.runs[3];
        assert_eq!(sampled.samples[0].agents.len(), 1);
        let call = &sampled.samples[0].agents[0];
        assert_eq!(call.output_text(), "1. Walk to the sink.");
        assert_eq!(
            call.settings.model, "gpt-4o",
            "the run's settings of that agent"
        );
        assert_eq!(call.usage.input_tokens + call.usage.output_tokens, 109);
        assert!(sampled.samples[1].agents.is_empty(), "it had no answer");
        assert_eq!(sampled.total_tokens(), 120 + 109, "every sample's tokens");
        assert_eq!(s.samples, 3);
        assert_eq!(
            s.current.plan_source,
            super::super::PlanSource::Run { run: 4 }
        );
    }

    #[test]
    fn a_session_saved_by_version_1_loads_with_its_run_history() {
        let (s, old) = restored("session-v1.json");
        assert_one_finished_sample(&s);
        assert_eq!(old["version"], 1);
        for (run, old_run) in s.current.runs.iter().zip(old["runs"].as_array().unwrap()) {
            assert_eq!(run.plan.len(), old_run["plan"].as_array().unwrap().len());
            for (agent, old_agent) in run.agents.iter().zip(old_run["agents"].as_array().unwrap()) {
                assert_eq!(agent.usage.input_tokens, old_agent["usage"]["input"]);
                assert_eq!(agent.usage.output_tokens, old_agent["usage"]["output"]);
            }
        }
    }

    #[test]
    fn a_session_saved_by_version_2_loads_with_its_runs_prompts_and_settings() {
        let (s, old) = restored("session-v2.json");
        assert_one_finished_sample(&s);
        assert_eq!(old["version"], 2);
        for (run, old_run) in s.current.runs.iter().zip(old["runs"].as_array().unwrap()) {
            assert_eq!(
                run.plan,
                serde_json::from_value::<Vec<String>>(old_run["plan"].clone()).unwrap()
            );
            let old_agents = old_run["agents"].as_array().unwrap();
            assert_eq!(run.agents.len(), old_agents.len());
            for (agent, old_agent) in run.agents.iter().zip(old_agents) {
                assert_eq!(agent.role.name(), old_agent["agent"]);
                assert_eq!(agent.elapsed_ms, old_agent["duration_ms"]);
                assert_eq!(agent.output_text(), old_agent["output"]);
                assert_eq!(
                    agent.settings.provider.name(),
                    old_agent["settings"]["provider"]
                );
                assert_eq!(agent.settings.model, old_agent["settings"]["model"]);
                assert_eq!(agent.prompt, template_name(run.approach, agent.role));
                let text = &run.prompts[&agent.role];
                assert_eq!(text, &old_agent["prompt"]);
                assert_eq!(agent.prompt_hash, prompt_hash(text));
            }
        }
        for (role, settings) in &s.current.settings {
            assert_eq!(settings.provider, ProviderKind::Replay, "{role}");
            assert!(settings.is_demo_recording(), "{role}: {settings:?}");
        }
    }

    #[test]
    fn an_unknown_provider_name_becomes_the_recording() {
        let mut settings = serde_json::json!({"provider": "local-llm", "model": "m", "temperature": 0.0, "max_tokens": 9});
        upgrade_settings(&mut settings);
        assert_eq!(settings["provider"], "replay");
        assert_eq!(
            settings["base_url"],
            ProviderKind::Replay.default_base_url()
        );
        let mut settings = serde_json::json!({"provider": "anthropic", "model": "m", "temperature": 0.0, "max_tokens": 9});
        upgrade_settings(&mut settings);
        assert_eq!(
            settings["base_url"],
            ProviderKind::Anthropic.default_base_url()
        );
    }
}
