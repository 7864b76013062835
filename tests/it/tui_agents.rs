//! The workbench over the real agents: the demo's recording (made for the
//! built-in templates, demo task and scene, replayed byte for byte) and a
//! live run against a local OpenAI-compatible server (wiremock), driven
//! through the workbench's update function.

use crate::agents_support;

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use agents_support::*;
use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use mapvlm::agents::cache::ResponseCache;
use mapvlm::agents::config::{AgentSettings, ConfigFile, Settings};
use mapvlm::agents::images::DEFAULT_MAX_EDGE;
use mapvlm::agents::pipeline::{AgentEvent, PlanInput, Runner, Source};
use mapvlm::agents::prompts::PromptSet;
use mapvlm::agents::provider::{Chunk, HttpSettings};
use mapvlm::agents::replay::{Pace, Recording};
use mapvlm::agents::{AgentRole, Approach, ProviderKind};
use mapvlm::demo;
use mapvlm::plan::parse_steps;
use mapvlm::workbench::agents::{
    demo_scene_file, run_blocking, AgentsPipeline, Pipeline, ProviderConfig,
};
use mapvlm::workbench::app::{App, AppInit};
use mapvlm::workbench::headless::Headless;
use mapvlm::workbench::message::{Cmd, Msg};
use mapvlm::workbench::panes::Pane;
use mapvlm::workbench::runs::AgentStatus;
use mapvlm::workbench::scoring::ModelSlot;
use serde_json::Value;
use tokio_util::sync::CancellationToken;
use wiremock::{MockServer, Request, Respond, ResponseTemplate};

/// The note the demo's recording carries.
const NOTE: &str =
    "The demo's answers were written by hand by the mapvlm authors (no model was asked), \
for the built-in prompts/ templates of the multi-image approach, the demo task and the demo scene.";

/// Answers each agent's request with the demo's hand-written output, the
/// token counts estimated from the text (four characters a token).
struct HandWritten;

impl Respond for HandWritten {
    fn respond(&self, request: &Request) -> ResponseTemplate {
        let body: Value = serde_json::from_slice(&request.body).unwrap();
        let text = body.to_string();
        let output = if text.contains(SKM_MARK) {
            demo::SKM_OUTPUT
        } else if text.contains(GKM_MARK) {
            demo::GKM_OUTPUT
        } else {
            demo::PLANNER_OUTPUT
        };
        let prompt_chars: usize = body["messages"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|m| match &m["content"] {
                Value::String(s) => vec![s.len()],
                Value::Array(parts) => parts
                    .iter()
                    .filter_map(|p| p["text"].as_str().map(str::len))
                    .collect(),
                _ => Vec::new(),
            })
            .sum();
        ResponseTemplate::new(200).set_body_json(serde_json::json!({
            "id": "demo", "object": "chat.completion",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": output}, "finish_reason": "stop"}],
            "usage": {"prompt_tokens": prompt_chars.div_ceil(4), "completion_tokens": output.len().div_ceil(4)}
        }))
    }
}

/// The demo's recording made anew: the runner asks a local server that
/// answers with the hand-written outputs, and records.
fn record_demo() -> Recording {
    let runtime = tokio::runtime::Runtime::new().unwrap();
    runtime.block_on(async {
        let server = MockServer::start().await;
        wiremock::Mock::given(wiremock::matchers::method("POST"))
            .respond_with(HandWritten)
            .mount(&server)
            .await;
        let mut agents = BTreeMap::new();
        for role in AgentRole::ALL {
            // The recording's own settings, over the OpenAI-compatible API
            // its requests are keyed as, at a local server.
            let settings = AgentSettings {
                provider: ProviderKind::Openai,
                base_url: format!("{}/v1", server.uri()),
                json_output: false,
                ..AgentSettings::demo_recording()
            };
            agents.insert(role, settings);
        }
        let settings = Settings {
            agents,
            http: HttpSettings::default(),
            max_image_edge: DEFAULT_MAX_EDGE,
        };
        let recording = Arc::new(Mutex::new(Recording::new(NOTE)));
        let runner = Runner::new(settings, PromptSet::load(None).unwrap(), Source::Live)
            .with_recorder(recording.clone());
        let input = PlanInput {
            task: demo::TASK.trim().to_string(),
            image: Some(demo_scene_file().unwrap()),
            table: None,
        };
        let (tx, _rx) = tokio::sync::mpsc::unbounded_channel();
        let record = runner
            .plan(Approach::MultiImage, &input, &tx, &CancellationToken::new())
            .await
            .unwrap();
        assert_eq!(record.first_error(), None);
        let mut recording = recording.lock().unwrap().clone();
        for answer in recording.answers.values_mut() {
            answer.completion.chunks = answer
                .completion
                .text
                .split_inclusive(' ')
                .enumerate()
                .map(|(i, word)| Chunk {
                    at_ms: 12 * i as u64,
                    text: word.to_string(),
                })
                .collect();
        }
        recording
    })
}

#[test]
fn the_demo_recording_answers_the_built_in_templates_on_the_demo_scene() {
    let made = serde_json::to_string_pretty(&record_demo()).unwrap() + "\n";
    if std::env::var_os("MAPVLM_UPDATE_DEMO_RECORDING").is_some() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/demo/recording.json");
        std::fs::write(path, &made).unwrap();
        return;
    }
    assert_eq!(
        made,
        demo::RECORDING,
        "the demo's recording is out of date: run this test with MAPVLM_UPDATE_DEMO_RECORDING=1"
    );
}

fn key(app: &mut App, code: KeyCode) -> Vec<Cmd> {
    app.update(Msg::Key(KeyEvent::new(code, KeyModifiers::NONE)))
}

/// Appends " Be brief." to the planner's prompt in the Prompt pane.
fn edit_planner_prompt(app: &mut App) {
    while app.focus != Pane::Prompt {
        key(app, KeyCode::Tab);
    }
    key(app, KeyCode::Char('3'));
    key(app, KeyCode::Enter);
    for c in " Be brief.".chars() {
        key(app, KeyCode::Char(c));
    }
    key(app, KeyCode::Esc);
}

/// Carries out the runs among `cmds` with `pipeline`, feeding every event to
/// the app; returns the events of the runs.
fn run_cmds(app: &mut App, pipeline: &dyn Pipeline, cmds: Vec<Cmd>) -> Vec<AgentEvent> {
    let mut seen = Vec::new();
    let models = ModelSlot::Unavailable("no models in this test".into());
    Headless::new(pipeline, models).run(app, cmds, &mut |msg| {
        if let Msg::Agent(_, event) = msg {
            seen.push(event.clone());
        }
    });
    seen
}

/// Each finished agent's whole output: its streamed pieces joined.
fn finished(events: &[AgentEvent]) -> BTreeMap<AgentRole, String> {
    let mut streamed: BTreeMap<AgentRole, String> = BTreeMap::new();
    let mut done = BTreeMap::new();
    for event in events {
        match event {
            AgentEvent::Token { role, text } => streamed.entry(*role).or_default().push_str(text),
            AgentEvent::Finished { role, .. } => {
                done.insert(*role, streamed.remove(role).unwrap_or_default());
            }
            _ => {}
        }
    }
    done
}

#[test]
fn the_demo_replays_byte_for_byte_with_no_provider() {
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "no models in this test"));
    let events = run_cmds(&mut app, &pipeline, cmds);
    let outputs = finished(&events);
    assert_eq!(outputs[&AgentRole::Skm], demo::SKM_OUTPUT);
    assert_eq!(outputs[&AgentRole::Gkm], demo::GKM_OUTPUT);
    assert_eq!(outputs[&AgentRole::Planner], demo::PLANNER_OUTPUT);
    let tokens = events
        .iter()
        .filter(|e| matches!(e, AgentEvent::Token { .. }))
        .count();
    assert!(
        tokens > 100,
        "the answers stream a word at a time: {tokens}"
    );
    assert_eq!(app.panes.plan.items, parse_steps(demo::PLANNER_OUTPUT));
    assert_eq!(app.panes.plan.items.len(), 7);
    assert!(app.panes.graph.kg.find("coffee machine").is_some());
    assert_eq!(app.runs.history.len(), 1);
    assert!(app
        .runs
        .agents
        .values()
        .take(3)
        .all(|v| v.status == AgentStatus::Done));
}

#[test]
fn editing_a_demo_prompt_says_which_provider_to_set() {
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "no models in this test"));
    run_cmds(&mut app, &pipeline, cmds);
    edit_planner_prompt(&mut app);
    let cmds = key(&mut app, KeyCode::Char('r'));
    assert!(matches!(&cmds[..], [Cmd::StartRun(r)] if r.agents == [AgentRole::Planner]));
    let Some(Cmd::StartRun(request)) = cmds.first() else {
        unreachable!()
    };
    let reason = pipeline.check(request).unwrap_err().to_string();
    assert!(
        reason.contains("Planner's prompt was edited")
            && reason.contains("Planner needs a provider")
            && reason.contains("OPENAI_API_KEY"),
        "{reason}"
    );
    app.update(Msg::Key(KeyEvent::new(
        KeyCode::Char('x'),
        KeyModifiers::NONE,
    )));

    let mut live = request.clone();
    live.settings.insert(
        AgentRole::Planner,
        AgentSettings::new(ProviderKind::Openai, "gpt-4o", 0.0, 512),
    );
    let reason = pipeline.check(&live).unwrap_err().to_string();
    assert!(
        reason.contains("Planner uses openai but no API key is set")
            && reason.contains("export OPENAI_API_KEY")
            && reason.contains("[agents.planner]"),
        "{reason}"
    );
}

/// A pipeline whose live agents ask `server` with the test key, caching
/// in `cache`.
fn live_pipeline(server: &MockServer, cache: &std::path::Path) -> AgentsPipeline {
    let uri = format!("{}/v1", server.uri());
    AgentsPipeline::new(
        ProviderConfig {
            file: ConfigFile::default(),
            path: None,
            env: Box::new(move |name| match name {
                "OPENAI_API_KEY" => Some(KEY.to_string()),
                "OPENAI_BASE_URL" => Some(uri.clone()),
                _ => None,
            }),
        },
        Some(ResponseCache::new(cache)),
        Pace::Instant,
    )
    .unwrap()
}

fn live_settings() -> AgentSettings {
    AgentSettings::new(ProviderKind::Openai, "test-model", 0.0, 321)
}

#[test]
fn a_live_run_streams_into_the_panes_and_an_edited_planner_prompt_asks_once() {
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let server = runtime.block_on(multi_agent_server(
        ProviderKind::Openai,
        true,
        Default::default(),
    ));
    let served = format!("{}/v1", server.uri());
    let cache_dir = tempfile::tempdir().unwrap();
    let pipeline = live_pipeline(&server, cache_dir.path());
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "no models in this test"));
    run_cmds(&mut app, &pipeline, cmds);
    assert!(
        runtime
            .block_on(server.received_requests())
            .unwrap()
            .is_empty(),
        "the demo's replay asks no server"
    );
    go_live(&mut app);

    let cmds = key(&mut app, KeyCode::Char('r'));
    let Some(Cmd::StartRun(request)) = cmds.first().cloned() else {
        panic!("no run: {:?}", app.messages.status)
    };
    let run = request.run;
    let (settings, events) = run_blocking(&pipeline, request).unwrap();
    // What the config layers resolved is what the workbench keeps: the
    // base URL from the environment, never the key.
    assert_eq!(settings[&AgentRole::Planner].base_url, served);
    assert!(settings.values().all(|s| s.api_key.is_none()));
    app.run_accepted(run, settings);
    let mut plan_sizes = Vec::new();
    for event in events.clone() {
        let planner_token = matches!(
            &event,
            AgentEvent::Token {
                role: AgentRole::Planner,
                ..
            }
        );
        let cmds = app.update(Msg::Agent(run, event));
        run_cmds(&mut app, &pipeline, cmds);
        if planner_token {
            plan_sizes.push(app.panes.plan.items.len());
        }
    }
    let outputs = finished(&events);
    assert_eq!(outputs[&AgentRole::Skm], SKM_TEXT);
    assert_eq!(outputs[&AgentRole::Planner], PLAN_TEXT);
    assert!(
        plan_sizes.len() > 3 && plan_sizes.first() < plan_sizes.last(),
        "the plan grows as the planner writes: {plan_sizes:?}"
    );
    assert_eq!(app.panes.plan.items, parse_steps(PLAN_TEXT));
    assert_eq!(app.runs.agents[&AgentRole::Gkm].output, GKM_TEXT);
    assert!(app.panes.graph.kg.find("sponge").is_some());
    assert_eq!(
        app.runs.agents[&AgentRole::Planner].status,
        AgentStatus::Done
    );
    assert_eq!(
        runtime.block_on(server.received_requests()).unwrap().len(),
        3
    );

    edit_planner_prompt(&mut app);
    assert_eq!(app.agents_to_run(false), [AgentRole::Planner]);
    let cmds = key(&mut app, KeyCode::Char('r'));
    let events = run_cmds(&mut app, &pipeline, cmds);
    let requests = runtime.block_on(server.received_requests()).unwrap();
    assert_eq!(requests.len(), 4, "SKM and GKM come from the cache");
    let last = String::from_utf8_lossy(&requests[3].body).to_string();
    assert!(last.contains(PLANNER_MARK) && last.contains("Be brief."));
    assert_eq!(finished(&events)[&AgentRole::Skm], SKM_TEXT);
    assert_eq!(app.runs.history.len(), 3);
    assert_eq!(app.panes.plan.items, parse_steps(PLAN_TEXT));
    let planner = app.runs.history[1].agents.last().unwrap();
    assert_eq!(
        (planner.role, planner.settings.base_url.as_str()),
        (AgentRole::Planner, served.as_str())
    );
    assert!(app.runs.history[1].prompts[&AgentRole::Planner].contains(PLANNER_MARK));
    let saved = serde_json::to_string(&app.runs.history).unwrap();
    assert!(!saved.contains(KEY), "no key in the run history");
}

/// The settings of every multi-agent role pointing at a live server.
/// `R` on live agents whose model has a price: the estimate is on the
/// status line before anything is sent, a second `R` sends every agent's
/// request once, and any other key in between sends nothing.
#[test]
fn a_priced_fresh_run_shows_its_estimate_and_sends_only_on_a_second_r() {
    use mapvlm::agents::config::Price;
    use mapvlm::agents::cost::PriceTable;

    let (runtime, server) = numbered_server();
    let cache_dir = tempfile::tempdir().unwrap();
    let pipeline = live_pipeline(&server, cache_dir.path());
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "no models in this test"));
    run_cmds(&mut app, &pipeline, cmds);
    let requests = || runtime.block_on(server.received_requests()).unwrap().len();
    go_live(&mut app);
    let price = Price {
        input_per_million: 2.5,
        output_per_million: 10.0,
        batch_input_per_million: None,
        batch_output_per_million: None,
    };
    let models = BTreeMap::from([("test-model".to_string(), price)]);
    app.work.prices =
        PriceTable::from_config(&BTreeMap::from([("openai".to_string(), models)])).unwrap();
    let status = |app: &App| {
        app.messages
            .status
            .as_ref()
            .map(|(text, _)| text.clone())
            .unwrap_or_default()
    };

    let cmds = key(&mut app, KeyCode::Char('R'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(requests(), 0, "nothing is sent before the second R");
    assert!(app.runs.active.is_none());
    let shown = status(&app);
    assert!(
        shown.contains("3 requests, ~$0.0") && shown.contains("R again sends"),
        "{shown}"
    );

    let cmds = key(&mut app, KeyCode::Char('j'));
    run_cmds(&mut app, &pipeline, cmds);
    let cmds = key(&mut app, KeyCode::Char('R'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(requests(), 0, "a key between the two R sends nothing");
    assert!(status(&app).contains("R again sends"), "priced again");

    let cmds = key(&mut app, KeyCode::Char('R'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(requests(), 3, "the second R asks each agent once");
    let run = app.runs.history.last().unwrap();
    assert!(
        run.agents.iter().all(|a| !a.cached),
        "every answer fresh: {:?}",
        run.agents
    );
}

/// A local server answering every request with [`Numbered`], on a runtime
/// of its own.
fn numbered_server() -> (tokio::runtime::Runtime, MockServer) {
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let server = runtime.block_on(async {
        let server = MockServer::start().await;
        wiremock::Mock::given(wiremock::matchers::method("POST"))
            .respond_with(Numbered::default())
            .mount(&server)
            .await;
        server
    });
    (runtime, server)
}

fn go_live(app: &mut App) {
    for role in [AgentRole::Skm, AgentRole::Gkm, AgentRole::Planner] {
        app.runs.agents.get_mut(&role).unwrap().settings = live_settings();
    }
}

#[test]
fn samples_ask_each_agent_n_times_keep_every_sample_and_reuse_them() {
    let (runtime, server) = numbered_server();
    let cache_dir = tempfile::tempdir().unwrap();
    let pipeline = live_pipeline(&server, cache_dir.path());
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "no models in this test"));
    run_cmds(&mut app, &pipeline, cmds);
    let requests = || runtime.block_on(server.received_requests()).unwrap();

    key(&mut app, KeyCode::Char('S'));
    assert_eq!(app.work.samples, 3);
    let cmds = key(&mut app, KeyCode::Char('R'));
    let Some(Cmd::PriceFreshRun(request)) = cmds.first() else {
        panic!("no run priced: {:?}", app.messages.status)
    };
    let refused = pipeline.check(request).unwrap_err().to_string();
    assert!(
        refused.starts_with("SKM answers from the demo's recording, which holds one sample"),
        "{refused}"
    );
    key(&mut app, KeyCode::Char('x'));

    go_live(&mut app);
    let cmds = key(&mut app, KeyCode::Char('R'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(requests().len(), 9, "3 samples of SKM, GKM and the Planner");
    let run = app.runs.history.last().unwrap().clone();
    assert_eq!(run.samples.len(), 2, "the samples after the first");
    assert_eq!(run.sample_scores().len(), 3, "every sample scored");
    let planners: Vec<String> = requests()
        .iter()
        .map(|r| String::from_utf8_lossy(&r.body).into_owned())
        .filter(|b| b.contains(PLANNER_MARK))
        .collect();
    let first_skm = run
        .agents
        .iter()
        .find(|a| a.role == AgentRole::Skm)
        .unwrap()
        .output_text()
        .to_string();
    let mut skms = vec![first_skm];
    for sample in &run.samples {
        assert!(sample.error.is_none(), "{:?}", sample.error);
        let output = |role| {
            sample
                .agents
                .iter()
                .find(|a| a.role == role)
                .map(|a| a.output_text().to_string())
                .unwrap_or_default()
        };
        skms.push(output(AgentRole::Skm));
        let gkm = &output(AgentRole::Gkm);
        let skm_mark = output(AgentRole::Skm)
            .rsplit("skm-answer-")
            .next()
            .unwrap()
            .trim_end_matches(')')
            .to_string();
        let gkm_mark = gkm.rsplit(' ').next().unwrap();
        assert!(
            planners
                .iter()
                .any(|b| b.contains(&format!("skm-answer-{skm_mark}")) && b.contains(gkm_mark)),
            "sample {}'s Planner read its own SKM and GKM",
            sample.sample
        );
    }
    skms.sort();
    skms.dedup();
    assert_eq!(skms.len(), 3, "each sample its own answer");

    let cmds = key(&mut app, KeyCode::Char('r'));
    assert!(cmds.is_empty(), "nothing changed: r asks for nothing");
    let cmds = key(&mut app, KeyCode::Char('R'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(
        requests().len(),
        18,
        "R asks every agent of every sample afresh, past the cache"
    );
    let fresh = app.runs.history.last().unwrap().clone();
    assert_eq!(fresh.samples.len(), 2);

    key(&mut app, KeyCode::Char('S'));
    assert_eq!(app.work.samples, 5);
    let cmds = key(&mut app, KeyCode::Char('r'));
    run_cmds(&mut app, &pipeline, cmds);
    assert_eq!(
        requests().len(),
        24,
        "r asks only for the two new samples, the others from the cache"
    );
    let more = app.runs.history.last().unwrap();
    for (old, new) in fresh.samples.iter().zip(&more.samples) {
        assert_eq!(
            old.plan, new.plan,
            "sample k reused as sample k, R's answers cached"
        );
    }
    assert_eq!(app.runs.history.last().unwrap().samples.len(), 4);
    let saved = serde_json::to_value(app.to_session()).unwrap();
    assert_eq!(saved["samples"], 5);
    assert_eq!(
        saved["runs"].as_array().unwrap().last().unwrap()["samples"]
            .as_array()
            .unwrap()
            .len(),
        4
    );
}

/// The Prompt pane's footer says what the selected agent's last run on
/// this task was: a dataset task's configured agents, before anything ran,
/// are "not run yet" (not "changed"); after a run its keys; after an edit
/// "changed"; after a refused request "failed".
#[test]
fn the_prompt_footer_names_the_agents_last_run_never_a_change_before_one() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
    let (dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
    let (runtime, server) = numbered_server();
    let cache_dir = tempfile::tempdir().unwrap();
    let pipeline = live_pipeline(&server, cache_dir.path());
    let configured = [AgentRole::Skm, AgentRole::Gkm, AgentRole::Planner]
        .into_iter()
        .map(|role| (role, live_settings()))
        .collect();
    let (mut app, cmds) = App::new(AppInit {
        dataset: Some(dataset),
        configured,
        ..AppInit::demo((200, 60), "no models in this test")
    });
    run_cmds(&mut app, &pipeline, cmds);
    while app.focus != Pane::Prompt {
        key(&mut app, KeyCode::Tab);
    }
    key(&mut app, KeyCode::Char('3'));
    let footer = |app: &mut App| {
        let screen = screen_of(app);
        let said = [
            "not run yet on this task",
            "changed since its last run",
            "its last run failed",
            "Enter edits · ←/→ agent",
        ];
        let found: Vec<&str> = said.into_iter().filter(|s| screen.contains(s)).collect();
        assert_eq!(
            found.len(),
            1,
            "one state in the footer: {found:?}\n{screen}"
        );
        found[0]
    };
    assert_eq!(footer(&mut app), "not run yet on this task");

    let cmds = key(&mut app, KeyCode::Char('r'));
    run_cmds(&mut app, &pipeline, cmds);
    let requests = || runtime.block_on(server.received_requests()).unwrap().len();
    assert_eq!(
        requests(),
        3,
        "r ran every agent: {:?}",
        app.messages.status
    );
    assert_eq!(footer(&mut app), "Enter edits · ←/→ agent");

    edit_planner_prompt(&mut app);
    assert_eq!(footer(&mut app), "changed since its last run");

    runtime.block_on(async {
        server.reset().await;
        wiremock::Mock::given(wiremock::matchers::method("POST"))
            .respond_with(ResponseTemplate::new(401).set_body_string("no"))
            .mount(&server)
            .await;
    });
    let cmds = key(&mut app, KeyCode::Char('r'));
    run_cmds(&mut app, &pipeline, cmds);
    assert!(matches!(
        app.runs.agents[&AgentRole::Planner].status,
        AgentStatus::Failed(_)
    ));
    assert_eq!(footer(&mut app), "its last run failed");
}

/// Until a dataset task's image is read the Scene pane says it is being
/// read, never that the task has none; once read, it is drawn.
#[test]
fn a_dataset_tasks_image_is_being_read_until_it_is_drawn_never_missing() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
    let (dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
    let (mut app, cmds) = App::new(AppInit {
        dataset: Some(dataset),
        ..AppInit::demo((200, 60), "no models in this test")
    });
    let before = screen_of(&mut app);
    assert!(
        before.contains("reading the image…") && !before.contains("no image for this task"),
        "{before}"
    );
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
    run_cmds(&mut app, &pipeline, cmds);
    let after = screen_of(&mut app);
    assert!(
        !after.contains("reading the image…") && !after.contains("no image for this task"),
        "{after}"
    );
}

/// The workbench drawn as text at its size.
fn screen_of(app: &mut App) -> String {
    use mapvlm::workbench::graphics::Graphics;
    use mapvlm::workbench::headless::prepare_image;
    use ratatui::{backend::TestBackend, Terminal};
    let (w, h) = app.size;
    prepare_image(app, &Graphics::halfblocks());
    let mut terminal = Terminal::new(TestBackend::new(w, h)).unwrap();
    terminal
        .draw(|f| mapvlm::workbench::render::render(f, app))
        .unwrap();
    terminal.backend().to_string()
}
