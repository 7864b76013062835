//! The scene image on terminals that answer the start-up query in
//! different ways (a pty whose other side the test plays), and inside tmux:
//! which protocol is chosen and said, that keys typed meanwhile count, and
//! that tmux's options are left as they were.

use std::time::{Duration, Instant};

use crate::common;
use common::pty::Pty;
use common::tmux::Tmux;

/// What every sixel the image encoder writes starts with, after `ESC P`
/// and its first two parameters.
const SIXEL: &str = ";0q\"";

/// kitty's placeholder character, as UTF-8.
const PLACEHOLDER: &str = "\u{10EEEE}";

/// kitty's answer to the query: graphics, its version, sixels, a cell
/// size, then the status report that ends it.
fn kitty_answer(version: &str) -> Vec<u8> {
    format!("\x1b_Gi=31;OK\x1b\\\x1bP>|kitty({version})\x1b\\\x1b[?62;4c\x1b[6;20;10t\x1b[0n")
        .into_bytes()
}

fn contains(haystack: &[u8], needle: &str) -> bool {
    haystack
        .windows(needle.len())
        .any(|w| w == needle.as_bytes())
}

/// Columns enough for the header to give the graphics' reason whole (at
/// 120 it gives way to the providers and models).
const WIDE: u16 = 160;

#[test]
fn an_answer_after_600_ms_falls_back_saying_why_and_keys_typed_meanwhile_arrows_too_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start_wide(dir.path(), "", &[], WIDE);
    pty.wait_for("the graphics query", "\x1b[5n");
    // The ground-truth picker, down to annotator B, chosen: typed before
    // the terminal answers.
    pty.send(b"g");
    pty.send(b"\x1b[B");
    pty.send(b"\r");
    std::thread::sleep(Duration::from_millis(600));
    pty.send(&kitty_answer("0.35.0"));
    pty.wait_screen(
        "the header saying why and annotator B's ground truth",
        |s| {
            s.contains("halfblocks: no answer from the terminal in 400 ms")
                && s.contains("demo annotator B")
        },
    );
    assert!(!contains(&pty.output(), PLACEHOLDER));
    // The reason kept whole in the message log, whatever the header's room.
    pty.send(b"M");
    pty.wait_screen("the message log", |s| {
        s.contains("scene image: halfblocks: no answer from the terminal in 400 ms (--graphics sixel forces)")
    });
    pty.send(b"q");
    pty.send(b"q");
    assert_eq!(pty.exit_code(), Some(0));
}

#[test]
fn graphics_sixel_forces_sixel_when_the_terminal_does_not_answer() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start_wide(dir.path(), "--graphics sixel", &[], WIDE);
    pty.wait_for("the graphics query", "\x1b[5n");
    pty.wait_screen("the header", |s| {
        s.contains("sixel: asked for (--graphics sixel)")
    });
    pty.wait_for("a sixel", SIXEL);
    pty.send(b"q");
    assert_eq!(pty.exit_code(), Some(0));
}

#[test]
fn kitty_0_26_gets_no_placeholders_and_kitty_0_35_does() {
    let dir = tempfile::tempdir().unwrap();
    let mut old = Pty::start_wide(dir.path(), "", &[], WIDE);
    old.wait_for("the graphics query", "\x1b[5n");
    old.send(&kitty_answer("0.26.5"));
    old.wait_screen("the header", |s| {
        s.contains("kitty (direct placement): kitty(0.26.5)")
    });
    old.wait_for("the picture placed at the cursor", "\x1b_Ga=T,f=32,");
    assert!(!contains(&old.output(), PLACEHOLDER));
    old.send(b"q");
    assert_eq!(old.exit_code(), Some(0));

    let dir = tempfile::tempdir().unwrap();
    let mut new = Pty::start_wide(dir.path(), "", &[], WIDE);
    new.wait_for("the graphics query", "\x1b[5n");
    new.send(&kitty_answer("0.35.0"));
    new.wait_screen("the header", |s| {
        s.contains("kitty: kitty(0.35.0) answered kitty graphics")
    });
    new.wait_for("the placeholders", PLACEHOLDER);
    new.send(b"q");
    assert_eq!(new.exit_code(), Some(0));
}

#[test]
fn no_color_draws_the_scene_in_characters_without_a_colour_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let mut pty = Pty::start_wide(dir.path(), "", &[("NO_COLOR", "1")], WIDE);
    pty.wait_for("the graphics query", "\x1b[5n");
    // The picture: characters of the ramp from dark to light, and no error.
    pty.wait_screen("the header and the picture", |s| {
        s.contains("characters: no answer") && s.contains("%%%%") && s.contains("====")
    });
    pty.send(b"q");
    let code = pty.exit_code();
    let output = pty.output();
    assert_eq!(code, Some(0));
    let colours = sgr_colours(&output);
    assert!(colours.is_empty(), "colour attributes written: {colours:?}");
}

/// The SGR parameters that set a colour (30–38, 40–48, 90–97, 100–107)
/// in `bytes`.
fn sgr_colours(bytes: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(bytes);
    let mut found = Vec::new();
    for part in text.split("\x1b[").skip(1) {
        let Some(end) = part.find(|c: char| !(c.is_ascii_digit() || c == ';')) else {
            continue;
        };
        if !part[end..].starts_with('m') {
            continue;
        }
        for p in part[..end].split(';') {
            if let Ok(n) = p.parse::<u32>() {
                if matches!(n, 30..=38 | 40..=48 | 90..=97 | 100..=107) {
                    found.push(part[..end].to_string());
                }
            }
        }
    }
    found
}

#[test]
fn tmux_allow_passthrough_is_the_same_after_the_workbench_as_before() {
    let dir = tempfile::tempdir().unwrap();
    let tmux = Tmux::new("passthrough");
    let command = format!(
        "env -u NO_COLOR TERM=xterm-256color HOME={home} XDG_CONFIG_HOME={home}/.config XDG_CACHE_HOME={home}/.cache MAPVLM_MODELS={} {} --replay-delay 1 --session {home}/s.json; echo $? > {home}/status; sleep 60",
        common::pack_dir().display(),
        env!("CARGO_BIN_EXE_mapvlm"),
        home = dir.path().display(),
    );
    tmux.open("pt", 200, 60, "sleep 60");
    let before = tmux.cmd(&["show-options", "-p", "-t", "pt", "allow-passthrough"]);
    tmux.cmd(&["respawn-pane", "-k", "-t", "pt", &command]);
    tmux.wait_for("pt", "the notice that the option was turned on", |s| {
        s.contains("allow-passthrough turned on")
    });
    let during = tmux.cmd(&["show-options", "-p", "-t", "pt", "allow-passthrough"]);
    assert_eq!(during.trim(), "allow-passthrough on");
    tmux.keys("pt", &["q"]);
    let status = dir.path().join("status");
    let start = Instant::now();
    while !std::fs::read_to_string(&status).is_ok_and(|s| s.ends_with('\n')) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "mapvlm did not quit"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(std::fs::read_to_string(&status).unwrap().trim(), "0");
    let after = tmux.cmd(&["show-options", "-p", "-t", "pt", "allow-passthrough"]);
    assert_eq!(after, before);
}

mod frames {
    //! Frames of the workbench written through crossterm to a byte sink, as
    //! a terminal receives them: what is sent for the picture, and when.

    use std::io::Write;
    use std::sync::{Arc, Mutex};

    use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
    use image::DynamicImage;
    use mapvlm::workbench::app::{App, AppInit};
    use mapvlm::workbench::graphics::{luminance, Graphics, Kind, DEFAULT_MAX_PIXELS};
    use mapvlm::workbench::layout::{pane_rects, Screen};
    use mapvlm::workbench::message::Msg;
    use mapvlm::workbench::panes::scene::scene_image_area;
    use mapvlm::workbench::panes::Pane;
    use mapvlm::workbench::{prepare_image, render};
    use ratatui::backend::{CrosstermBackend, TestBackend};
    use ratatui::layout::Rect;
    use ratatui::style::Color;
    use ratatui::{Terminal, TerminalOptions, Viewport};
    use ratatui_image::FontSize;

    /// What the terminal was sent, shared with the test.
    #[derive(Clone, Default)]
    struct Sink(Arc<Mutex<Vec<u8>>>);

    impl Write for Sink {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Sink {
        fn take(&self) -> String {
            String::from_utf8_lossy(&std::mem::take(&mut *self.0.lock().unwrap())).into_owned()
        }
    }

    fn sixel(tmux: bool) -> Graphics {
        Graphics {
            kind: Kind::Sixel,
            font: FontSize::new(10, 20),
            tmux,
            max_pixels: DEFAULT_MAX_PIXELS,
            why: "test".into(),
        }
    }

    struct Bench {
        app: App,
        sink: Sink,
        terminal: Terminal<CrosstermBackend<Sink>>,
    }

    impl Bench {
        fn new() -> Bench {
            let (app, _) = App::new(AppInit::demo((120, 40), "no models in this test"));
            let sink = Sink::default();
            let terminal = Terminal::with_options(
                CrosstermBackend::new(sink.clone()),
                TerminalOptions {
                    viewport: Viewport::Fixed(Rect::new(0, 0, 120, 40)),
                },
            )
            .unwrap();
            Bench {
                app,
                sink,
                terminal,
            }
        }

        fn key(&mut self, c: KeyCode) {
            self.app
                .update(Msg::Key(KeyEvent::new(c, KeyModifiers::NONE)));
        }

        /// Draws a frame and returns what it sent.
        fn frame(&mut self) -> String {
            let app = &self.app;
            self.terminal.draw(|f| render::render(f, app)).unwrap();
            self.sink.take()
        }
    }

    fn sixels(sent: &str) -> usize {
        sent.matches(super::SIXEL).count()
    }

    #[test]
    fn the_picture_is_sent_once_after_each_overlay_closes_and_never_over_one() {
        let mut b = Bench::new();
        prepare_image(&mut b.app, &sixel(false));
        assert_eq!(sixels(&b.frame()), 1, "the first frame draws the picture");
        assert_eq!(sixels(&b.frame()), 0, "an unchanged frame sends nothing");
        for open in [KeyCode::Char('?'), KeyCode::Char('g')] {
            b.key(open);
            assert!(b.app.overlay.is_some(), "{open:?} opens an overlay");
            assert_eq!(sixels(&b.frame()), 0, "nothing is painted over the overlay");
            b.key(KeyCode::Esc);
            assert!(b.app.overlay.is_none());
            assert_eq!(
                sixels(&b.frame()),
                1,
                "the picture again after {open:?} Esc"
            );
            assert_eq!(sixels(&b.frame()), 0);
        }
    }

    #[test]
    fn a_picture_that_finishes_while_the_help_is_open_waits_for_it_to_close() {
        let mut b = Bench::new();
        b.frame();
        b.key(KeyCode::Char('?'));
        b.frame();
        prepare_image(&mut b.app, &sixel(false));
        assert_eq!(sixels(&b.frame()), 0, "the help stays on top");
        b.key(KeyCode::Esc);
        assert_eq!(sixels(&b.frame()), 1);
    }

    #[test]
    fn inside_tmux_the_picture_is_one_well_formed_pass_through() {
        let mut b = Bench::new();
        prepare_image(&mut b.app, &sixel(true));
        let sent = b.frame();
        let start = sent.find("\x1bPtmux;").expect("a pass-through wrapper");
        let rest = &sent[start..];
        // The wrapper ends at the first undoubled ESC \.
        let inner = mapvlm::workbench::graphics::tmux::unwrap_all(
            &rest[..wrapper_len(rest).expect("the wrapper is closed")],
        )
        .unwrap();
        assert_eq!(inner.len(), 1);
        assert!(inner[0].contains(super::SIXEL) && inner[0].ends_with("\x1b\\"));
    }

    /// The length of the pass-through wrapper `s` starts with.
    fn wrapper_len(s: &str) -> Option<usize> {
        let b = s.as_bytes();
        let mut i = "\x1bPtmux;".len();
        while i + 1 < b.len() {
            match (b[i], b[i + 1]) {
                (0x1b, 0x1b) => i += 2,
                (0x1b, b'\\') => return Some(i + 2),
                _ => i += 1,
            }
        }
        None
    }

    #[test]
    fn without_colour_the_scene_is_characters_by_luminance_with_no_colour() {
        let (mut app, _) = App::new(AppInit {
            no_color: true,
            ..AppInit::demo((120, 40), "no models in this test")
        });
        prepare_image(&mut app, &Graphics::text(true, "test"));
        let mut terminal = Terminal::new(TestBackend::new(120, 40)).unwrap();
        terminal.draw(|f| render::render(f, &app)).unwrap();
        let buf = terminal.backend().buffer().clone();
        assert!(
            buf.content()
                .iter()
                .all(|c| c.fg == Color::Reset && c.bg == Color::Reset),
            "a cell with a colour"
        );
        let Screen::Panes { panes, .. } = pane_rects(Rect::new(0, 0, 120, 40), app.focus, false)
        else {
            panic!("the grid");
        };
        let (_, pane) = panes.into_iter().find(|(p, _)| *p == Pane::Scene).unwrap();
        let area = scene_image_area(pane);
        // The picture as drawn: the rows holding ramp characters.
        let drawn: Vec<Vec<f64>> = (area.top()..area.bottom())
            .map(|y| {
                (area.left()..area.right())
                    .map(|x| buf[(x, y)].symbol().chars().next().unwrap_or(' '))
                    .map(|c| luminance::level(c).unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        let scene = DynamicImage::ImageRgb8(mapvlm::demo::scene_image());
        let size = ratatui_image::Resize::Scale(None).size_for(
            &scene,
            mapvlm::workbench::graphics::DEFAULT_FONT,
            area.as_size(),
        );
        let (cols, rows) = (usize::from(size.width), usize::from(size.height));
        assert!(rows > 4 && cols > 8, "a picture of {cols}×{rows} cells");
        assert!(
            drawn
                .iter()
                .take(rows)
                .all(|r| r.iter().take(cols).all(|v| v.is_finite())),
            "every cell of the picture is a character of the ramp"
        );
        let scene = scene
            .resize_exact(
                cols as u32,
                rows as u32,
                image::imageops::FilterType::Triangle,
            )
            .to_luma8();
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for (y, row) in drawn.iter().take(rows).enumerate() {
            for (x, v) in row.iter().take(cols).enumerate() {
                xs.push(*v);
                ys.push(f64::from(scene.get_pixel(x as u32, y as u32).0[0]) / 255.0);
            }
        }
        let r = mapvlm::stats::correlation::Paired::new(&xs, &ys)
            .correlations()
            .pearson
            .unwrap();
        assert!(r >= 0.6, "luminance correlation {r:.3}");
    }
}
