//! The providers and the pipeline against a local server (wiremock) that
//! speaks both the OpenAI and the Anthropic API.

use crate::agents_support;

use std::time::{Duration, Instant};

use agents_support::*;
use base64::Engine;
use mapvlm::agents::cache::ResponseCache;
use mapvlm::agents::pipeline::AgentEvent;
use mapvlm::agents::{AgentRole, Approach, ProviderKind};
use serde_json::Value;
use wiremock::matchers::{body_string_contains, method, path};
use wiremock::{Mock, MockServer, ResponseTemplate};

const BOTH: [ProviderKind; 2] = [ProviderKind::Openai, ProviderKind::Anthropic];

fn bodies(requests: &[wiremock::Request]) -> Vec<Value> {
    requests
        .iter()
        .map(|r| serde_json::from_slice(&r.body).unwrap())
        .collect()
}

#[tokio::test]
async fn requests_carry_the_image_the_settings_and_the_key() {
    for provider in BOTH {
        let dir = tempfile::tempdir().unwrap();
        let image = scene(dir.path());
        let server = multi_agent_server(provider, false, Duration::ZERO).await;
        let runner = runner(settings(&server, provider, false));
        let (record, _) =
            plan_with_events(&runner, Approach::MultiImage, &image_input(image.clone())).await;
        assert_eq!(record.first_error(), None);
        let requests = server.received_requests().await.unwrap();
        assert_eq!(requests.len(), 3, "{provider:?}");
        let png = base64::engine::general_purpose::STANDARD.encode(std::fs::read(&image).unwrap());
        let mut with_image = 0;
        for (request, body) in requests.iter().zip(bodies(&requests)) {
            assert_eq!(body["model"], "test-model");
            assert_eq!(body["temperature"], 0.25);
            assert_eq!(body["max_tokens"], 321);
            assert_eq!(body["stream"], false);
            let text = body.to_string();
            match provider {
                ProviderKind::Openai => {
                    assert_eq!(
                        request.headers["authorization"],
                        format!("Bearer {KEY}").as_str()
                    );
                    if text.contains(&format!("data:image/png;base64,{png}")) {
                        with_image += 1;
                    }
                }
                ProviderKind::Anthropic => {
                    assert_eq!(request.headers["x-api-key"], KEY);
                    assert_eq!(request.headers["anthropic-version"], "2023-06-01");
                    let content = &body["messages"][0]["content"];
                    if content[0]["source"]["data"] == png.as_str() {
                        assert_eq!(content[0]["source"]["media_type"], "image/png");
                        with_image += 1;
                    }
                }
                ProviderKind::Replay => panic!("the recording is not served over HTTP"),
            }
            assert!(text.contains("Place a wet sponge inside the bathtub"));
        }
        assert_eq!(
            with_image, 2,
            "both miners see the image, the planner does not ({provider:?})"
        );
        let planner = bodies(&requests)
            .into_iter()
            .find(|b| b.to_string().contains(PLANNER_MARK))
            .unwrap()
            .to_string();
        assert!(planner.contains("(sponge, on, bathtub)") && planner.contains("green sponge lies"));
    }
}

#[tokio::test]
async fn miners_run_concurrently_and_the_planner_after_both() {
    for provider in BOTH {
        let dir = tempfile::tempdir().unwrap();
        let server = multi_agent_server(provider, true, Duration::from_millis(500)).await;
        let runner = runner(settings(&server, provider, true));
        let start = Instant::now();
        let (record, events) = plan_with_events(
            &runner,
            Approach::MultiImage,
            &image_input(scene(dir.path())),
        )
        .await;
        let elapsed = start.elapsed();
        assert_eq!(record.first_error(), None);
        assert!(
            elapsed < Duration::from_millis(1200 + 500),
            "multi-image took {elapsed:?} with 500 ms answers ({provider:?})"
        );
        let position =
            |wanted: &dyn Fn(&AgentEvent) -> bool| events.iter().position(wanted).unwrap();
        let started = |role| position(&move |e| *e == AgentEvent::Started { role });
        let finished = |role: AgentRole| {
            position(&move |e| matches!(e, AgentEvent::Finished { role: r, .. } if *r == role))
        };
        assert!(started(AgentRole::Gkm) < finished(AgentRole::Skm));
        assert!(started(AgentRole::Skm) < finished(AgentRole::Gkm));
        assert!(
            started(AgentRole::Planner) > finished(AgentRole::Skm).max(finished(AgentRole::Gkm))
        );
        assert_eq!(record.steps.len(), 6);
        assert_eq!(
            record.steps[1],
            "Pick up the green sponge from the bathtub."
        );
        assert_eq!(record.triples.as_ref().unwrap().triples.len(), 3);
        assert_eq!(record.graph.as_ref().unwrap().nodes.len(), 6);
    }
}

#[tokio::test]
async fn streaming_assembles_the_same_text_as_a_whole_answer() {
    let text = "1. Walk to the sink — it is ahead.\n2. Pick up the mug (the blue one).\n3. Put the mug in the sink.";
    for provider in BOTH {
        let mut outputs = Vec::new();
        for stream in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            let server = MockServer::start().await;
            let response = if stream {
                streamed(provider, &pieces(text, 5), true)
            } else {
                whole(provider, text)
            };
            answer(&server, provider, PLANNER_MARK, response).await;
            let runner = runner(settings(&server, provider, stream));
            let (record, events) = plan_with_events(
                &runner,
                Approach::SingleImage,
                &image_input(scene(dir.path())),
            )
            .await;
            let tokens: String = events
                .iter()
                .filter_map(|e| match e {
                    AgentEvent::Token { text, .. } => Some(text.as_str()),
                    _ => None,
                })
                .collect();
            assert_eq!(tokens, text);
            let single = &record.agents[0];
            assert_eq!(single.usage.input_tokens, 100);
            assert_eq!(single.usage.output_tokens, 20);
            outputs.push(single.output.clone().unwrap());
        }
        assert_eq!(outputs[0], outputs[1]);
        assert_eq!(outputs[0], text);
    }
}

#[tokio::test]
async fn too_many_requests_is_retried_after_the_servers_delay() {
    for provider in BOTH {
        let dir = tempfile::tempdir().unwrap();
        let server = MockServer::start().await;
        Mock::given(method("POST"))
            .and(path(endpoint(provider)))
            .respond_with(ResponseTemplate::new(429).insert_header("retry-after", "1"))
            .up_to_n_times(1)
            .with_priority(1)
            .mount(&server)
            .await;
        answer(
            &server,
            provider,
            PLANNER_MARK,
            whole(provider, "1. Walk to the sink."),
        )
        .await;
        let runner = runner(settings(&server, provider, false));
        let start = Instant::now();
        let (record, _) = plan_with_events(
            &runner,
            Approach::SingleImage,
            &image_input(scene(dir.path())),
        )
        .await;
        assert_eq!(record.steps, ["Walk to the sink."]);
        assert!(
            start.elapsed() >= Duration::from_secs(1),
            "Retry-After honoured"
        );
        assert_eq!(server.received_requests().await.unwrap().len(), 2);
    }
}

#[tokio::test]
async fn a_refused_key_is_not_retried_and_says_so() {
    for provider in BOTH {
        let dir = tempfile::tempdir().unwrap();
        let server = MockServer::start().await;
        let echo = format!("{{\"error\": {{\"message\": \"Incorrect API key provided: {KEY}\"}}}}");
        answer(
            &server,
            provider,
            PLANNER_MARK,
            ResponseTemplate::new(401).set_body_string(echo),
        )
        .await;
        let runner = runner(settings(&server, provider, false));
        let (record, events) = plan_with_events(
            &runner,
            Approach::SingleImage,
            &image_input(scene(dir.path())),
        )
        .await;
        let (_, error) = record.first_error().unwrap();
        assert!(error.contains("refused the API key"), "{error}");
        assert!(!error.contains(KEY));
        assert!(events
            .iter()
            .any(|e| matches!(e, AgentEvent::Failed { .. })));
        assert_eq!(server.received_requests().await.unwrap().len(), 1);
    }
}

/// Makes GKM fail in the way `gkm` says and checks that SKM's result stays,
/// GKM's error reads `expect`, and the Planner did not run.
async fn gkm_fails(
    provider: ProviderKind,
    gkm: ResponseTemplate,
    timeout: Option<f64>,
    expect: &str,
) {
    let dir = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    answer(&server, provider, SKM_MARK, whole(provider, SKM_TEXT)).await;
    answer(&server, provider, GKM_MARK, gkm).await;
    answer(&server, provider, PLANNER_MARK, whole(provider, PLAN_TEXT)).await;
    let mut settings = settings(&server, provider, true);
    if let Some(seconds) = timeout {
        settings.http.total_timeout = Duration::from_secs_f64(seconds);
    }
    let (record, events) = plan_with_events(
        &runner(settings),
        Approach::MultiImage,
        &image_input(scene(dir.path())),
    )
    .await;
    let by_role = |role| record.agents.iter().find(|a| a.role == role).unwrap();
    assert_eq!(
        by_role(AgentRole::Skm).output.as_deref(),
        Some(SKM_TEXT),
        "{provider:?} {expect} {:?}",
        by_role(AgentRole::Skm).error
    );
    assert_eq!(record.triples.as_ref().unwrap().triples.len(), 3);
    let error = by_role(AgentRole::Gkm).error.clone().unwrap_or_default();
    assert!(
        error.contains(expect),
        "{provider:?}: `{error}` lacks `{expect}`"
    );
    assert_eq!(
        by_role(AgentRole::Planner).error.as_deref(),
        Some("not run: gkm failed")
    );
    assert!(record.steps.is_empty());
    assert!(events.iter().any(|e| matches!(e,
        AgentEvent::Failed { role: AgentRole::Gkm, error: e, .. } if *e == error)));
}

#[tokio::test]
async fn each_failure_ends_only_its_agent_with_a_clear_error() {
    for provider in BOTH {
        let slow = streamed(provider, &["late"], true).set_delay(Duration::from_secs(3));
        gkm_fails(provider, slow, Some(0.5), "timed out after 0.5 s").await;
        let cut = streamed(provider, &["The sponge is", " on the"], false);
        gkm_fails(
            provider,
            cut,
            None,
            "stream ended before the answer was complete (20 characters received)",
        )
        .await;
        let garbage = ResponseTemplate::new(200)
            .insert_header("content-type", "text/event-stream")
            .set_body_string("data: {not json\n\n");
        gkm_fails(provider, garbage, None, "invalid JSON in stream event").await;
        gkm_fails(
            provider,
            streamed(provider, &[], true),
            None,
            "returned an empty answer (model test-model)",
        )
        .await;
    }
    let dir = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    answer(
        &server,
        ProviderKind::Openai,
        PLANNER_MARK,
        ResponseTemplate::new(200).set_body_string("<html>oops"),
    )
    .await;
    let runner = runner(settings(&server, ProviderKind::Openai, false));
    let (record, _) = plan_with_events(
        &runner,
        Approach::SingleImage,
        &image_input(scene(dir.path())),
    )
    .await;
    assert!(
        record.first_error().unwrap().1.contains("invalid JSON"),
        "{:?}",
        record.first_error()
    );
}

#[tokio::test]
async fn json_schema_is_asked_for_and_dropped_when_the_server_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    Mock::given(method("POST"))
        .and(body_string_contains("response_format"))
        .respond_with(
            ResponseTemplate::new(400)
                .set_body_string("{\"error\": {\"message\": \"response_format not supported\"}}"),
        )
        .with_priority(1)
        .mount(&server)
        .await;
    let provider = ProviderKind::Openai;
    answer(&server, provider, SKM_MARK, whole(provider, SKM_TEXT)).await;
    answer(&server, provider, GKM_MARK, whole(provider, GKM_TEXT)).await;
    answer(&server, provider, PLANNER_MARK, whole(provider, PLAN_TEXT)).await;
    let (record, _) = plan_with_events(
        &runner(settings(&server, provider, false)),
        Approach::MultiImage,
        &image_input(scene(dir.path())),
    )
    .await;
    assert_eq!(record.first_error(), None);
    let schema_asked = bodies(&server.received_requests().await.unwrap())
        .iter()
        .filter(|b| b["response_format"]["json_schema"]["schema"]["required"][0] == "triples")
        .count();
    assert_eq!(schema_asked, 1, "only SKM asks for the schema, once");
    assert_eq!(server.received_requests().await.unwrap().len(), 4);
}

#[tokio::test]
async fn an_unchanged_second_run_is_served_from_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ResponseCache::new(dir.path().join("cache"));
    let image = scene(dir.path());
    let server = multi_agent_server(ProviderKind::Openai, true, Duration::ZERO).await;
    let settings = settings(&server, ProviderKind::Openai, true);
    let first = runner(settings.clone()).with_cache(cache.clone());
    let (one, _) =
        plan_with_events(&first, Approach::MultiImage, &image_input(image.clone())).await;
    assert_eq!(server.received_requests().await.unwrap().len(), 3);
    let second = runner(settings.clone()).with_cache(cache.clone());
    let (two, events) =
        plan_with_events(&second, Approach::MultiImage, &image_input(image.clone())).await;
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        3,
        "no new request"
    );
    assert!(two.agents.iter().all(|a| a.cached));
    assert_eq!(one.steps, two.steps);
    assert_eq!(
        one.agents.iter().map(|a| &a.output).collect::<Vec<_>>(),
        two.agents.iter().map(|a| &a.output).collect::<Vec<_>>()
    );
    assert!(events
        .iter()
        .any(|e| matches!(e, AgentEvent::Finished { cached: true, .. })));
    let mut warmer = settings;
    warmer
        .agents
        .get_mut(&AgentRole::Planner)
        .unwrap()
        .temperature = 0.7;
    let (_, _) = plan_with_events(
        &runner(warmer).with_cache(cache),
        Approach::MultiImage,
        &image_input(image),
    )
    .await;
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        4,
        "only the changed agent runs again"
    );
}
