//! The annotation screen (`annotate.md` §3): blind judgement of plans, one
//! [`Component`](crate::workbench::component::Component) of the TUI with its
//! own state ([`state`]), update ([`update`]) and drawing ([`view`]). It
//! shares the workbench's key table (its contexts `Annotate…`), help
//! overlay, theme, terminal set-up and scene image widget.
//!
//! Reading the scene image and appending judgements happen off the loop:
//! images on blocking tasks, judgements on one writer thread that keeps
//! them in order and flushes each to disk before reporting back.

#[cfg(test)]
mod fixtures;
#[cfg(test)]
mod key_table;
pub mod state;
pub mod update;
pub mod view;

use std::time::{Duration, Instant};

use crossterm::event::{Event, MouseEventKind};
use ratatui::layout::Rect;
use tokio::sync::mpsc;

use crate::annotate::skips::skip_line;
use crate::annotate::{AnnotationWriter, Judgement, Verdict};
use crate::workbench::component::Component;
use crate::workbench::graphics::{Graphics, Request};
use crate::workbench::scene_image;
use crate::workbench::scroll::WHEEL_LINES;
use crate::workbench::shared::{spawn_signal_watch, unix_now};
use crate::workbench::terminal_query;
use crate::workbench::theme::Theme;
use crate::workbench::TuiError;
use state::{Clock, Cmd, Judging, Msg, Scene, Setup};

/// What the annotation screen is opened with.
pub struct Options {
    /// The items, guidelines and judgements the screen starts from.
    pub setup: Setup,
    /// The writer of the annotations file, opened already.
    pub writer: AnnotationWriter,
    /// The writer of the skips file beside it ([`crate::annotate::skips`]).
    pub skips: AnnotationWriter,
    /// The theme.
    pub theme: Theme,
    /// How images are drawn (`--graphics`): `auto` asks the terminal.
    pub graphics: Request,
    /// How long the terminal has to answer the start-up query.
    pub query_timeout: Duration,
}

/// How the sitting ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outcome {
    /// Units judged, of all.
    pub judged: usize,
    /// Units in all.
    pub total: usize,
    /// Lines that could not be written (already shown on screen).
    pub failures: Vec<String>,
}

/// A line for the writer thread.
enum Write {
    /// A judgement, and what was current before it (restored if the
    /// line cannot be written).
    Judgement(Box<Judgement>, Option<Verdict>),
    /// A line of the skips file.
    Skip(String),
}

/// Starts the writer thread: it appends each line in the order sent and
/// reports a failure back as [`Msg::NotSaved`] (a judgement) or as a
/// warning (a skip).
fn spawn_writer(
    mut writer: AnnotationWriter,
    mut skips: AnnotationWriter,
    msgs: mpsc::UnboundedSender<Msg>,
) -> (std::sync::mpsc::Sender<Write>, std::thread::JoinHandle<()>) {
    let (tx, rx) = std::sync::mpsc::channel::<Write>();
    let handle = std::thread::spawn(move || {
        for line in rx {
            match line {
                Write::Judgement(judgement, previous) => {
                    if let Err(e) = writer.append(&judgement) {
                        let _ = msgs.send(Msg::NotSaved {
                            subject: judgement.subject,
                            previous,
                            error: e.to_string(),
                        });
                    }
                }
                Write::Skip(text) => {
                    if let Err(e) = skips.append_text(&text) {
                        let _ = msgs.send(Msg::SkipNotSaved(e.to_string()));
                    }
                }
            }
        }
    });
    (tx, handle)
}

/// Reads the user's input on a thread of its own: first the rest of a late
/// answer to the start-up query (its keys kept, its replies dropped), then
/// crossterm's events.
fn spawn_input(
    msgs: mpsc::UnboundedSender<Msg>,
    resized: mpsc::UnboundedSender<(u16, u16)>,
    late: Option<terminal_query::Late>,
) {
    std::thread::spawn(move || {
        if let Some(late) = late {
            late.drain(|key| {
                let _ = msgs.send(Msg::Key(key));
            });
            if let Ok(size) = crossterm::terminal::size() {
                let _ = resized.send(size);
            }
        }
        read_events(&msgs, &resized);
    });
}

fn read_events(msgs: &mpsc::UnboundedSender<Msg>, resized: &mpsc::UnboundedSender<(u16, u16)>) {
    loop {
        let msg = match crossterm::event::read() {
            Ok(Event::Key(key)) => Msg::Key(key),
            Ok(Event::Mouse(mouse)) => match mouse.kind {
                MouseEventKind::ScrollDown => Msg::Wheel(WHEEL_LINES),
                MouseEventKind::ScrollUp => Msg::Wheel(-WHEEL_LINES),
                _ => continue,
            },
            Ok(Event::Resize(w, h)) => {
                if resized.send((w, h)).is_err() {
                    return;
                }
                continue;
            }
            Ok(_) => continue,
            Err(_) => {
                // The terminal is gone: stop (a zero size).
                let _ = resized.send((0, 0));
                return;
            }
        };
        if msgs.send(msg).is_err() {
            return;
        }
    }
}

/// Asks for the scene image to be encoded for the area the screen shows it
/// in, once per image and area, on a blocking task (resizing and encoding
/// are slow; the loop keeps reading keys): the result comes back as a
/// message naming the image file. The cells the picture leaves are padded
/// with `theme`'s background.
fn request_image(
    screen: &mut Judging,
    graphics: &Graphics,
    theme: &Theme,
    area: Rect,
    msgs: &mpsc::UnboundedSender<Msg>,
) {
    let Some(wanted) = view::image_area(area, screen) else {
        return;
    };
    if screen.image.as_ref().is_some_and(|(at, _)| *at == wanted) {
        return;
    }
    let Scene::Loaded(path, image) = &screen.scene else {
        return;
    };
    let request = (path.clone(), wanted);
    if screen.requested.as_ref() == Some(&request) {
        return;
    }
    screen.requested = Some(request);
    let (graphics, image, path, msgs) =
        (graphics.clone(), image.clone(), path.clone(), msgs.clone());
    let background = theme.picture_background();
    tokio::task::spawn_blocking(move || {
        let msg = match scene_image::encode(&graphics, &image, wanted, background) {
            Ok(encoded) => Msg::ImageReady(path, encoded),
            Err(e) => Msg::ImageUndrawable(path, e.to_string()),
        };
        let _ = msgs.send(msg);
    });
}

/// Opens the screen and runs it until the user quits; the terminal is
/// restored on every way out.
pub fn run(options: Options) -> Result<Outcome, TuiError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()?;
    rt.block_on(run_async(options))
}

async fn run_async(options: Options) -> Result<Outcome, TuiError> {
    let started = Instant::now();
    let clock = |start: Instant| Clock {
        elapsed: start.elapsed(),
        unix: unix_now(),
    };
    let (mut screen, first) = Judging::new(options.setup, clock(started));
    let theme = options.theme;
    let (guard, mut terminal) = crate::workbench::runtime::setup_terminal()?;
    let (msg_tx, mut msg_rx) = mpsc::unbounded_channel::<Msg>();
    let (size_tx, mut size_rx) = mpsc::unbounded_channel::<(u16, u16)>();
    // Asked before the input thread exists, so no key is lost; keys typed
    // meanwhile go first.
    let no_color = crate::workbench::theme::no_color_requested();
    let probe = terminal_query::probe(options.graphics, options.query_timeout, no_color);
    for key in probe.typed {
        let _ = msg_tx.send(Msg::Key(key));
    }
    let size = terminal.size()?;
    let _ = size_tx.send((size.width, size.height));
    // Held to the end: dropping it puts tmux's option back.
    let _passthrough = probe.passthrough;
    if let Some(notice) = probe.notice {
        // After what the screen already says (the start-up notices).
        screen.status = Some(match screen.status.take() {
            Some((first, severity)) => (format!("{first} · {notice}"), severity),
            None => (notice, state::Severity::Warn),
        });
    }
    let graphics = probe.graphics;
    spawn_input(msg_tx.clone(), size_tx.clone(), probe.late);
    let quit = size_tx.clone();
    // A zero size is the loop's sign to stop.
    spawn_signal_watch(move || {
        let _ = quit.send((0, 0));
    });
    let size = terminal.size()?;
    screen.update(Msg::Resize(size.width, size.height));
    let (writer, writer_thread) = spawn_writer(options.writer, options.skips, msg_tx.clone());
    let annotator = screen.annotator.clone();
    let mut failures = Vec::new();
    let execute = |cmd: Cmd, failures: &mut Vec<String>| match cmd {
        Cmd::Append {
            judgement,
            previous,
        } => {
            if writer.send(Write::Judgement(judgement, previous)).is_err() {
                failures.push("the writer stopped; judgements after this were not saved".into());
            }
        }
        Cmd::Skip { subject, skipped } => {
            let line = skip_line(&subject, &annotator, skipped, unix_now());
            if writer.send(Write::Skip(line)).is_err() {
                failures.push("the writer stopped; skips after this were not saved".into());
            }
        }
        Cmd::LoadImage(path) => {
            let msgs = msg_tx.clone();
            tokio::task::spawn_blocking(move || {
                let read = scene_image::read(&path);
                let _ = msgs.send(Msg::Image(path, read));
            });
        }
    };
    for cmd in first {
        execute(cmd, &mut failures);
    }
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    let ascii = !crate::locale::utf8_locale();
    loop {
        let area = terminal.get_frame().area();
        request_image(&mut screen, &graphics, &theme, area, &msg_tx);
        terminal.draw(|f| {
            let area = f.area();
            screen.draw(f, area, &theme);
            if ascii {
                crate::workbench::shared::fold_to_ascii(f.buffer_mut());
            }
        })?;
        let msg = tokio::select! {
            msg = msg_rx.recv() => msg,
            size = size_rx.recv() => match size {
                Some((0, 0)) | None => break,
                Some((w, h)) => {
                    terminal.resize(Rect::new(0, 0, w, h))?;
                    screen.update(Msg::Resize(w, h));
                    continue;
                }
            },
            _ = tick.tick() => Some(Msg::Tick(clock(started))),
        };
        let Some(msg) = msg else { break };
        if let Msg::NotSaved { error, .. } = &msg {
            failures.push(error.clone());
        }
        if matches!(msg, Msg::Key(_)) {
            screen.update(Msg::Tick(clock(started)));
        }
        for cmd in screen.update(msg) {
            execute(cmd, &mut failures);
        }
        if screen.quit {
            break;
        }
    }
    drop(writer);
    // Every line sent is on disk before the terminal is given back.
    let _ = writer_thread.join();
    drop(guard);
    Ok(Outcome {
        judged: screen.judged(),
        total: screen.units.len(),
        failures,
    })
}
