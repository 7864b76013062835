//! How long one frame of the workbench takes to render at 200×60, how long
//! the first frame takes (the workbench built from nothing, then drawn), and
//! how long the update of one keystroke in the step editor takes with its
//! frame.

use criterion::{criterion_group, criterion_main, Criterion};
use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use mapvlm::agents::replay::Pace;
use mapvlm::workbench::agents::AgentsPipeline;
use mapvlm::workbench::app::{App, AppInit};
use mapvlm::workbench::graphics::Graphics;
use mapvlm::workbench::headless::Headless;
use mapvlm::workbench::message::Msg;
use mapvlm::workbench::scoring::ModelSlot;
use mapvlm::workbench::{prepare_image, render};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn demo_app() -> App {
    let (mut app, cmds) = App::new(AppInit::demo((200, 60), "bench"));
    let models = ModelSlot::Unavailable("bench".into());
    let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap_or_else(|e| panic!("{e}"));
    Headless::new(&pipeline, models).run(&mut app, cmds, &mut |_| {});
    prepare_image(&mut app, &Graphics::halfblocks());
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
    c.bench_function("first frame 200x60 (App::new + render)", |b| {
        b.iter(|| {
            let (app, _cmds) = App::new(AppInit::demo((200, 60), "bench"));
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
