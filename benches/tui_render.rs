//! How long one frame of the workbench takes to render at 200×60, and how
//! long the update of one keystroke in the step editor takes.

use criterion::{criterion_group, criterion_main, Criterion};
use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use mapvlm::agents::replay::Pace;
use mapvlm::workbench::agents::{run_blocking, AgentsPipeline};
use mapvlm::workbench::app::{App, AppInit};
use mapvlm::workbench::message::{Cmd, Msg};
use mapvlm::workbench::scoring::{score_now, ModelSlot};
use mapvlm::workbench::{prepare_image, render};
use ratatui::backend::TestBackend;
use ratatui::Terminal;
use ratatui_image::picker::Picker;

fn demo_app() -> App {
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "bench"));
    let models = ModelSlot::Unavailable("bench".into());
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap_or_else(|e| panic!("{e}"));
    let mut queue = cmds;
    while let Some(cmd) = queue.pop() {
        match cmd {
            Cmd::StartRun(req) => {
                let run = req.run;
                let events = run_blocking(&pipeline, req).unwrap_or_else(|e| panic!("{e}"));
                for event in events {
                    queue.extend(app.update(Msg::Agent(run, event)));
                }
            }
            Cmd::Score(req) => queue.extend(app.update(Msg::Scored(score_now(&models, &req)))),
            _ => {}
        }
    }
    prepare_image(&mut app, &Picker::halfblocks());
    app
}

fn render(c: &mut Criterion) {
    let app = demo_app();
    let mut terminal = Terminal::new(TestBackend::new(200, 60)).unwrap_or_else(|e| panic!("{e}"));
    c.bench_function("render demo frame 200x60", |b| {
        b.iter(|| {
            terminal
                .draw(|f| render::render(f, &app))
                .unwrap_or_else(|e| panic!("{e}"));
        })
    });
    let mut app = demo_app();
    app.update(Msg::Key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE)));
    c.bench_function("keystroke in the step editor (update + render)", |b| {
        b.iter(|| {
            app.update(Msg::Key(KeyEvent::new(
                KeyCode::Char('x'),
                KeyModifiers::NONE,
            )));
            app.update(Msg::Key(KeyEvent::new(
                KeyCode::Backspace,
                KeyModifiers::NONE,
            )));
            terminal
                .draw(|f| render::render(f, &app))
                .unwrap_or_else(|e| panic!("{e}"));
        })
    });
}

criterion_group!(benches, render);
criterion_main!(benches);
