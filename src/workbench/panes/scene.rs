//! The Scene pane: the task's image, read and encoded off the loop.

use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui::text::Line;
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use crate::demo;
use crate::workbench::app::App;
use crate::workbench::panes::{highlighted, pane_block, Pane};
use crate::workbench::scene_image::{self, Encoded};

/// The Scene pane's state: the image and its encoding for the terminal.
pub struct ScenePane {
    /// Whether the image is shown.
    pub enabled: bool,
    /// The image, once read.
    pub image: Option<Arc<DynamicImage>>,
    /// The image encoded for an area of the terminal.
    pub protocol: Option<Encoded>,
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
            requested: None,
            graphics: String::new(),
            message: None,
            hold: false,
        }
    }
}

pub(crate) fn draw(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.looks.theme;
    let block = pane_block(app, Pane::Scene, None);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let caption = Line::from(highlighted(
        &app.work.task.text,
        &app.panes.search,
        t.base,
        t.highlight,
    ));
    frame.render_widget(Paragraph::new(caption), Rect { height: 1, ..inner });
    let image_area = scene_image_area(area);
    let (encoded, note) = if !app.panes.scene.enabled {
        (None, "image off (i shows it)")
    } else if app.panes.scene.image.is_none() {
        (None, "no image for this task")
    } else {
        (app.panes.scene.protocol.as_ref(), "drawing the image…")
    };
    scene_image::draw(
        frame,
        image_area,
        encoded,
        note,
        t.muted,
        app.overlay.is_some() || app.panes.scene.hold,
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
