//! The Plan pane's `c`: the plan corrupted into a new run through `update`,
//! with the real English pipeline and word vectors of the pack (loaded once
//! for this test binary), and the picker drawn.

use crate::common;

use std::sync::{Arc, OnceLock};

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

use mapvlm::agents::replay::Pace;
use mapvlm::corrupt::{apply_edits, Kind, Vocabulary};
use mapvlm::models::{EN_CORE_WEB_SM, GLOVE_6B_50D};
use mapvlm::nlp::en::EnPipeline;
use mapvlm::nlp::wordvec::WordVectorTable;
use mapvlm::workbench::agents::AgentsPipeline;
use mapvlm::workbench::app::{App, AppInit};
use mapvlm::workbench::corrupting::CorruptionModels;
use mapvlm::workbench::headless::Headless;
use mapvlm::workbench::message::{Cmd, Msg};
use mapvlm::workbench::panes::Pane;
use mapvlm::workbench::render;
use mapvlm::workbench::scoring::ModelSlot;
use mapvlm::workbench::session::PlanSource;

fn models() -> &'static CorruptionModels {
    static MODELS: OnceLock<CorruptionModels> = OnceLock::new();
    MODELS.get_or_init(|| {
        let dir = common::pack_dir();
        CorruptionModels {
            parser: Arc::new(EnPipeline::load(&dir.join(EN_CORE_WEB_SM)).unwrap()),
            vectors: Arc::new(WordVectorTable::load_glove_pack(&dir.join(GLOVE_6B_50D)).unwrap()),
            vocabulary: Arc::new(Vocabulary::built_in().unwrap()),
        }
    })
}

fn press(app: &mut App, code: KeyCode) -> Vec<Cmd> {
    app.update(Msg::Key(KeyEvent::new(code, KeyModifiers::NONE)))
}

/// Carries out the commands as the runtime would: corruptions with the
/// pack's models, scores with KAS alone (no sentence encoder here).
fn run(app: &mut App, cmds: Vec<Cmd>) {
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
    let slot = ModelSlot::Unavailable("no sentence encoder in this test".into());
    let runner = Headless::new(&pipeline, slot).with_corruption(models().clone());
    runner.run(app, cmds, &mut |msg| {
        if let Msg::Scored(outcome) = msg {
            outcome.millis = 0.0;
        }
    });
}

/// The demo after its agents ran once (replayed from the demo's recording):
/// one run in the history, its plan in the Plan pane.
fn demo_with_a_plan() -> App {
    let (mut app, cmds) = App::new(AppInit::demo((120, 40), "no models in this test"));
    run(&mut app, cmds);
    assert_eq!(app.runs.history.len(), 1, "{:?}", app.messages.status);
    while app.focus != Pane::Plan {
        press(&mut app, KeyCode::Tab);
    }
    assert!(!app.panes.plan.items.is_empty(), "the demo has a plan");
    app
}

fn screen(app: &App) -> String {
    let mut terminal = Terminal::new(TestBackend::new(120, 40)).unwrap();
    terminal.draw(|f| render::render(f, app)).unwrap();
    terminal.backend().to_string()
}

/// Chooses `kind` in the picker opened with `c`.
fn corrupt(app: &mut App, kind: Kind) {
    let cmds = press(app, KeyCode::Char('c'));
    assert!(cmds.is_empty());
    let position = Kind::ALL.iter().position(|k| *k == kind).unwrap();
    for _ in 0..position {
        press(app, KeyCode::Down);
    }
    let cmds = press(app, KeyCode::Enter);
    assert!(
        matches!(cmds.as_slice(), [Cmd::Corrupt(r)] if r.kind == kind),
        "{cmds:?}"
    );
    run(app, cmds);
}

#[test]
fn c_corrupts_the_plan_into_a_new_run_scored_at_once() {
    for kind in [Kind::ObjectSwap, Kind::Drop, Kind::Reorder, Kind::Truncate] {
        let mut app = demo_with_a_plan();
        let before = app.runs.history.clone();
        let plan = app.panes.plan.items.clone();
        let source = app.work.plan_source.clone();
        let generation = app.work.score_generation;
        corrupt(&mut app, kind);
        assert_eq!(
            app.runs.history.len(),
            before.len() + 1,
            "{kind}: {:?}",
            app.messages.status
        );
        assert_eq!(
            app.runs.history[..before.len()],
            before[..],
            "older runs are unchanged"
        );
        let new = app.runs.history.last().unwrap();
        let from = new.corrupted.as_ref().unwrap();
        assert_eq!(from.source, source);
        assert_eq!(from.corruption.kind, kind.name());
        assert_eq!(from.corruption.seed, before.len() as u64);
        assert_ne!(new.plan, plan);
        assert_eq!(
            apply_edits(&plan, &from.corruption.edits).unwrap(),
            new.plan,
            "{kind}"
        );
        assert_eq!(app.panes.plan.items, new.plan);
        assert_eq!(app.work.plan_source, PlanSource::Run { run: new.id });
        assert!(app.work.score_generation > generation);
        assert!(
            new.scores.is_some(),
            "{kind}: the new run is scored at once"
        );
        if kind == Kind::ObjectSwap {
            assert!(from.corruption.similarity.is_some());
        }
    }
}

#[test]
fn the_same_session_gives_the_same_corruption() {
    let mut one = demo_with_a_plan();
    let mut two = demo_with_a_plan();
    corrupt(&mut one, Kind::ObjectSwap);
    corrupt(&mut two, Kind::ObjectSwap);
    // What the corruption decides: the new run's plan, its recorded edits and
    // its scores. (Start times and the replayed agents' timings may differ.)
    let made = |app: &App| {
        let run = app.runs.history.last().unwrap().clone();
        (run.id, run.plan, run.corrupted, run.scores, run.steps)
    };
    assert!(made(&one).2.is_some(), "a corrupted run was made");
    assert_eq!(made(&one), made(&two));
}

#[test]
fn the_picker_lists_every_kind_and_a_kind_that_does_not_apply_says_why() {
    let mut app = demo_with_a_plan();
    press(&mut app, KeyCode::Char('c'));
    let shown = screen(&app);
    for kind in Kind::ALL {
        assert!(shown.contains(kind.name()), "{kind} not in the picker");
    }
    insta::assert_snapshot!("corrupt_picker_120x40", shown);
    press(&mut app, KeyCode::Esc);
    let runs = app.runs.history.len();
    // The demo has no other task to take a step from.
    corrupt(&mut app, Kind::Insert);
    assert_eq!(app.runs.history.len(), runs);
    let (status, _) = app.messages.status.clone().unwrap();
    assert!(
        status.starts_with("insert cannot corrupt this plan: "),
        "{status}"
    );
}
