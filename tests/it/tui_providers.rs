//! Configured providers by default and prompt sets, end to end: a user's
//! config file sends the agents to a local OpenAI-compatible server
//! (wiremock, in this test process), and the real binary runs against it,
//! in tmux for the workbench.

use crate::common;

use std::time::Duration;

use common::server::{self, LocalServer, GKM_ANSWER};
use common::workbench::{score_on, UserHome, Workbench, LOCAL_MODEL};
use mapvlm::agents::AgentRole;

/// How long the server holds each answer back: long enough that two
/// requests less than this apart were both waiting at once.
const HOLD: Duration = Duration::from_millis(1500);

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
    let workbench = Workbench::start_on_alfred30("first-r", &home);
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

#[test]
fn eval_with_a_saved_prompt_set_sends_its_prompts_and_records_their_versions() {
    use mapvlm::agents::prompt_sets;
    use mapvlm::agents::prompts::{PromptSet, Template};
    use mapvlm::agents::Approach;

    let server = LocalServer::start();
    let home = UserHome::new();
    home.point_at(&server);
    let shipped = PromptSet::load(None).unwrap();
    let skm = shipped.get(Approach::MultiImage, AgentRole::Skm).unwrap();
    let text = format!("{}\nName every towel.", skm.text());
    let edited = shipped
        .clone()
        .with(Template::parse(&skm.name, "test", &text).unwrap());
    let root = home.config_home().join("mapvlm/prompt-sets");
    let dir = prompt_sets::save(&root, "towels", &edited).unwrap();
    let saved = prompt_sets::load(&root, "towels").unwrap();
    let hash = &saved
        .get(Approach::MultiImage, AgentRole::Skm)
        .unwrap()
        .hash;

    let first = std::fs::read_to_string(common::shared().join("data/alfred30/tasks.jsonl"))
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string();
    let task: serde_json::Value = serde_json::from_str(&first).unwrap();
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    // The images stay shared, linked into the dataset as clusters do.
    std::os::unix::fs::symlink(
        common::shared().join("data/alfred30/images"),
        data.join("images"),
    )
    .unwrap();
    std::fs::write(data.join("tasks.jsonl"), format!("{task}\n")).unwrap();
    let out = home.path().join("out");
    let run = home
        .command()
        .args([
            "eval",
            "--approaches",
            "multi-image",
            "--metrics",
            "kas",
            "--dataset",
        ])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .arg("--prompts")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", common::stderr(&run));

    let requests = server.requests();
    assert_eq!(server::roles(&requests).len(), 3);
    assert!(server::only(&requests, AgentRole::Skm)
        .text()
        .contains("Name every towel."));
    assert!(!server::only(&requests, AgentRole::Gkm)
        .text()
        .contains("Name every towel."));
    let results: Vec<serde_json::Value> = std::fs::read_dir(out.join("tasks"))
        .unwrap()
        .map(|e| {
            serde_json::from_str(&std::fs::read_to_string(e.unwrap().path()).unwrap()).unwrap()
        })
        .collect();
    assert_eq!(results.len(), 1);
    let agents = results[0]["record"]["agents"].as_array().unwrap();
    let skm_record = agents.iter().find(|a| a["role"] == "skm").unwrap();
    assert_eq!(&skm_record["prompt_hash"], hash.as_str(), "{skm_record}");
    assert_ne!(hash, &skm.hash, "the edited prompt is another version");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let recorded = &manifest["provenance"]["prompts"]["multi-image-skm"];
    assert_eq!(&recorded["hash"], hash.as_str(), "{manifest}");
    let file = dir.join("multi-image-skm.txt");
    assert_eq!(recorded["source"], file.display().to_string());
    assert_eq!(
        manifest["provenance"]["prompts"]
            .as_object()
            .map(|m| m.len()),
        Some(3)
    );
}
