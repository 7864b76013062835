//! A recorded session: the shipped prompts make a model produce SKM's
//! triples, GKM's description and the Planner's steps in the shapes the
//! pipeline reads. No real provider is reachable here, so the answers in
//! tests/fixtures/handwritten/ were written by hand and recorded through a
//! local server (see its README).

use crate::agents_support;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use agents_support::*;
use mapvlm::agents::config::{ConfigFile, FlagLayers, Settings};
use mapvlm::agents::pipeline::{PlanInput, Runner, Source};
use mapvlm::agents::prompts::PromptSet;
use mapvlm::agents::replay::{Pace, Recording};
use mapvlm::agents::{Approach, ProviderKind};
use wiremock::MockServer;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

fn session_file() -> PathBuf {
    fixtures().join("multi-image-session.json")
}

fn handwritten(name: &str) -> String {
    std::fs::read_to_string(fixtures().join("handwritten").join(name)).unwrap()
}

fn input() -> PlanInput {
    PlanInput {
        task: "Place a wet sponge inside the bathtub".into(),
        image: Some(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/alfred30/images/7.jpg"),
        ),
        table: None,
    }
}

/// The paper's setting (temperature 0), the image sent as it is.
fn paper_settings(base_url: &str) -> Settings {
    let mut flags = FlagLayers::default();
    flags.all.provider = Some(ProviderKind::Openai);
    flags.all.base_url = Some(base_url.to_string());
    flags.all.model = Some("gpt-4o".into());
    flags.max_image_edge = Some(1400);
    Settings::resolve(&ConfigFile::default(), &|_| None, &flags).unwrap()
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "re-records tests/fixtures/multi-image-session.json"]
async fn record_hand_written_session() {
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    for (mark, file) in [
        (SKM_MARK, "skm.txt"),
        (GKM_MARK, "gkm.txt"),
        (PLANNER_MARK, "planner.txt"),
    ] {
        let text = handwritten(file);
        answer(
            &server,
            provider,
            mark,
            streamed(provider, &pieces(&text, 9), true),
        )
        .await;
    }
    let recording = Arc::new(Mutex::new(Recording::new(
        "HAND-WRITTEN answers (tests/fixtures/handwritten), served by a local wiremock server: no real provider was reachable",
    )));
    let runner = Runner::new(
        paper_settings(&format!("{}/v1", server.uri())),
        PromptSet::load(None).unwrap(),
        Source::Live,
    )
    .with_recorder(recording.clone());
    let (record, _) = plan_with_events(&runner, Approach::MultiImage, &input()).await;
    assert_eq!(record.first_error(), None);
    recording.lock().unwrap().save(&session_file()).unwrap();
}

#[tokio::test]
async fn recorded_session_gives_triples_a_description_and_steps() {
    let recording = Recording::load(&session_file()).unwrap();
    assert!(recording.note.starts_with("HAND-WRITTEN"));
    let runner = Runner::new(
        paper_settings("http://unreachable.invalid/v1"),
        PromptSet::load(None).unwrap(),
        Source::Replay(Arc::new(recording), Pace::Instant),
    );
    let (record, _) = plan_with_events(&runner, Approach::MultiImage, &input()).await;
    assert_eq!(
        record.first_error(),
        None,
        "the shipped prompts changed: re-record (see tests/fixtures/handwritten/README.md)"
    );
    let triples = record.triples.unwrap();
    assert_eq!(
        triples.triples.len(),
        handwritten("skm.txt").lines().count()
    );
    assert!(triples.unparsed.is_empty());
    let graph = record.graph.unwrap();
    let sponge = graph.find("green sponge").unwrap();
    assert_eq!(
        graph.nodes[graph.outgoing(sponge).next().unwrap().to],
        "vanity"
    );
    assert_eq!(
        record.agents[1].output.as_deref(),
        Some(handwritten("gkm.txt").as_str())
    );
    assert_eq!(record.steps.len(), 6);
    assert_eq!(record.steps[0], "Walk forward to the vanity.");
    assert!(record.steps.iter().all(|s| s.ends_with('.')));
}

#[test]
fn a_runner_prepares_a_tasks_image_once_for_every_stage() {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("scene.jpg");
    std::fs::copy(input().image.unwrap(), &image).unwrap();
    let task = PlanInput {
        image: Some(image.clone()),
        ..input()
    };
    let runner = || {
        Runner::new(
            paper_settings("http://unreachable.invalid/v1"),
            PromptSet::load(None).unwrap(),
            Source::Live,
        )
    };
    let sent = |stage: mapvlm::agents::pipeline::Stage| -> Vec<String> {
        stage
            .requests
            .iter()
            .flat_map(|r| r.request.images.iter().map(|i| i.sha256.clone()))
            .collect()
    };
    let first = runner();
    let estimate = sent(first.next_stage(Approach::MultiImage, &task, 0).unwrap());
    assert_eq!(estimate.len(), 2, "SKM and GKM see the scene");
    // The file is no image any more: the runner that prepared it does not
    // read it again, a new one does and refuses.
    std::fs::write(&image, b"not an image").unwrap();
    let round = sent(first.next_stage(Approach::MultiImage, &task, 0).unwrap());
    assert_eq!(round, estimate);
    let fresh = runner()
        .next_stage(Approach::MultiImage, &task, 0)
        .unwrap_err();
    assert!(fresh.to_string().contains("scene.jpg"), "{fresh}");
}
