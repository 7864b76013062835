//! The scene image as every screen shows it (the workbench's Scene pane and
//! the annotation screen): read on a blocking task, encoded for exactly the
//! area it is drawn in, and a one-line note in that area until it is.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::Span;
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use super::graphics::{Drawing, Graphics};

/// An image encoded for the terminal, with the area it was encoded for.
pub type Encoded = (Rect, Box<Drawing>);

/// Why the scene image cannot be shown, in one line.
#[derive(Debug, thiserror::Error)]
pub enum SceneImageError {
    /// The file could not be read or decoded.
    #[error("{}: the scene image cannot be read ({error})", path.display())]
    Read {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        error: image::ImageError,
    },
    /// This terminal's graphics protocol cannot draw it.
    #[error(transparent)]
    Encode(#[from] ratatui_image::errors::Errors),
}

/// Reads a scene image (on a blocking task: decoding is slow).
pub fn read(path: &Path) -> Result<Arc<DynamicImage>, SceneImageError> {
    image::open(path)
        .map(Arc::new)
        .map_err(|error| SceneImageError::Read {
            path: path.to_path_buf(),
            error,
        })
}

/// Resizes and encodes `image` to fill `area` with the terminal's graphics
/// protocol: the slow part of showing it, done on a blocking task.
pub fn encode(
    graphics: &Graphics,
    image: &DynamicImage,
    area: Rect,
) -> Result<Encoded, SceneImageError> {
    let drawing = graphics.encode(image, area)?;
    Ok((area, Box::new(drawing)))
}

/// Draws the image in `area` when it is encoded for exactly that area, and
/// `note` (wrapped, in `style`) otherwise. With `held` (an overlay is open
/// over the screen), a picture the terminal paints is not sent until the
/// overlay has gone, so it never covers the overlay and is sent once after.
pub fn draw(
    frame: &mut Frame,
    area: Rect,
    encoded: Option<&Encoded>,
    note: &str,
    style: Style,
    held: bool,
) {
    match encoded {
        Some((at, drawing)) if *at == area => {
            drawing.render(area, frame.buffer_mut(), held);
        }
        _ => frame.render_widget(
            Paragraph::new(Span::styled(note, style)).wrap(Wrap { trim: true }),
            area,
        ),
    }
}
