//! The runtime: sets the terminal up and restores it, runs the loop that
//! feeds messages to `update`, and carries out the commands it returns
//! with [`super::execute::execute`], their work in background tasks.

use std::collections::HashMap;
use std::io::Stdout;
use std::path::PathBuf;
use std::sync::{Arc, RwLock};
use std::time::Instant;

use crossterm::event::{
    DisableBracketedPaste, DisableMouseCapture, EnableBracketedPaste, EnableMouseCapture, Event,
};
use crossterm::execute;
use crossterm::terminal::{
    disable_raw_mode, enable_raw_mode, EnterAlternateScreen, LeaveAlternateScreen,
};
use ratatui::backend::CrosstermBackend;
use ratatui::layout::Rect;
use ratatui::Terminal;
use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;

use super::agents::{Pipeline, RunError, RunRequest};
use super::app::{App, AppInit};
use super::scoring::{ModelSlot, ScorerLoader, SharedModels};
use super::session::{Restored, Session};
use super::shared::{spawn_signal_watch, Severity};
use crate::agents::pipeline::AgentEvent;
use crate::dataset::Dataset;

use super::corrupting::{CorruptError, CorruptionModels, SharedCorruptionModels};
use super::execute::{execute, Carrier, Job, Models};
use super::graphics::{self, Graphics, Kind, Request};
use super::message::Msg;
use super::saver::{self, NumberedCopy, SessionFile};
use super::scene_image::{self, ImageRequest};
use super::{render, terminal_query, theme, Options, TuiError, SCORE_DEBOUNCE};
use super::{scoring, session};

/// Puts the terminal back as it was: raw mode off, main screen, no mouse capture.
fn restore_terminal() {
    let _ = disable_raw_mode();
    let _ = execute!(
        std::io::stdout(),
        DisableMouseCapture,
        DisableBracketedPaste,
        LeaveAlternateScreen,
        crossterm::cursor::Show
    );
}

/// Restores the terminal when dropped, so every way out of [`run`] restores it.
pub(crate) struct TerminalGuard;

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        restore_terminal();
    }
}

pub(crate) fn setup_terminal(
) -> Result<(TerminalGuard, Terminal<CrosstermBackend<Stdout>>), TuiError> {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        restore_terminal();
        previous(info);
    }));
    enable_raw_mode()?;
    let guard = TerminalGuard;
    execute!(
        std::io::stdout(),
        EnterAlternateScreen,
        EnableMouseCapture,
        EnableBracketedPaste
    )?;
    let terminal = Terminal::new(CrosstermBackend::new(std::io::stdout()))?;
    Ok((guard, terminal))
}

/// Hands the encoding of the scene image to a blocking task when the app
/// wants it in an area it is not encoded for; the task answers with
/// [`Msg::ImageReady`], so the loop never resizes or encodes an image.
fn request_image(app: &mut App, graphics: &Graphics, msgs: &mpsc::UnboundedSender<Msg>) {
    let Some(request) = app.request_image() else {
        return;
    };
    let (graphics, msgs) = (graphics.clone(), msgs.clone());
    tokio::task::spawn_blocking(move || {
        let ImageRequest {
            area,
            image,
            background,
        } = request;
        let _ = msgs.send(Msg::ImageReady(
            area,
            scene_image::encode(&graphics, &image, area, background).map(|(_, drawing)| drawing),
        ));
    });
}

/// Takes kitty's directly placed picture off the screen when what is shown
/// changes (`now` differs from `shown`): unlike a sixel it is not text the
/// next frame overwrites, and it would stay over an overlay or a new layout.
/// A frame with the picture held back comes between, so the next frame
/// places it again.
fn take_off_placed_picture(
    terminal: &mut Terminal<CrosstermBackend<Stdout>>,
    app: &mut App,
    graphics: &Graphics,
    shown: &mut Option<(Rect, bool)>,
) -> std::io::Result<()> {
    let now = app.picture_shown();
    if graphics.kind != Kind::KittyDirect || *shown == now {
        *shown = now;
        return Ok(());
    }
    *shown = now;
    use std::io::Write;
    let backend = terminal.backend_mut();
    backend.write_all(graphics::kitty_direct_clear(graphics.tmux).as_bytes())?;
    backend.flush()?;
    app.panes.scene.hold = true;
    let held = terminal.draw(|f| render::render(f, app)).map(|_| ());
    app.panes.scene.hold = false;
    held
}

/// Everything the loop hands work to.
struct Runtime {
    msgs: mpsc::UnboundedSender<Msg>,
    agent_events: mpsc::UnboundedSender<(u64, AgentEvent)>,
    scores: watch::Sender<Option<scoring::ScoreRequest>>,
    pipeline: Arc<dyn Pipeline>,
    runs: HashMap<u64, JoinHandle<()>>,
    corruption: SharedCorruptionModels,
    models: SharedModels,
}

impl Carrier for Runtime {
    fn pipeline(&self) -> &dyn Pipeline {
        self.pipeline.as_ref()
    }

    fn models(&self) -> Models {
        Models::Shared(self.models.clone())
    }

    fn corruption(&self) -> Result<CorruptionModels, CorruptError> {
        self.corruption
            .read()
            .map(|slot| slot.clone())
            .unwrap_or_else(|p| p.into_inner().clone())
    }

    fn spawn(&mut self, job: Job) {
        let msgs = self.msgs.clone();
        tokio::task::spawn_blocking(move || {
            for msg in job() {
                let _ = msgs.send(msg);
            }
        });
    }

    fn start_run(&mut self, request: RunRequest) -> Result<(), RunError> {
        let run = request.run;
        let handle = self.pipeline.spawn(request, self.agent_events.clone());
        self.runs.insert(run, handle);
        Ok(())
    }

    fn cancel_run(&mut self, run: u64) {
        if let Some(handle) = self.runs.remove(&run) {
            handle.abort();
        }
    }

    fn score(&mut self, request: scoring::ScoreRequest) {
        self.scores.send_replace(Some(request));
    }
}

/// Reads the user's input on a thread of its own: first the rest of a late
/// answer to the start-up query (its keys kept, its replies dropped), then
/// crossterm's events.
fn spawn_input_thread(msgs: mpsc::UnboundedSender<Msg>, late: Option<terminal_query::Late>) {
    std::thread::spawn(move || {
        if let Some(late) = late {
            late.drain(|key| {
                let _ = msgs.send(Msg::Key(key));
            });
            if let Ok((w, h)) = crossterm::terminal::size() {
                let _ = msgs.send(Msg::Resize(w, h));
            }
        }
        read_events(&msgs);
    });
}

fn read_events(msgs: &mpsc::UnboundedSender<Msg>) {
    loop {
        let msg = match crossterm::event::read() {
            Ok(Event::Key(key)) => Msg::Key(key),
            Ok(Event::Mouse(mouse)) => Msg::Mouse(mouse),
            Ok(Event::Resize(w, h)) => Msg::Resize(w, h),
            Ok(Event::Paste(text)) => Msg::Paste(text),
            Ok(_) => continue,
            Err(_) => Msg::Quit,
        };
        if msgs.send(msg).is_err() {
            return;
        }
    }
}

/// Starts the workbench and runs it until the user quits. The terminal is
/// restored on every way out, a panic included.
pub fn run(options: Options) -> Result<(), TuiError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let result = rt.block_on(run_async(options));
    // The session is saved by now; a model still loading on a blocking
    // thread must not hold the exit up (dropping the runtime would wait).
    rt.shutdown_background();
    result
}

fn load_start(
    options: &mut Options,
) -> (
    Option<Dataset>,
    Option<Session>,
    Vec<String>,
    Option<PathBuf>,
) {
    let mut notices = Vec::new();
    let dataset = options.dataset.take().map(|(dataset, errors)| {
        if let Some(first) = errors.first() {
            notices.push(format!(
                "{} bad lines in the dataset, first: {first}",
                errors.len()
            ));
        }
        dataset
    });
    let path = options.session.clone();
    let restored = match &path {
        Some(p) => match session::restore(p) {
            Ok(Restored::Loaded { session, repaired }) => {
                if let Some(first) = repaired.first() {
                    notices.push(match repaired.len() {
                        1 => first.clone(),
                        n => format!(
                            "{first} (and {} more values put back to their defaults)",
                            n - 1
                        ),
                    });
                }
                Some(*session)
            }
            Ok(Restored::Fresh) => None,
            Ok(Restored::SetAside { moved_to, reason }) => {
                notices.push(format!(
                    "the session file could not be read ({reason}); it was moved to {} and a new session started",
                    moved_to.display()
                ));
                None
            }
            Err(e) => {
                notices.push(format!("session not restored: {e}"));
                None
            }
        },
        None => {
            notices.push(
                "no session file (set --session or HOME): this session will not be saved".into(),
            );
            None
        }
    };
    if let Err(e) = &options.prices {
        notices.push(format!(
            "costs off, the config file's prices are not used: {e}; fix that entry"
        ));
    }
    if let Err(e) = &options.configured {
        notices.push(format!(
            "the agents start on the demo's recording, the config file's providers cannot be used: {e}"
        ));
    }
    (dataset, restored, notices, path)
}

async fn run_async(mut options: Options) -> Result<(), TuiError> {
    let (dataset, restored, notices, session_path) = load_start(&mut options);
    let (themes, theme_problems) = (
        std::mem::take(&mut options.themes),
        std::mem::take(&mut options.theme_problems),
    );
    let notice = notices
        .into_iter()
        .chain(theme_problems)
        .next()
        .map(|n| (n, Severity::Warn));
    let (guard, mut terminal) = setup_terminal()?;
    let size = terminal.size()?;
    let (mut app, first_cmds) = App::new(AppInit {
        dataset,
        themes,
        theme: options.theme.clone(),
        samples: options.samples,
        no_color: theme::no_color_requested(),
        ascii: !crate::locale::utf8_locale(),
        session: restored,
        notice,
        size: (size.width, size.height),
        models: ModelSlot::Loading("starting".to_string()),
        prompts: options.prompts.clone(),
        configured: options
            .configured
            .as_ref()
            .ok()
            .cloned()
            .unwrap_or_default(),
        prompt_sets: options.prompt_sets.clone(),
    });
    app.work.prices = options.prices.as_ref().ok().cloned().unwrap_or_default();
    terminal.draw(|f| render::render(f, &app))?;

    let (msg_tx, mut msg_rx) = mpsc::unbounded_channel::<Msg>();
    // The query reads stdin itself, so it runs before the input thread
    // exists; what was typed meanwhile and the size the window has now
    // (a resize during the query has no reader yet) go first in the queue.
    let probe = terminal_query::probe(options.graphics, options.query_timeout, app.looks.no_color);
    for key in probe.typed {
        let _ = msg_tx.send(Msg::Key(key));
    }
    let size = terminal.size()?;
    let _ = msg_tx.send(Msg::Resize(size.width, size.height));
    // Held to the end: dropping it puts tmux's option back.
    let _passthrough = probe.passthrough;
    if let Some(notice) = probe.notice {
        app.set_status(notice, Severity::Warn);
    }
    if options.graphics == Request::None {
        app.panes.scene.enabled = false;
    }
    let graphics = probe.graphics;
    app.panes.scene.graphics = graphics.summary();
    app.log(
        format!("scene image: {}", graphics.summary()),
        Severity::Info,
    );
    let (agent_tx, mut agent_rx) = mpsc::unbounded_channel();
    let (score_tx, score_rx) = watch::channel(None);
    let (save_tx, save_rx) = watch::channel::<Option<NumberedCopy>>(None);
    let models: SharedModels = Arc::new(RwLock::new(ModelSlot::Loading("starting".into())));
    let corruption: SharedCorruptionModels = Arc::new(RwLock::new(Err(CorruptError::StillLoading)));

    spawn_input_thread(msg_tx.clone(), probe.late);
    let quit = msg_tx.clone();
    spawn_signal_watch(move || {
        let _ = quit.send(Msg::Quit);
    });
    {
        let msgs = msg_tx.clone();
        tokio::spawn(async move {
            while let Some((run, event)) = agent_rx.recv().await {
                if msgs.send(Msg::Agent(run, event)).is_err() {
                    return;
                }
            }
        });
    }
    {
        let msgs = msg_tx.clone();
        tokio::spawn(scoring::worker(
            score_rx,
            models.clone(),
            SCORE_DEBOUNCE,
            move |o| {
                let _ = msgs.send(Msg::Scored(o));
            },
        ));
    }
    {
        let (done_tx, mut done_rx) = mpsc::unbounded_channel();
        let progress = msg_tx.clone();
        let loader = options.scorer;
        let wrapped: ScorerLoader = Box::new(move |report: &dyn Fn(String)| {
            loader(&|line: String| {
                let _ = progress.send(Msg::ModelsProgress(line.clone()));
                report(line);
            })
        });
        scoring::spawn_loader(wrapped, models.clone(), corruption.clone(), done_tx);
        let msgs = msg_tx.clone();
        tokio::spawn(async move {
            if let Some(slot) = done_rx.recv().await {
                let _ = msgs.send(Msg::ModelsLoaded(slot));
            }
        });
    }
    let session_file = session_path.map(|p| Arc::new(SessionFile::new(p)));
    let saver = session_file
        .clone()
        .map(|file| saver::spawn(file, save_rx, msg_tx.clone()));

    let mut runtime = Runtime {
        msgs: msg_tx,
        agent_events: agent_tx,
        scores: score_tx,
        pipeline: options.pipeline,
        runs: HashMap::new(),
        corruption,
        models: models.clone(),
    };
    for cmd in first_cmds {
        execute(cmd, &mut app, &mut runtime);
    }
    request_image(&mut app, &graphics, &runtime.msgs);
    let mut shown = app.picture_shown();
    terminal.draw(|f| render::render(f, &app))?;

    let mut wake: Option<Instant> = None;
    loop {
        let first = match wake {
            Some(at) => tokio::select! {
                msg = msg_rx.recv() => msg.map(Some),
                () = tokio::time::sleep_until(at.into()) => Some(None),
            },
            None => msg_rx.recv().await.map(Some),
        };
        let Some(first) = first else { break };
        let mut pending: Vec<Msg> = first.into_iter().collect();
        while let Ok(more) = msg_rx.try_recv() {
            pending.push(more);
        }
        for msg in pending {
            if let Msg::Resize(w, h) = msg {
                terminal.resize(Rect::new(0, 0, w, h))?;
            }
            for cmd in app.update(msg) {
                execute(cmd, &mut app, &mut runtime);
            }
        }
        let (copy, next) = app.poll_snapshot(Instant::now());
        if let Some(session) = copy {
            save_tx.send_replace(Some((app.saving.persist.taken(), session)));
        }
        wake = match (next, app.countdown_wake(Instant::now())) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        if app.quit {
            break;
        }
        request_image(&mut app, &graphics, &runtime.msgs);
        take_off_placed_picture(&mut terminal, &mut app, &graphics, &mut shown)?;
        terminal.draw(|f| render::render(f, &app))?;
    }
    for (_, handle) in runtime.runs.drain() {
        handle.abort();
    }
    if let (Some(saver), Some(file)) = (saver, session_file) {
        // A copy already being written finishes first, and none written
        // later can replace this one: the file ends with the final state.
        saver.abort();
        if let Err(e) = file.write(saver::FINAL, &app.to_session()) {
            drop(guard);
            eprintln!("mapvlm: session not saved: {e}");
            return Ok(());
        }
    }
    drop(guard);
    Ok(())
}
