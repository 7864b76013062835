//! The scene image in a real sixel terminal: xterm (`-ti vt340`) on a
//! virtual X server of the test's own (Xvfb), the workbench on alfred30's
//! first task, directly and inside tmux, read back from screenshots
//! (ImageMagick's `import`). The Scene pane's pixels are the picture (a
//! luminance spread and a correlation with the task image scaled to the
//! pane's pixel box, found from the layout and the font), they are as they
//! were once the help has come and gone, and the zoomed scene is a picture
//! in xterm's default configuration (at most 1000×1000 pixels a graphic).
//!
//! The test plays the keyboard through the terminal's own pty: xterm runs
//! on a pty whose master the test opened (`xterm -S`), so every key goes
//! where a typed one goes. Each case has an X server of its own (cheap, and
//! windows of cases running at once never cover each other), stopped when
//! the case ends, failed or not. The screenshots stay in
//! `target/tmp/xterm-shots/` for a look.

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use image::{DynamicImage, RgbImage};
use mapvlm::workbench::layout::{pane_rects, Screen};
use mapvlm::workbench::panes::scene::scene_image_area;
use mapvlm::workbench::panes::Pane;
use ratatui::layout::{Rect, Size};
use ratatui_image::{FontSize, Resize};

use crate::common;
use common::tmux::Tmux;
use common::workbench::UserHome;

/// The terminal's size in cells.
const COLS: u16 = 120;
const ROWS: u16 = 40;

/// How long a wait lasts before it fails the case with what it last saw.
const WAIT: Duration = Duration::from_secs(60);

/// xterm's default largest graphic (`maxGraphicSize`), in pixels.
const XTERM_MAX_GRAPHIC: u32 = 1000;

/// The largest graphic xterm draws in a window of `cell`-sized cells: its
/// default `maxGraphicSize`, or the window where that is smaller (what it
/// answers to XTSMGRAPHICS).
fn largest_graphic(cell: (u32, u32)) -> (u32, u32) {
    (
        XTERM_MAX_GRAPHIC.min(u32::from(COLS) * cell.0),
        XTERM_MAX_GRAPHIC.min(u32::from(ROWS) * cell.1),
    )
}

/// A bitmap font of the X server's (xfonts-base, which xterm recommends),
/// so a cell's size in pixels is known.
struct Font {
    name: &'static str,
    cell: (u32, u32),
}

/// 6×13: 720×520 pixels for the whole terminal, small and quick.
const SMALL: Font = Font {
    name: "-misc-fixed-medium-r-semicondensed--13-120-75-75-c-60-iso10646-1",
    cell: (6, 13),
};

/// 10×20: a zoomed Scene pane 1,180 pixels wide, wider than xterm's
/// largest graphic.
const LARGE: Font = Font {
    name: "-misc-fixed-medium-r-normal--20-200-75-75-c-100-iso10646-1",
    cell: (10, 20),
};

/// Starts `command`, failing the test with the tool's name and the
/// package that brings it when it is not installed.
fn spawn(command: &mut Command, tool: &str, package: &str) -> Child {
    command.spawn().unwrap_or_else(|e| {
        panic!("{tool} cannot be run ({e}): install {package} to run this test (.ci/run does)")
    })
}

/// A virtual X server of one case, on a display number it chose itself
/// (`-displayfd`); stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Xvfb {
        let mut child = spawn(
            Command::new("Xvfb")
                .args(["-displayfd", "1", "-nolisten", "tcp", "-screen", "0"])
                .arg("1280x1024x24")
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::null()),
            "Xvfb",
            "xvfb",
        );
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(stdout).read_line(&mut line);
            let _ = tx.send(line);
        });
        let number = rx.recv_timeout(WAIT).unwrap_or_default();
        let number = number.trim();
        if number.is_empty() || !number.chars().all(|c| c.is_ascii_digit()) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("Xvfb did not say its display number (it printed {number:?})");
        }
        Xvfb {
            child,
            display: format!(":{number}"),
        }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A pseudo-terminal: the master side (the terminal's) and the slave side
/// (the program's), both closed on exec unless handed on.
fn open_pty() -> (OwnedFd, File, PathBuf) {
    // SAFETY: plain libc calls on a descriptor this function owns.
    unsafe {
        let master = libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC);
        assert!(
            master >= 0,
            "posix_openpt: {}",
            std::io::Error::last_os_error()
        );
        let master = OwnedFd::from_raw_fd(master);
        assert_eq!(libc::grantpt(master.as_raw_fd()), 0, "grantpt");
        assert_eq!(libc::unlockpt(master.as_raw_fd()), 0, "unlockpt");
        let mut name = [0 as libc::c_char; 128];
        assert_eq!(
            libc::ptsname_r(master.as_raw_fd(), name.as_mut_ptr(), name.len()),
            0,
            "ptsname_r"
        );
        let path = PathBuf::from(
            std::ffi::CStr::from_ptr(name.as_ptr())
                .to_string_lossy()
                .into_owned(),
        );
        let slave = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOCTTY | libc::O_CLOEXEC)
            .open(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        (master, slave, path)
    }
}

/// xterm in sixel mode (`-ti vt340`, otherwise its defaults) on a pty the
/// test holds the master of, and the program running in it.
struct Xterm {
    display: String,
    font: &'static Font,
    window: String,
    master: File,
    slave: Option<File>,
    xterm: Child,
    program: Option<Child>,
}

impl Xterm {
    /// Opens xterm, COLS×ROWS cells of `font`, on `x`, and waits for its
    /// window.
    fn open(x: &Xvfb, font: &'static Font) -> Xterm {
        let (master, slave, path) = open_pty();
        let fd = master.as_raw_fd();
        let mut command = Command::new("xterm");
        command
            .env("DISPLAY", &x.display)
            .args(["-ti", "vt340", "-b", "0", "-fn", font.name])
            .arg("-geometry")
            .arg(format!("{COLS}x{ROWS}+0+0"))
            .arg(format!("-S{}/{fd}", path.display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        // SAFETY: only fcntl between fork and exec. xterm is handed the
        // master as the descriptor `-S` names.
        unsafe {
            command.pre_exec(move || {
                let flags = libc::fcntl(fd, libc::F_GETFD);
                if flags < 0 || libc::fcntl(fd, libc::F_SETFD, flags & !libc::FD_CLOEXEC) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let mut xterm = spawn(&mut command, "xterm", "xterm");
        // xterm says its window id on the pty once the window is up.
        let mut line = Vec::new();
        let start = Instant::now();
        while !line.ends_with(b"\n") {
            if let Some(status) = xterm.try_wait().unwrap() {
                panic!("xterm ended before its window was up ({status}); is the font {} installed (xfonts-base)?", font.name);
            }
            assert!(start.elapsed() < WAIT, "xterm did not open its window");
            if readable(&slave, 100) {
                let mut buf = [0u8; 64];
                let n = std::io::Read::read(&mut &slave, &mut buf).unwrap();
                line.extend_from_slice(&buf[..n]);
            }
        }
        let window = String::from_utf8_lossy(&line).trim().to_string();
        assert!(
            !window.is_empty() && window.chars().all(|c| c.is_ascii_hexdigit()),
            "xterm's window id: {window:?}"
        );
        Xterm {
            display: x.display.clone(),
            font,
            window: format!("0x{window}"),
            master: File::from(master),
            slave: Some(slave),
            xterm,
            program: None,
        }
    }

    /// Runs `command` in the terminal (its controlling terminal, as a
    /// shell would run it: `setsid -c`).
    fn run(&mut self, mut command: Command) {
        let slave = self.slave.take().expect("one program a terminal");
        command
            .stdin(slave.try_clone().unwrap())
            .stdout(slave.try_clone().unwrap())
            .stderr(slave);
        self.program = Some(spawn(&mut command, "setsid", "util-linux"));
    }

    /// Types `bytes`.
    fn send(&self, bytes: &[u8]) {
        (&self.master).write_all(bytes).unwrap();
    }

    /// What the window shows now.
    fn shot(&self) -> RgbImage {
        let out = spawn(
            Command::new("import")
                .env("DISPLAY", &self.display)
                .args(["-window", &self.window, "png:-"])
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped()),
            "import",
            "imagemagick",
        )
        .wait_with_output()
        .unwrap();
        assert!(
            out.status.success(),
            "import: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let shot = image::load_from_memory(&out.stdout)
            .expect("import wrote a PNG")
            .to_rgb8();
        let (cw, ch) = self.font.cell;
        assert_eq!(
            (shot.width(), shot.height()),
            (u32::from(COLS) * cw, u32::from(ROWS) * ch),
            "the window is {COLS}×{ROWS} cells of {cw}×{ch} pixels"
        );
        shot
    }

    /// Takes screenshots until `check` accepts one and returns it (saved as
    /// `NAME.png`); fails after [`WAIT`] with `check`'s last word, the last
    /// screenshot saved as `NAME-failed.png`.
    fn wait_for<T>(&self, name: &str, check: impl Fn(&RgbImage) -> Result<T, String>) -> T {
        let start = Instant::now();
        loop {
            let shot = self.shot();
            match check(&shot) {
                Ok(v) => {
                    save(&shot, name);
                    return v;
                }
                Err(why) if start.elapsed() > WAIT => {
                    let path = save(&shot, &format!("{name}-failed"));
                    panic!(
                        "timed out waiting for {name}: {why} (see {})",
                        path.display()
                    );
                }
                Err(_) => std::thread::sleep(Duration::from_millis(100)),
            }
        }
    }

    /// Presses `q` and waits for the program to end; returns its exit code.
    fn quit(&mut self) -> Option<i32> {
        self.send(b"q");
        let program = self.program.as_mut().expect("a program runs");
        let start = Instant::now();
        loop {
            if let Some(status) = program.try_wait().unwrap() {
                return status.code();
            }
            assert!(start.elapsed() < WAIT, "the program did not quit");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Xterm {
    fn drop(&mut self) {
        if let Some(program) = &mut self.program {
            let _ = program.kill();
            let _ = program.wait();
        }
        let _ = self.xterm.kill();
        let _ = self.xterm.wait();
    }
}

/// Whether `file` has something to read within `ms` milliseconds.
fn readable(file: &File, ms: i32) -> bool {
    let mut fd = libc::pollfd {
        fd: file.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    // SAFETY: one pollfd on a descriptor `file` owns.
    unsafe { libc::poll(&mut fd, 1, ms) > 0 }
}

/// Saves `shot` as `NAME.png` among the kept screenshots; returns where.
fn save(shot: &RgbImage, name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("xterm-shots");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.png"));
    shot.save(&path).unwrap();
    path
}

/// alfred30's dataset folder and its first task's image (the task the
/// workbench opens on).
fn first_task() -> (PathBuf, DynamicImage) {
    let dataset = common::shared().join("data/alfred30");
    let tasks = std::fs::read_to_string(dataset.join("tasks.jsonl")).unwrap();
    let first: serde_json::Value = serde_json::from_str(tasks.lines().next().unwrap()).unwrap();
    let image = dataset.join(first["image"].as_str().unwrap());
    let image = image::open(&image).unwrap_or_else(|e| panic!("{}: {e}", image.display()));
    (dataset, image)
}

/// The workbench's command line on alfred30 in `home`.
fn workbench_args(home: &UserHome, dataset: &std::path::Path) -> Vec<String> {
    vec![
        "--dataset".into(),
        dataset.display().to_string(),
        "--session".into(),
        home.session_file().display().to_string(),
    ]
}

/// The workbench run directly in the terminal: `setsid -c mapvlm ARGS`
/// in `home`, outside any tmux or screen, `TERM=xterm` (xterm's own).
fn direct(home: &UserHome, dataset: &std::path::Path) -> Command {
    let mut command = home.command_program("setsid");
    command
        .args(["-c", "-w"])
        .arg(env!("CARGO_BIN_EXE_mapvlm"))
        .args(workbench_args(home, dataset));
    for name in ["TMUX", "TMUX_PANE", "STY", "TERM_PROGRAM", "NO_COLOR"] {
        command.env_remove(name);
    }
    command.env("TERM", "xterm");
    command
}

/// A rectangle of pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Pixels {
    x: u32,
    y: u32,
    width: u32,
    height: u32,
}

impl Pixels {
    /// The pixels of `cells` in a terminal of `cell`-sized cells.
    fn of(cells: Rect, cell: (u32, u32)) -> Pixels {
        Pixels {
            x: u32::from(cells.x) * cell.0,
            y: u32::from(cells.y) * cell.1,
            width: u32::from(cells.width) * cell.0,
            height: u32::from(cells.height) * cell.1,
        }
    }

    fn crop(&self, shot: &RgbImage) -> RgbImage {
        image::imageops::crop_imm(shot, self.x, self.y, self.width, self.height).to_image()
    }
}

/// The Scene pane as the workbench lays out a COLS×ROWS screen: in the
/// grid, or zoomed.
fn scene_pane(zoom: bool) -> Rect {
    let Screen::Panes { panes, .. } = pane_rects(Rect::new(0, 0, COLS, ROWS), Pane::Scene, zoom)
    else {
        panic!("{COLS}×{ROWS} lays out panes");
    };
    panes
        .into_iter()
        .find(|(p, _)| *p == Pane::Scene)
        .expect("a Scene pane")
        .1
}

/// Where the picture is drawn in `pane` (its pixels) and what it must look
/// like there: `image` scaled to fit the pane's image area (and the
/// largest graphic, `max` pixels), at the area's top left, as the
/// workbench scales it; and the pixels of the cells it is drawn in.
fn expected_picture(
    image: &DynamicImage,
    pane: Rect,
    cell: (u32, u32),
    max: (u32, u32),
) -> (Pixels, RgbImage, Pixels) {
    let area = scene_image_area(pane);
    let within = |cells: u16, limit: u32, px: u32| cells.min((limit / px) as u16);
    let available = Size::new(
        within(area.width, max.0, cell.0),
        within(area.height, max.1, cell.1),
    );
    let font = FontSize::new(cell.0 as u16, cell.1 as u16);
    let size = Resize::Scale(None).size_for(image, font, available);
    let (bw, bh) = (
        u32::from(size.width) * cell.0,
        u32::from(size.height) * cell.1,
    );
    let picture = image
        .resize(bw, bh, image::imageops::FilterType::Triangle)
        .to_rgb8();
    let at = Pixels::of(area, cell);
    (
        Pixels {
            width: picture.width(),
            height: picture.height(),
            ..at
        },
        picture,
        Pixels {
            width: bw,
            height: bh,
            ..at
        },
    )
}

/// The dark theme's background, which the workbench starts with.
const BACKGROUND: [u8; 3] = [0x1b, 0x1d, 0x23];

/// Whether the pixels of `cells` that the picture at `at` leaves are the
/// theme's background (not the terminal's own, which shows through a
/// sixel's unpainted pixels: white in xterm inside tmux), or how many are
/// not.
fn padding_is_background(shot: &RgbImage, cells: Pixels, at: Pixels) -> Result<(), String> {
    let inside = |x: u32, y: u32| {
        (at.x..at.x + at.width).contains(&x) && (at.y..at.y + at.height).contains(&y)
    };
    let mut padding = 0;
    let mut wrong = Vec::new();
    for y in cells.y..cells.y + cells.height {
        for x in cells.x..cells.x + cells.width {
            if inside(x, y) {
                continue;
            }
            padding += 1;
            let pixel = shot.get_pixel(x, y).0;
            // A sixel's colours are percentages: within 3 of each channel.
            if pixel.iter().zip(BACKGROUND).any(|(p, b)| p.abs_diff(b) > 3) {
                wrong.push((x, y, pixel));
            }
        }
    }
    match wrong.first() {
        None => Ok(()),
        Some((x, y, pixel)) => Err(format!(
            "{} of the {padding} pixels around the picture are not the background {BACKGROUND:?} (the first at ({x}, {y}) is {pixel:?})",
            wrong.len()
        )),
    }
}

/// Luminance, 0 to 255.
fn luma(image: &RgbImage) -> Vec<f64> {
    DynamicImage::ImageRgb8(image.clone())
        .to_luma8()
        .pixels()
        .map(|p| f64::from(p.0[0]))
        .collect()
}

/// What the screenshot shows in `at` against the picture it should be:
/// the luminance's standard deviation (0 to 255) and its correlation with
/// the picture's, or why it is not the picture.
fn is_picture(shot: &RgbImage, at: Pixels, picture: &RgbImage) -> Result<(f64, f64), String> {
    let shown = luma(&at.crop(shot));
    let wanted = luma(picture);
    let n = shown.len() as f64;
    let mean = shown.iter().sum::<f64>() / n;
    let spread = (shown.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let r = mapvlm::stats::correlation::Paired::new(&shown, &wanted)
        .correlations()
        .pearson
        .unwrap_or(0.0);
    if spread >= 20.0 && r >= 0.8 {
        Ok((spread, r))
    } else {
        Err(format!(
            "the {}×{} pixels at ({}, {}): luminance spread {spread:.1}/255 (at least 20), correlation {r:.3} with the picture (at least 0.8)",
            at.width, at.height, at.x, at.y
        ))
    }
}

/// The picture in the grid's Scene pane, then `?` and Esc: the pane's
/// pixels as they were before the help. `label` names the screenshots.
fn picture_then_help(term: &Xterm, image: &DynamicImage, label: &str) {
    let cell = term.font.cell;
    let pane = scene_pane(false);
    let (at, picture, cells) = expected_picture(image, pane, cell, largest_graphic(cell));
    let (spread, r) = term.wait_for(label, |shot| {
        let seen = is_picture(shot, at, &picture)?;
        padding_is_background(shot, cells, at)?;
        Ok(seen)
    });
    eprintln!("{label}: spread {spread:.1}/255, correlation {r:.3}");
    let pane_pixels = Pixels::of(pane, cell);
    let before = pane_pixels.crop(&term.shot());
    term.send(b"?");
    term.wait_for(&format!("{label}-help"), |shot| {
        (pane_pixels.crop(shot) != before)
            .then_some(())
            .ok_or_else(|| "the help does not cover the Scene pane".to_string())
    });
    term.send(b"\x1b");
    term.wait_for(&format!("{label}-after-help"), |shot| {
        let after = pane_pixels.crop(shot);
        let differ = after
            .pixels()
            .zip(before.pixels())
            .filter(|(a, b)| a != b)
            .count();
        (differ == 0)
            .then_some(())
            .ok_or_else(|| format!("{differ} pixels of the Scene pane differ from before the help"))
    });
}

/// The workbench on alfred30's first task run directly in xterm (`font`)
/// on an X server of its own; dropped in this order: the workbench and
/// xterm, the X server, the home. With the task's image.
fn directly_in_xterm(font: &'static Font) -> (Xterm, Xvfb, UserHome, DynamicImage) {
    let (dataset, image) = first_task();
    let home = UserHome::new();
    let x = Xvfb::start();
    let mut term = Xterm::open(&x, font);
    term.run(direct(&home, &dataset));
    (term, x, home, image)
}

#[test]
fn directly_in_xterm_the_scene_pane_is_the_picture_before_and_after_the_help() {
    let (mut term, _x, _home, image) = directly_in_xterm(&SMALL);
    picture_then_help(&term, &image, "direct");
    assert_eq!(term.quit(), Some(0));
}

#[test]
fn inside_tmux_in_xterm_the_scene_pane_is_the_picture_before_and_after_the_help() {
    let (dataset, image) = first_task();
    let home = UserHome::new();
    let x = Xvfb::start();
    let tmux = Tmux::new("xterm");
    let mut term = Xterm::open(&x, &SMALL);
    // The session started from the terminal, as a user starts one (a
    // session started detached keeps tmux's default cell of 16×32 pixels
    // until its size changes, and the picture is drawn at that size).
    let mut client = Command::new("setsid");
    client
        .args(["-c", "-w", "tmux", "-L", tmux.socket()])
        .args(["new-session", "-s", "w", "sleep 600"])
        .env("TERM", "xterm");
    term.run(client);
    common::tmux::wait("the tmux session in xterm", || {
        let clients = tmux.cmd(&["list-clients"]);
        (!clients.trim().is_empty()).then_some(()).ok_or(clients)
    });
    tmux.cmd(&["set-option", "-g", "status", "off"]);
    let args = workbench_args(&home, &dataset);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    tmux.cmd(&["respawn-pane", "-k", "-t", "w", &home.shell_line(&args)]);
    picture_then_help(&term, &image, "tmux");
    tmux.keys("w", &["q"]);
    let status = home.path().join("status");
    common::tmux::wait("the workbench to quit", || {
        std::fs::read_to_string(&status)
            .ok()
            .filter(|s| s.ends_with('\n'))
            .ok_or_else(|| tmux.screen("w"))
    });
    assert_eq!(std::fs::read_to_string(&status).unwrap().trim(), "0");
}

#[test]
fn the_zoomed_scene_is_a_picture_within_xterms_default_largest_graphic() {
    let (mut term, _x, _home, image) = directly_in_xterm(&LARGE);
    let cell = LARGE.cell;
    let (at, picture, _) = expected_picture(&image, scene_pane(false), cell, largest_graphic(cell));
    term.wait_for("zoom-grid", |shot| is_picture(shot, at, &picture));
    // From the Plan pane, where the workbench starts, back to the Scene.
    term.send(b"\x1b[Z\x1b[Z\x1b[Z");
    term.send(b"z");
    let zoomed = scene_pane(true);
    assert!(
        u32::from(scene_image_area(zoomed).width) * cell.0 > XTERM_MAX_GRAPHIC,
        "the zoomed pane is wider than xterm's largest graphic"
    );
    let (at, picture, _) = expected_picture(&image, zoomed, cell, largest_graphic(cell));
    assert!(at.width <= XTERM_MAX_GRAPHIC && at.width > 900, "{at:?}");
    let (spread, r) = term.wait_for("zoomed", |shot| is_picture(shot, at, &picture));
    eprintln!("zoomed: spread {spread:.1}/255, correlation {r:.3}, {at:?}");
    assert_eq!(term.quit(), Some(0));
}
