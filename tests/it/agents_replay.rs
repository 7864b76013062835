//! Recording and replay, and the API key's absence from every file, record,
//! log line and error message.

use crate::agents_support;

use std::collections::BTreeMap;
use std::io::Write;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use agents_support::*;
use mapvlm::agents::cache::ResponseCache;
use mapvlm::agents::pipeline::{AgentEvent, PlanRecord, Runner, Source};
use mapvlm::agents::prompts::PromptSet;
use mapvlm::agents::replay::{Pace, Recording};
use mapvlm::agents::{Approach, ProviderKind};
use wiremock::{MockServer, ResponseTemplate};

/// A record as JSON with the measured times taken out.
fn without_times(record: &PlanRecord) -> String {
    let mut record = record.clone();
    record.elapsed_ms = 0;
    for agent in &mut record.agents {
        agent.elapsed_ms = 0;
    }
    serde_json::to_string_pretty(&record).unwrap()
}

/// Each agent's pieces in the order they arrived (the two miners interleave
/// differently from run to run).
fn tokens(events: &[AgentEvent]) -> BTreeMap<String, Vec<String>> {
    let mut pieces: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for event in events {
        if let AgentEvent::Token { role, text } = event {
            pieces
                .entry(role.to_string())
                .or_default()
                .push(text.clone());
        }
    }
    pieces
}

#[tokio::test]
async fn replay_reproduces_a_recorded_run_byte_for_byte() {
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        let dir = tempfile::tempdir().unwrap();
        let image = scene(dir.path());
        let server = multi_agent_server(provider, true, Duration::from_millis(300)).await;
        let settings = settings(&server, provider, true);
        let recording = Arc::new(Mutex::new(Recording::new("test")));
        let live = runner(settings.clone()).with_recorder(recording.clone());
        let (recorded, live_events) =
            plan_with_events(&live, Approach::MultiImage, &image_input(image.clone())).await;
        let file = dir.path().join("session.json");
        recording.lock().unwrap().save(&file).unwrap();
        drop(server);

        let loaded = Recording::load(&file).unwrap();
        assert_eq!(loaded.answers.len(), 3);
        let replay = Runner::new(
            settings,
            PromptSet::load(None).unwrap(),
            Source::Replay(Arc::new(loaded), Pace::AsRecorded),
        );
        let start = Instant::now();
        let (replayed, replay_events) =
            plan_with_events(&replay, Approach::MultiImage, &image_input(image)).await;
        assert!(
            start.elapsed() >= Duration::from_millis(600),
            "streamed at the recorded pace"
        );
        assert_eq!(without_times(&replayed), without_times(&recorded));
        assert_eq!(tokens(&replay_events), tokens(&live_events));
        assert!(tokens(&replay_events).values().all(|p| p.len() > 5));
    }
}

#[tokio::test]
async fn a_missing_answer_in_a_recording_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let replay = Runner::new(
        settings(&server, ProviderKind::Openai, true),
        PromptSet::load(None).unwrap(),
        Source::Replay(Arc::new(Recording::new("empty")), Pace::Instant),
    );
    let (record, _) = plan_with_events(
        &replay,
        Approach::SingleImage,
        &image_input(scene(dir.path())),
    )
    .await;
    let (_, error) = record.first_error().unwrap();
    assert!(
        error.contains("the recording has no answer") && error.contains("record it again"),
        "{error}"
    );
}

#[derive(Clone, Default)]
struct Logs(Arc<Mutex<Vec<u8>>>);

impl Write for Logs {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[tokio::test]
async fn the_key_never_appears_in_a_file_a_record_a_log_or_an_error() {
    let logs = Logs::default();
    let writer = logs.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_max_level(tracing::Level::TRACE)
        .with_writer(move || writer.clone())
        .finish();
    let _guard = tracing::subscriber::set_default(subscriber);

    let dir = tempfile::tempdir().unwrap();
    let image = scene(dir.path());
    let cache = ResponseCache::new(dir.path().join("cache"));
    let recording = Arc::new(Mutex::new(Recording::new("test")));
    let echo = format!("{{\"error\": {{\"message\": \"bad key {KEY}\"}}}}");
    let stream_error = format!("data: {{\"error\": {{\"message\": \"quota for {KEY}\"}}}}\n\n");
    let mut texts = Vec::new();
    for provider in [ProviderKind::Openai, ProviderKind::Anthropic] {
        let good = multi_agent_server(provider, true, Duration::ZERO).await;
        let bad = MockServer::start().await;
        answer(
            &bad,
            provider,
            SKM_MARK,
            ResponseTemplate::new(401).set_body_string(echo.clone()),
        )
        .await;
        answer(
            &bad,
            provider,
            GKM_MARK,
            ResponseTemplate::new(503).set_body_string(echo.clone()),
        )
        .await;
        let worse = MockServer::start().await;
        answer(
            &worse,
            provider,
            PLANNER_MARK,
            ResponseTemplate::new(400).set_body_string(echo.clone()),
        )
        .await;
        answer(
            &worse,
            provider,
            SKM_MARK,
            ResponseTemplate::new(200)
                .insert_header("content-type", "text/event-stream")
                .set_body_string(stream_error.clone()),
        )
        .await;
        for (server, approach) in [
            (&good, Approach::MultiImage),
            (&bad, Approach::MultiImage),
            (&worse, Approach::SingleImage),
            (&worse, Approach::MultiImage),
        ] {
            let mut runner =
                runner(settings(server, provider, true)).with_recorder(recording.clone());
            if std::ptr::eq(server, &good) {
                runner = runner.with_cache(cache.clone());
            }
            let (record, events) =
                plan_with_events(&runner, approach, &image_input(image.clone())).await;
            texts.push(serde_json::to_string(&record).unwrap());
            texts.push(format!("{record:?} {events:?} {runner:?}"));
        }
    }
    let errors = texts.iter().filter(|t| t.contains("\"error\":\"")).count();
    assert!(errors >= 4, "the failing runs produced errors");
    assert!(
        texts.iter().any(|t| t.contains("bad key [redacted]")),
        "the server's message is kept, redacted"
    );
    let file = dir.path().join("session.json");
    recording.lock().unwrap().save(&file).unwrap();
    texts.push(std::fs::read_to_string(&file).unwrap());
    let mut cache_files = 0;
    for shard in std::fs::read_dir(cache.dir()).unwrap() {
        for entry in std::fs::read_dir(shard.unwrap().path()).unwrap() {
            texts.push(std::fs::read_to_string(entry.unwrap().path()).unwrap());
            cache_files += 1;
        }
    }
    assert_eq!(cache_files, 6, "three answers a provider were cached");
    let logged = String::from_utf8(logs.0.lock().unwrap().clone()).unwrap();
    assert!(
        logged.contains("retrying") && logged.contains("agent failed"),
        "{logged}"
    );
    texts.push(logged);
    for text in &texts {
        assert!(!text.contains(KEY), "the key leaked into: {text}");
        assert!(!text.contains("Very-Secret"));
    }
}
