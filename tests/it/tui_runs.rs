//! Honest runs end to end: the real workbench in tmux against a local
//! OpenAI-compatible server (wiremock, in this test process) told to fail
//! the Planner on demand. A failed run is kept as failed in the history
//! and the session, never scored, and the last good plan stays on screen.

use crate::common;

use common::server::{self, Failure, LocalServer};
use common::workbench::{score_on, UserHome, Workbench, LOCAL_MODEL};
use mapvlm::agents::AgentRole;

/// A config file sending every agent to `server`, with no retries (a 500
/// fails at once).
fn point_without_retries(home: &UserHome, server: &LocalServer) {
    point_at(home, server, 0);
}

/// A config file sending every agent to `server`, retrying `retries` times.
fn point_at(home: &UserHome, server: &LocalServer, retries: u32) {
    home.write_config(&format!(
        "max_retries = {retries}\n[defaults]\nprovider = \"openai\"\nbase_url = \"{}\"\nmodel = \"{LOCAL_MODEL}\"\n",
        server.base_url()
    ));
}

/// The good plan's step the screen must keep showing.
const GOOD_STEP: &str = "Wet the sponge under the faucet.";

/// The Plan pane's title on `screen`, without its border.
fn plan_title(screen: &str) -> String {
    let line = screen
        .lines()
        .find(|l| l.contains("┏ Plan ") || l.contains("┌ Plan "))
        .unwrap_or_else(|| panic!("no Plan pane: {screen}"));
    let start = line.find(" Plan ").unwrap();
    let end = line[start..]
        .find(['┓', '┐'])
        .map_or(line.len(), |e| start + e);
    line[start..end]
        .trim_end_matches(['━', '─'])
        .trim()
        .to_string()
}

#[test]
fn a_500_and_a_dropped_stream_are_failed_runs_unscored_and_the_good_plan_stays() {
    let server = LocalServer::start();
    let home = UserHome::new();
    point_without_retries(&home, &server);
    let workbench = Workbench::start_on_alfred30("honest-runs", &home);
    workbench.keys(&["r"]);
    let first = workbench.wait_for("run 1, scored", |s| {
        s.contains("run 1 finished")
            && s.contains(GOOD_STEP)
            && !s.contains("scoring…")
            && score_on(s, "KAS").is_some()
    });
    let kas = score_on(&first, "KAS");
    assert_eq!(server.requests().len(), 3);

    server.fail_planner(Some(Failure::Status(500)));
    workbench.keys(&["R"]);
    let failed = workbench.wait_for("run 2 failed with the good plan kept", |s| {
        s.contains("run 2 failed: Planner:") && s.contains(GOOD_STEP) && !s.contains("scoring…")
    });
    assert!(failed.contains("500"), "{failed}");
    let title = plan_title(&failed);
    assert!(
        title.contains("run 2 failed") && title.ends_with('…'),
        "the failure in the Plan pane's title, cut with an ellipsis: {title:?}"
    );
    assert_eq!(
        score_on(&failed, "KAS"),
        kas,
        "the good plan's scores: {failed}"
    );
    let mut asked = server::roles(&server.requests()[3..]);
    asked.sort();
    let mut every = vec![AgentRole::Skm, AgentRole::Gkm, AgentRole::Planner];
    every.sort();
    assert_eq!(asked, every, "R asks every agent afresh, each once");

    server.fail_planner(Some(Failure::DropAfter(6)));
    workbench.keys(&["R"]);
    let dropped = workbench.wait_for("run 3 failed with the good plan kept", |s| {
        s.contains("run 3 failed: Planner:") && s.contains(GOOD_STEP) && !s.contains("scoring…")
    });
    assert!(dropped.contains("stream ended"), "{dropped}");
    assert_eq!(score_on(&dropped, "KAS"), kas, "{dropped}");
    assert_eq!(server.requests().len(), 9, "three agents a run, no retries");

    workbench.keys(&["H"]);
    let history = workbench.wait_for("the history with two failed runs", |s| {
        s.matches("1/1 finished").count() == 1 && s.matches("0/1 failed").count() == 2
    });
    assert!(history.contains("run #3 failed: Planner:"), "{history}");
    assert!(
        history.contains("its partial plan is kept, not scored"),
        "{history}"
    );
    workbench.keys(&["Escape"]);
    workbench.wait_for("the history closed", |s| !s.contains("Runs (↑↓ move"));
    assert_eq!(workbench.quit(), "0");

    let session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(home.session_file()).unwrap()).unwrap();
    let runs = session["runs"].as_array().unwrap();
    let states: Vec<&str> = runs.iter().map(|r| r["state"].as_str().unwrap()).collect();
    assert_eq!(states, ["finished", "failed", "failed"]);
    assert!(runs[0]["scores"]["kas"].is_number(), "{}", runs[0]);
    for run in &runs[1..] {
        assert!(run["scores"].is_null(), "never scored: {run}");
        assert!(
            run["error"].as_str().unwrap().starts_with("Planner: "),
            "{run}"
        );
        let planner = run["agents"]
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["role"] == "planner")
            .unwrap();
        assert_eq!(
            planner["usage"]["output_tokens"], 0,
            "nothing reported: {run}"
        );
        assert_eq!(planner["cached"], false, "{run}");
    }
    assert!(runs[1]["error"].as_str().unwrap().contains("500"));
    assert_eq!(
        runs[2]["plan"],
        serde_json::json!(["Walk to the bathtub.", "Pick"]),
        "the dropped stream's partial plan is kept"
    );
    assert_eq!(
        session["plan"], runs[0]["plan"],
        "the session keeps the last good plan in the Plan pane"
    );
}

/// The SKM's server unreachable (a port nobody listens on) on a dataset
/// task: the run is failed in the history and the session, never scored,
/// the Planner never asked, and the task's published plan stays on screen.
#[test]
fn an_unreachable_miner_is_a_failed_run_unscored_and_the_published_plan_stays() {
    let server = LocalServer::start();
    let home = UserHome::new();
    let closed = {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        listener.local_addr().unwrap().port()
    };
    home.write_config(&format!(
        "max_retries = 0\n[defaults]\nprovider = \"openai\"\nbase_url = \"{}\"\nmodel = \"{LOCAL_MODEL}\"\n\
         [agents.skm]\nbase_url = \"http://127.0.0.1:{closed}/v1\"\n",
        server.base_url()
    ));
    let workbench = Workbench::start_on_alfred30("unreachable-miner", &home);
    workbench.keys(&["r"]);
    let failed = workbench.wait_for("run 1 failed with the published plan kept", |s| {
        s.contains("run 1 failed: SKM:")
            && s.contains(PUBLISHED_STEP)
            && !s.contains("scoring…")
            && score_on(s, "KAS").is_some()
    });
    assert!(failed.contains("published"), "{failed}");
    workbench.keys(&["H"]);
    workbench.wait_for("the history with the failed run", |s| {
        s.contains("0/1 failed") && s.contains("run #1 failed: SKM:")
    });
    workbench.keys(&["Escape"]);
    workbench.wait_for("the history closed", |s| !s.contains("Runs (↑↓ move"));
    assert_eq!(workbench.quit(), "0");
    assert_eq!(
        server::roles(&server.requests())
            .iter()
            .filter(|r| **r == AgentRole::Planner)
            .count(),
        0,
        "the Planner is not asked once a miner failed"
    );
    let session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(home.session_file()).unwrap()).unwrap();
    let run = &session["runs"][0];
    assert_eq!(run["state"], "failed", "{run}");
    assert!(run["scores"].is_null(), "never scored: {run}");
    assert!(run["error"].as_str().unwrap().starts_with("SKM: "), "{run}");
}

/// The first step of alfred30's first task's published multi-image plan,
/// which the Plan pane shows before any run.
const PUBLISHED_STEP: &str = "Walk to vanity at position in front of the toilet.";

/// A run of three samples of the three agents: the history's tokens, cost
/// and time are the sums over every request the server saw, and each agent
/// says how many calls it made.
#[test]
fn a_sampled_runs_tokens_cost_and_time_in_the_history_are_sums_over_every_request() {
    use common::server::{GKM_ANSWER, PLAN_ANSWER, SKM_ANSWER};
    use std::time::Duration;

    let server = LocalServer::start();
    server.delay_answers(Duration::from_millis(200));
    let home = UserHome::new();
    home.write_config(&format!(
        "max_retries = 0\n[defaults]\nprovider = \"openai\"\nbase_url = \"{}\"\nmodel = \"{LOCAL_MODEL}\"\n\
         [prices.openai.\"{LOCAL_MODEL}\"]\ninput_per_million = 10.0\noutput_per_million = 40.0\n",
        server.base_url()
    ));
    let workbench = Workbench::start_on_alfred30("sampled-sums", &home);
    workbench.keys(&["S"]);
    workbench.wait_for("three samples a run", |s| s.contains("samples per run: 3"));
    workbench.keys(&["r"]);
    let requests = server.wait_for_requests(9);
    workbench.keys(&["H"]);
    let history = workbench.wait_for("the run with its three samples", |s| {
        s.contains("3/3 finished")
    });
    let requests_now = server.requests();
    assert_eq!(
        requests_now.len(),
        9,
        "three agents, three samples: {requests:?}"
    );
    // The server's usage: 120 tokens in, a token a four characters out.
    let written = |role| match role {
        AgentRole::Skm => SKM_ANSWER.len().div_ceil(4) as u64,
        AgentRole::Gkm => GKM_ANSWER.len().div_ceil(4) as u64,
        _ => PLAN_ANSWER.len().div_ceil(4) as u64,
    };
    let input = 120 * requests_now.len() as u64;
    let output: u64 = requests_now.iter().map(|r| written(r.role)).sum();
    let cost = (input as f64 * 10.0 + output as f64 * 40.0) / 1e6;
    let row = history
        .lines()
        .find(|l| l.contains("#1 ") && l.contains("3/3 finished"))
        .unwrap_or_else(|| panic!("no row of run 1: {history}"));
    assert!(row.contains(&format!(" {} ", input + output)), "{row}");
    assert!(
        row.contains(&format!("${cost:.4}")),
        "{row} (expected ${cost:.4})"
    );
    for agent in ["SKM", "GKM", "Planner"] {
        let line = history
            .lines()
            .find(|l| l.contains(&format!("  {agent:<8}openai/")))
            .unwrap_or_else(|| panic!("no line of {agent}: {history}"));
        assert!(line.contains("· 3 calls"), "{line}");
    }
    workbench.keys(&["Escape"]);
    workbench.wait_for("the history closed", |s| !s.contains("Runs (↑↓ move"));
    assert_eq!(workbench.quit(), "0");

    let session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(home.session_file()).unwrap()).unwrap();
    let run = &session["runs"][0];
    let calls: Vec<&serde_json::Value> = run["agents"]
        .as_array()
        .unwrap()
        .iter()
        .chain(
            run["samples"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|s| s["agents"].as_array().unwrap()),
        )
        .collect();
    assert_eq!(calls.len(), 9, "each request its own record: {run}");
    let ms: u64 = calls
        .iter()
        .map(|c| c["elapsed_ms"].as_u64().unwrap())
        .sum();
    assert!(
        calls
            .iter()
            .all(|c| c["elapsed_ms"].as_u64().unwrap() >= 200),
        "each call waited for its answer: {run}"
    );
    assert!(
        row.contains(&format!(" {ms} ")),
        "the time is the sum {ms}: {row}"
    );
    let tokens: u64 = calls
        .iter()
        .map(|c| {
            c["usage"]["input_tokens"].as_u64().unwrap()
                + c["usage"]["output_tokens"].as_u64().unwrap()
        })
        .sum();
    assert_eq!(tokens, input + output);
}

#[test]
fn retries_and_a_retry_after_are_counted_down_in_the_planners_pane() {
    let server = LocalServer::start();
    let home = UserHome::new();
    point_at(&home, &server, 4);
    server.fail_planner_next(&[
        Failure::Status(500),
        Failure::Status(500),
        Failure::RetryAfter(503, 3),
    ]);
    let workbench = Workbench::start_on_alfred30("retry-after", &home);
    workbench.keys(&["r"]);
    let first = workbench.wait_for("the Retry-After counted down", |s| {
        s.contains("HTTP 503 · retry 3 of 4 in 3 s (Retry-After)")
    });
    assert!(first.contains("Planner"), "{first}");
    workbench.wait_for("the countdown moving", |s| {
        s.contains("HTTP 503 · retry 3 of 4 in 2 s (Retry-After)")
    });
    workbench.wait_for("the run finished after the retries", |s| {
        s.contains("run 1 finished") && s.contains(GOOD_STEP)
    });
    let planner = server
        .requests()
        .iter()
        .filter(|r| r.role == AgentRole::Planner)
        .count();
    assert_eq!(planner, 4, "three refusals, then the answer");
    assert_eq!(workbench.quit(), "0");
}

/// A provider that says nothing for seconds is not shown as streaming: the
/// pane titles count the silence (`no answer yet · 3 s`) until the answer
/// comes.
#[test]
fn a_silent_provider_is_counted_in_the_pane_titles() {
    let server = LocalServer::start();
    let home = UserHome::new();
    point_at(&home, &server, 0);
    server.delay_answers(std::time::Duration::from_secs(5));
    let workbench = Workbench::start_on_alfred30("silence", &home);
    workbench.keys(&["r"]);
    workbench.wait_for("the silence counted", |s| s.contains("no answer yet · 3 s"));
    workbench.wait_for("the count moving", |s| s.contains("no answer yet · 4 s"));
    workbench.wait_for("the run finished after the silence", |s| {
        s.contains("run 1 finished") && s.contains(GOOD_STEP) && !s.contains("no answer yet")
    });
    assert_eq!(workbench.quit(), "0");
}
