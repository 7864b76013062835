//! Configured providers by default, end to end: a user's config file sends
//! the agents to a local OpenAI-compatible server (wiremock, in this test
//! process), and the real binary runs against it, in tmux for the
//! workbench.

mod common;

use std::time::Duration;

use common::server::{self, LocalServer, GKM_ANSWER};
use common::workbench::{score_on, UserHome, Workbench, LOCAL_MODEL};
use mapvlm::agents::AgentRole;

/// How long the server holds each answer back: long enough that two
/// requests less than this apart were both waiting at once.
const HOLD: Duration = Duration::from_millis(1500);

/// alfred30, beside the repository.
fn alfred30() -> String {
    common::shared().join("data/alfred30").display().to_string()
}

#[test]
fn plan_runs_on_the_config_files_provider_with_the_miners_at_once() {
    let server = LocalServer::start();
    server.delay_answers(HOLD);
    let home = UserHome::new();
    home.point_at(&server);
    let image = common::shared().join("data/alfred30/images/7.jpg");
    let out = home
        .command()
        .args([
            "plan",
            "--task",
            "Place a wet sponge inside the bathtub",
            "--json",
        ])
        .arg("--image")
        .arg(&image)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", common::stderr(&out));
    let requests = server.requests();
    let (skm, gkm) = (
        server::only(&requests, AgentRole::Skm),
        server::only(&requests, AgentRole::Gkm),
    );
    let planner = server::only(&requests, AgentRole::Planner);
    assert!(
        server::overlapped(&skm, &gkm, HOLD),
        "SKM and GKM were asked one after the other"
    );
    assert!(
        planner.at >= skm.at.max(gkm.at) + HOLD,
        "the planner waits for both"
    );
    assert!(planner.text().contains(GKM_ANSWER));
    assert_eq!(planner.body["model"], LOCAL_MODEL);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        json.to_string()
            .contains("Wet the sponge under the faucet."),
        "{json}"
    );
}

#[test]
fn the_first_key_r_on_a_dataset_task_runs_every_agent_on_the_configured_server() {
    let server = LocalServer::start();
    server.delay_answers(HOLD);
    let home = UserHome::new();
    home.point_at(&server);
    let dataset = alfred30();
    let workbench = Workbench::start("first-r", &home, (200, 60), &["--dataset", &dataset]);
    let configured = format!("SKM·GKM·Planner openai/{LOCAL_MODEL}");
    workbench.wait_for("the dataset task on the configured provider", |s| {
        s.contains("Place a wet sponge inside the bathtub") && s.contains(&configured)
    });
    workbench.keys(&["r"]);
    let requests = server.wait_for_requests(2);
    assert_eq!(
        server::roles(&requests[..2])
            .iter()
            .filter(|r| **r != AgentRole::Planner)
            .count(),
        2,
        "SKM and GKM first: {:?}",
        server::roles(&requests)
    );
    assert!(
        server::overlapped(&requests[0], &requests[1], HOLD),
        "SKM and GKM were asked one after the other"
    );
    let screen = workbench.wait_for("the plan, scored", |s| {
        s.contains("run 1 finished")
            && s.contains("Wet the sponge under the faucet.")
            && !s.contains("scoring…")
            && score_on(s, "KAS").is_some()
            && score_on(s, "PG2S").is_some()
    });
    assert!(!screen.contains("needs a provider"), "{screen}");
    let requests = server.requests();
    assert_eq!(
        server::roles(&requests).len(),
        3,
        "{:?}",
        server::roles(&requests)
    );
    let planner = server::only(&requests, AgentRole::Planner);
    assert!(planner.text().contains(GKM_ANSWER));
    assert!(requests.iter().all(|r| r.body["model"] == LOCAL_MODEL));
    assert_eq!(workbench.quit(), "0");

    let session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(home.session_file()).unwrap()).unwrap();
    let run = &session["runs"][0];
    assert!(run["scores"]["kas"].is_number(), "{run}");
    let providers: Vec<&str> = run["agents"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["provider"].as_str().unwrap_or_default())
        .collect();
    assert_eq!(providers, ["openai"; 3], "{run}");
}
