//! The Scene pane: the task's image, read and encoded off the loop.

use std::path::PathBuf;
use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use super::Shared;
use crate::demo;
use crate::workbench::panes::{draw_scrolled, highlighted, pane_block, Pane};
use crate::workbench::scene_image::{self, Encoded};
use crate::workbench::scroll;

/// The Scene pane's state: the image and its encoding for the terminal.
pub struct ScenePane {
    /// Whether the image is shown.
    pub enabled: bool,
    /// The image, once read.
    pub image: Option<Arc<DynamicImage>>,
    /// The image encoded for an area of the terminal.
    pub protocol: Option<Encoded>,
    /// The task's table as its agents read it (or why it cannot be read),
    /// shown in place of the picture on a table approach.
    pub table: Option<(PathBuf, Result<String, String>)>,
    /// The area an encoding is under way for, off the loop.
    pub requested: Option<Rect>,
    /// How the image is drawn on this terminal and why, as the header says
    /// it ([`crate::workbench::graphics::Graphics::summary`]); empty (and
    /// not shown) until the terminal has been asked.
    pub graphics: String,
    /// The status line's message about this image, if it still shows one:
    /// it goes when the image does.
    pub message: Option<String>,
    /// Holds a picture the terminal paints back for a frame, as an overlay
    /// does: the next frame without it sends the picture again.
    pub hold: bool,
}

impl ScenePane {
    /// The built-in demo's scene, shown.
    pub fn demo() -> Self {
        ScenePane {
            enabled: true,
            image: Some(Arc::new(DynamicImage::ImageRgb8(demo::scene_image()))),
            protocol: None,
            table: None,
            requested: None,
            graphics: String::new(),
            message: None,
            hold: false,
        }
    }
}

/// The table's lines as the Scene pane shows them in `body`: wrapped, the
/// search's hits highlighted; what is wrong with the file, or that it is
/// being read.
fn table_lines(app: &Shared, body: Rect) -> Vec<Line<'static>> {
    let t = app.theme;
    let text: Vec<Line> = match &app.panes.scene.table {
        Some((_, Ok(table))) => table
            .lines()
            .map(|l| Line::from(highlighted(l, &app.panes.search, t.base, t.highlight)))
            .collect(),
        Some((_, Err(why))) => vec![Line::from(Span::styled(why.clone(), t.warn))],
        None => vec![Line::from(Span::styled("reading the table…", t.muted))],
    };
    scroll::wrap_text(&text, body.width.into())
}

/// The furthest the Scene pane scrolls in `area`: through the table when it
/// shows one, not at all over a picture.
pub(crate) fn scroll_limit(app: &Shared, area: Rect) -> usize {
    if !app.work.shows_table() {
        return 0;
    }
    let body = scene_image_area(area);
    table_lines(app, body)
        .len()
        .saturating_sub(usize::from(body.height))
}

pub(crate) fn draw(frame: &mut Frame, app: &Shared, area: Rect) {
    let t = app.theme;
    let block = pane_block(app, Pane::Scene, None, area.width);
    let inner = block.inner(area);
    let image_area = scene_image_area(area);
    if app.work.shows_table() {
        // A table approach reads the table, not the picture: shown as the
        // agents get it, scrolled with the pane's keys.
        let lines = table_lines(app, image_area);
        draw_scrolled(frame, app, Pane::Scene, block, area, image_area, lines);
    } else {
        frame.render_widget(block, area);
    }
    let caption = scroll::cut_line(
        Line::from(highlighted(
            &app.work.task.text,
            &app.panes.search,
            t.base,
            t.highlight,
        )),
        usize::from(inner.width),
    );
    frame.render_widget(Paragraph::new(caption), Rect { height: 1, ..inner });
    if app.work.shows_table() {
        return;
    }
    let (encoded, note) = if !app.panes.scene.enabled {
        (None, "image off (i shows it)")
    } else if app.panes.scene.image.is_none() {
        // A task with an image file says so while it is read, or that it
        // could not be: "no image" only when it has none.
        let note = match (&app.work.task.image, &app.panes.scene.message) {
            (None, _) => "no image for this task",
            (Some(_), Some(_)) => "the image cannot be shown (M says why)",
            (Some(_), None) => "reading the image…",
        };
        (None, note)
    } else {
        (app.panes.scene.protocol.as_ref(), "drawing the image…")
    };
    scene_image::draw(
        frame,
        image_area,
        encoded,
        note,
        t.muted,
        app.overlay_open || app.panes.scene.hold,
    );
}

/// The part of the Scene pane the image is drawn in: inside the border,
/// below the caption line.
pub fn scene_image_area(pane: Rect) -> Rect {
    let inner = Block::bordered().inner(pane);
    Rect {
        y: inner.y.saturating_add(1),
        height: inner.height.saturating_sub(1),
        ..inner
    }
}
