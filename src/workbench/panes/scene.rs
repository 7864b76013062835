//! The Scene pane: the task's image, read and encoded off the loop.

use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui::text::Line;
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use crate::demo;
use crate::workbench::app::{App, Severity};
use crate::workbench::layout::{pane_rects, Screen};
use crate::workbench::message::Cmd;
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

impl App {
    pub(crate) fn load_scene(&mut self) -> Vec<Cmd> {
        self.scene.protocol = None;
        self.scene.requested = None;
        if let Some(message) = self.scene.message.take() {
            if self
                .status
                .as_ref()
                .is_some_and(|(text, _)| *text == message)
            {
                self.status = None;
            }
        }
        match &self.task.image {
            Some(path) => {
                self.scene.image = None;
                vec![Cmd::LoadImage(path.clone())]
            }
            None if self.is_demo() => {
                self.scene.image = Some(Arc::new(DynamicImage::ImageRgb8(demo::scene_image())));
                Vec::new()
            }
            None => {
                self.scene.image = None;
                Vec::new()
            }
        }
    }

    /// The terminal area the scene image is shown in now, when it is.
    pub fn image_area(&self) -> Option<Rect> {
        if !self.scene.enabled || self.scene.image.is_none() {
            return None;
        }
        let screen = Rect::new(0, 0, self.size.0, self.size.1);
        let Screen::Panes { panes, .. } = pane_rects(screen, self.focus, self.zoom) else {
            return None;
        };
        let (_, rect) = panes.into_iter().find(|(p, _)| *p == Pane::Scene)?;
        let inner = scene_image_area(rect);
        (inner.width > 0 && inner.height > 0).then_some(inner)
    }

    /// Where a picture is on the screen and whether it is held back (an
    /// overlay is open), when one is drawn: a picture kitty placed directly
    /// must be taken off whenever this changes.
    pub fn picture_shown(&self) -> Option<(Rect, bool)> {
        let area = self.image_area()?;
        let drawn = matches!(&self.scene.protocol, Some((r, _)) if *r == area);
        drawn.then_some((area, self.overlay.is_some()))
    }

    /// The terminal area the scene image should be encoded for, when it is
    /// shown and not yet encoded for that area.
    pub fn image_area_wanted(&self) -> Option<Rect> {
        let inner = self.image_area()?;
        let encoded = matches!(&self.scene.protocol, Some((r, _)) if *r == inner);
        (!encoded && self.scene.requested != Some(inner)).then_some(inner)
    }

    /// Shows `text` on the status line as a message about the scene image:
    /// it goes away with the image.
    pub(crate) fn image_status(&mut self, text: String) {
        self.set_status(text.clone(), Severity::Warn);
        self.scene.message = Some(text);
    }

    /// Notes that the scene is being encoded for `area` and returns what the
    /// encoding needs, when the image is wanted in an area it is not
    /// encoded (or being encoded) for: the loop hands it to a task.
    pub fn request_image(&mut self) -> Option<(Rect, Arc<DynamicImage>)> {
        let area = self.image_area_wanted()?;
        let image = self.scene.image.clone()?;
        self.scene.requested = Some(area);
        Some((area, image))
    }
}

pub(crate) fn draw(frame: &mut Frame, app: &App, area: Rect) {
    let t = &app.theme;
    let block = pane_block(app, Pane::Scene, None);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let caption = Line::from(highlighted(
        &app.task.text,
        &app.search,
        t.base,
        t.highlight,
    ));
    frame.render_widget(Paragraph::new(caption), Rect { height: 1, ..inner });
    let image_area = scene_image_area(area);
    let (encoded, note) = if !app.scene.enabled {
        (None, "image off (i shows it)")
    } else if app.scene.image.is_none() {
        (None, "no image for this task")
    } else {
        (app.scene.protocol.as_ref(), "drawing the image…")
    };
    scene_image::draw(
        frame,
        image_area,
        encoded,
        note,
        t.muted,
        app.overlay.is_some() || app.scene.hold,
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
