//! The run diff end to end: the real workbench in tmux, its agents on a
//! local OpenAI-compatible server (wiremock, in this test process) that
//! answers an edited Planner prompt with another plan; two runs with the
//! prompt edit between them, then the diff of the two.

use crate::common;

use common::server::LocalServer;
use common::workbench::{score_on, UserHome, Workbench};
use mapvlm::agents::AgentRole;

/// What the edit appends to the Planner's prompt, and what the server
/// looks for to answer it with [`SHORT_PLAN`].
const EDIT: &str = " Be brief.";

/// The plan the server writes for the edited prompt: six steps as the
/// first plan (so KAS pairs them all), in fewer words.
const SHORT_PLAN: &str = "1. Walk to the bathtub.\n2. Take the sponge.\n3. Go to the sink.\n\
                          4. Soak the sponge.\n5. Go back.\n6. Drop the sponge in the bathtub.";

/// The line of the diff's verdict on `metric`, if it is on `screen`.
fn verdict<'a>(screen: &'a str, metric: &str) -> Option<&'a str> {
    screen
        .lines()
        .find(|l| l.contains(&format!("│{metric} ")) && l.contains(" → "))
}

#[test]
fn a_prompt_edit_between_two_runs_shows_in_their_diff_with_the_score_change() {
    let server = LocalServer::start();
    server.plan_when(EDIT.trim(), SHORT_PLAN);
    let home = UserHome::new();
    home.point_at(&server);
    let dataset = common::shared().join("data/alfred30").display().to_string();
    let workbench = Workbench::start("run-diff", &home, (120, 40), &["--dataset", &dataset]);
    workbench.wait_for("the dataset task", |s| {
        s.contains("trial_T20190906_234735_610018-1")
    });
    workbench.keys(&["r"]);
    let first = workbench.wait_for("run 1, scored", |s| {
        s.contains("run 1 finished") && !s.contains("scoring…") && score_on(s, "KAS").is_some()
    });

    // The Plan pane has the focus; the Prompt pane is three panes on.
    workbench.keys(&["Tab", "Tab", "Tab", "3", "Enter"]);
    workbench.wait_for("the Planner's prompt in the editor", |s| {
        s.contains("EDIT prompt")
    });
    workbench.keys(&[EDIT, "Escape"]);
    workbench.wait_for("the edit kept", |s| !s.contains("EDIT prompt"));
    workbench.keys(&["r"]);
    let second = workbench.wait_for("run 2, scored", |s| {
        s.contains("run 2 finished")
            && !s.contains("scoring…")
            && s.contains("Drop the sponge in the bathtub.")
    });
    assert_ne!(
        score_on(&first, "KAS"),
        score_on(&second, "KAS"),
        "{second}"
    );
    let requests = server.requests();
    let planners: Vec<_> = requests
        .iter()
        .filter(|r| r.role == AgentRole::Planner)
        .collect();
    assert_eq!(
        requests.len(),
        4,
        "SKM, GKM, Planner, then the Planner alone"
    );
    assert!(planners[1].text().contains(EDIT.trim()));

    workbench.keys(&["H", "d"]);
    // The wait covers every string asserted below, so a frame tmux
    // captured half drawn (title drawn, body not yet) is never judged.
    let diff = workbench.wait_for("the whole diff of runs 1 and 2", |s| {
        [
            "Diff run #1 → #2",
            "── Planner ──",
            "Be brief.+}",
            "tok $0.0000 (cached)",
            "set samples to 5",
        ]
        .iter()
        .all(|needle| s.contains(needle))
            && verdict(s, "KAS").is_some()
    });
    assert!(diff.contains("── Planner ──"), "{diff}");
    assert!(
        diff.contains("{+"),
        "the prompt's added words are marked: {diff}"
    );
    assert!(diff.contains("Be brief.+}"), "{diff}");
    assert!(
        diff.contains("tok $0.0000 (cached)"),
        "the miners answered run 2 from the cache, and it says so: {diff}"
    );
    let kas = verdict(&diff, "KAS").unwrap_or_else(|| panic!("no KAS verdict: {diff}"));
    let (before, after) = (
        score_on(&first, "KAS").unwrap_or_default(),
        score_on(&second, "KAS").unwrap_or_default(),
    );
    assert!(kas.contains(&format!("{before} → {after}")), "{kas}");
    assert!(
        kas.contains("1+1 samples: cannot tell a change from noise"),
        "{kas}"
    );
    assert!(diff.contains("set samples to 5"), "{diff}");

    // Scrolled to the end: the plans step by step, the dropped steps marked.
    workbench.keys(&["End"]);
    let end = workbench.wait_for("the plan diff", |s| s.contains("each step's score"));
    assert!(end.contains("[-"), "{end}");
    // One key at a time: two escapes sent at once read as Alt-Esc.
    workbench.keys(&["Escape"]);
    workbench.wait_for("back in the run history", |s| s.contains("Runs (↑↓ move"));
    workbench.keys(&["Escape"]);
    workbench.wait_for("the history closed", |s| !s.contains("Runs (↑↓ move"));
    assert_eq!(workbench.quit(), "0");
}
